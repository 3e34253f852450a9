"""The study scripts still in use (docs/lab/): each runs end to end on a tiny input, a 64 px ground-truth set made
here and two procedural materials, with the packaged model. Nothing is asserted about the figures, only that the
scripts still run against today's package and write what their docstrings say."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

from svbrdf.runtime.io.images import write_image  # noqa: E402
from svbrdf.runtime.core.maps import encode_normal  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
LAB = ROOT / "docs" / "lab"
MODEL = ROOT / "models" / "svbrdf_prior_v2.onnx"
N = 64


def _des19_set(path: Path) -> None:
    """One Des19-layout ground-truth file (normal, diffuse, roughness, specular panels) with some relief."""
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:N, 0:N] / N
    h = 0.5 * np.sin(2 * np.pi * 3 * xx) * np.cos(2 * np.pi * 2 * yy)
    gy, gx = np.gradient(h)
    normal = np.stack([-gx * 4, gy * 4, np.ones_like(h)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    diffuse = np.clip(0.4 + 0.1 * rng.standard_normal((N, N, 3)), 0, 1)
    grey = lambda v: np.repeat(np.full((N, N, 1), v), 3, -1)  # noqa: E731
    panels = [encode_normal(normal), diffuse, grey(0.5), grey(0.04)]
    path.parent.mkdir(parents=True, exist_ok=True)
    write_image(path, np.concatenate(panels, 1).astype(np.float32), bits=8)


def _run(script: str, tmp_path: Path, *args: str) -> dict:
    data = tmp_path / "data"
    _des19_set(data / "Des19" / "1_tiny.png")
    out = tmp_path / "out.json"
    env = {**os.environ, "DATA": str(data), "SIZE": str(N), "OMP_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, str(LAB / script), str(MODEL), str(out), *args], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(out.read_text())


@pytest.mark.integration
def test_relief_gap_probe_runs_on_a_tiny_input(tmp_path):
    doc = _run("relief_gap_probe.py", tmp_path, "2", "0.5")
    assert len(doc["A"]) == len(doc["B"]) == 1 and len(doc["C"]) == len(doc["D"]) == 2
    assert len(doc["summary"]) == 4 and all(np.isfinite(r["angle"]) for r in doc["B"] + doc["D"])


@pytest.mark.integration
def test_normal_bound_runs_on_a_tiny_input(tmp_path):
    doc = _run("normal_bound.py", tmp_path)
    assert [r["case"] for r in doc["rows"]] == ["Des19/1_tiny"]
    assert set(doc["rows"][0]["angle"]) == {"0.0", "0.5", "1.0", "1.5", "2.0", "3.0", "4.0", "6.0"}


@pytest.mark.integration
def test_network_size_probe_runs_on_a_tiny_input(tmp_path):
    data = tmp_path / "data"
    _des19_set(data / "Des19" / "1_tiny.png")
    out = tmp_path / "out.json"
    env = {**os.environ, "DATA": str(data), "SIZE": str(N), "SPLIT": "all", "CASES": "*", "OMP_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, str(LAB / "network_size_probe.py"), str(MODEL), str(out), "32,64"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    doc = json.loads(out.read_text())
    assert [row["size"] for row in doc["rows"]] == ["shipped", 32, 64]
    assert all(np.isfinite(row[k]) for row in doc["rows"] for k in ("burn_in", "detail_diffuse", "gt_detail_diffuse"))
    assert [m["size"] for m in doc["summary"]] == ["shipped", 32, 64] and "| all | synthetic | 32 | 1 |" in r.stdout


def test_the_network_size_probes_detail_ratio():
    """About 1 for a stationary texture, well below 1 where the texture under the highlight is flattened."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("network_size_probe", LAB / "network_size_probe.py")
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    field = np.random.default_rng(2).random((256, 256)) * 0.5
    assert 0.9 < probe.detail_ratio(field, (128, 128), 256) < 1.1
    d = np.hypot(*np.mgrid[0:256, 0:256] + 0.5 - 128) / 256
    hazy = np.where(d < 0.2, 0.25 + 0.2 * (field - 0.25), field)
    assert 0.15 < probe.detail_ratio(hazy, (128, 128), 256) < 0.3


def test_the_readme_table_of_a_results_json(tmp_path):
    rec = dict(case="a", kind="synthetic", seconds=1.0, rerender_rmse=0.1, grazing_rmse=0.2, diffuse_rmse=0.3,
               specular_rmse=0.4, roughness_rmse=0.5, normal_angle_deg=9.123, burn_in=0.6)
    photo = dict(case="b/00", kind="photo", seconds=3.0, capture_rmse=0.15, capture_ssim=0.5, burn_in=0.9,
                 foreign_colour=4.25)
    records = [dict(r, method="preview", preset=None, iterations=None) for r in (rec, photo)]
    records += [dict(r, method="finetune", preset="fast", iterations=150) for r in (rec, photo)]
    (tmp_path / "results.json").write_text(json.dumps({"records": records}))
    r = subprocess.run([sys.executable, str(ROOT / "docs" / "results" / "table.py"), str(tmp_path / "results.json")],
                       capture_output=True, text=True, check=True)
    lines = r.stdout.splitlines()
    assert lines[0].startswith("| method | seconds (n 2) | capture relit ↓ (n 1) |") and len(lines) == 4
    assert lines[2] == "| preview | 2 | 0.15 | 0.5 | 0.1 | 0.2 | 0.3 | 0.4 | 0.5 | 9.12 | 0.6 | 0.9 | 4.25 |"
    assert lines[3].startswith("| generator fine-tune (`fast`) 150 | 2 |")


def _photo(path: Path, side: int = 96) -> Path:
    """A small flash-like photo: a textured surface brighter at the centre (linear RGB written as 8-bit sRGB)."""
    rng = np.random.default_rng(1)
    yy, xx = np.mgrid[0:side, 0:side] / side
    light = 0.3 + 0.6 * np.exp(-((xx - 0.5) ** 2 + (yy - 0.5) ** 2) / 0.05)
    img = np.clip(light[..., None] * (0.5 + 0.2 * rng.random((side, side, 3))), 0, 1).astype(np.float32)
    write_image(path, img, bits=8)
    return path


def _script(args, tmp_path: Path) -> None:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, *map(str, args)], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]


@pytest.mark.integration
def test_the_speed_stage_timer_runs_on_a_tiny_photo(tmp_path):
    out = tmp_path / "stages.json"
    _script([LAB / "speed" / "stages.py", _photo(tmp_path / "p.png"), "--threads", "1", "--repeats", "1",
             "--json", out], tmp_path)
    doc = json.loads(out.read_text())
    assert "load" in doc and doc["result"]


@pytest.mark.integration
def test_the_guided_path_agreement_script_runs_on_a_tiny_photo(tmp_path):
    out = tmp_path / "agreement.json"
    _script([LAB / "speed" / "agreement.py", _photo(tmp_path / "p.png"), "--max-size", "4096", "--json", out],
            tmp_path)
    assert json.loads(out.read_text())


@pytest.mark.integration
def test_the_size_benchmark_runs_both_versions_on_a_tiny_photo(tmp_path):
    """docs/results/sizes.py with ``--before HEAD``: both versions (HEAD and the working tree, "now") run, taking
    turns; the table, the records and the plot are written, and its git worktree is gone afterwards."""
    if subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True).returncode:
        pytest.skip("not a git checkout")
    out = tmp_path / "sizes"
    _script([ROOT / "docs" / "results" / "sizes.py", "--before", "HEAD", "--photo", _photo(tmp_path / "p.png"),
             "--sizes", "64", "--repeats", "1", "--out", out], tmp_path)
    doc = json.loads((out / "sizes.json").read_text())
    row = doc["rows"][0]
    assert row["label"] == "64" and row["versions"]["HEAD"]["seconds"] > 0 and row["versions"]["now"]["seconds"] > 0
    assert {r["version"] for r in doc["records"]} == {"HEAD", "now"} and all(r["rc"] == 0 for r in doc["records"])
    assert (out / "sizes.md").read_text().startswith("| photo |") and (out / "sizes.png").stat().st_size > 0
    worktrees = subprocess.run(["git", "-C", str(ROOT), "worktree", "list"], capture_output=True, text=True).stdout
    assert "svbrdf-sizes-" not in worktrees
