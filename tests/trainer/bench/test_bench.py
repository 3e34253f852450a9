"""svbrdf-bench: metrics on hand-made cases, case preparation, summary definitions, and the CLI end to end."""

import json
from pathlib import Path
import math

import numpy as np
import pytest

from svbrdf.trainer.camera_model import REALISTIC, Camera
from svbrdf.runtime.core.colour import linear_to_srgb
from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.images import read_image, write_image
from svbrdf.runtime.core.maps import Maps, encode_normal, normalize_normals
from svbrdf.runtime.core.render import ZHAO, RenderConfig, novel_lights, render, rerender_rmse
from svbrdf.trainer.bench import cases as bc
from svbrdf.trainer.bench import metrics as bm
from svbrdf.trainer.bench import report
from svbrdf.trainer.bench.cli import main, run_benchmark
from svbrdf.trainer.bench.methods import BenchOptions, torch_available

S = 48


def _maps(n=S, seed=0, diffuse=None, roughness=0.4, specular=0.05, normal=None):
    rng = np.random.default_rng(seed)
    d = rng.uniform(0.2, 0.6, (n, n, 3)) if diffuse is None else np.broadcast_to(diffuse, (n, n, 3))
    if normal is None:
        normal = np.zeros((n, n, 3))
        normal[..., 2] = 1.0
    return Maps(diffuse=np.array(d, np.float32), specular=np.full((n, n, 1), specular, np.float32),
                roughness=np.full((n, n, 1), roughness, np.float32), normal=np.array(normal, np.float32))


def _tilted(n, deg):
    t = math.radians(deg)
    normal = np.zeros((n, n, 3))
    normal[..., 1], normal[..., 2] = math.sin(t), math.cos(t)
    return normal


# ------------------------------------------------------------------------------------------------ metrics
def test_identical_maps_score_zero():
    m = _maps()
    out = bm.evaluate(m, gt=m)
    for key in bm.MAP_METRICS + ("rerender_rmse", "input_rmse"):
        assert out[key] == pytest.approx(0.0, abs=1e-6), key


def test_known_shifts_give_known_rmse():
    gt = _maps(diffuse=0.3, roughness=0.4, specular=0.04)
    pred = _maps(diffuse=0.4, roughness=0.6, specular=0.1)
    e = bm.map_errors(pred, gt)
    assert e["diffuse_rmse"] == pytest.approx(0.1, abs=1e-6)
    assert e["roughness_rmse"] == pytest.approx(0.2, abs=1e-6)
    assert e["specular_rmse"] == pytest.approx(0.06, abs=1e-6)
    assert e["diffuse_rmse_srgb"] == pytest.approx(float(linear_to_srgb(0.4) - linear_to_srgb(0.3)), abs=1e-4)
    assert e["specular_rmse_srgb"] == pytest.approx(float(linear_to_srgb(0.1) - linear_to_srgb(0.04)), abs=1e-4)
    assert e["normal_rmse"] == pytest.approx(0.0, abs=1e-7)


def test_angular_error_of_a_known_tilt():
    gt = _maps()
    pred = _maps(normal=_tilted(S, 30.0))
    e = bm.map_errors(pred, gt)
    assert e["normal_angle_deg"] == pytest.approx(30.0, abs=1e-3)
    # (n+1)/2 differs by (0, sin t / 2, (cos t - 1) / 2): RMSE over 3 channels = sqrt((2 - 2 cos t) / 12)
    assert e["normal_rmse"] == pytest.approx(math.sqrt((2 - 2 * math.cos(math.radians(30))) / 12), abs=1e-5)


def test_evaluation_lights_and_input_rmse():
    gt = _maps(seed=2)
    lights = bm.evaluation_lights()
    assert len(lights) == 10 and lights[-1] is None
    assert np.allclose(np.array(lights[:9]), novel_lights(ZHAO))
    photo = np.clip(render(gt, None, ZHAO), 0, 1)
    darker = Maps(**{**dict(gt.items()), "diffuse": gt.diffuse * 0.5})
    assert bm.evaluate(darker, photo=photo)["input_rmse"] == pytest.approx(
        rerender_rmse(darker, gt, [None]), abs=1e-6)
    assert bm.evaluate(darker, gt=gt)["rerender_rmse"] == pytest.approx(rerender_rmse(darker, gt, lights), abs=1e-9)
    # A photo with the flash's fall-off: explained exactly by maps without it only under a renderer with fall-off.
    falling = np.clip(render(gt, None, ZHAO.replace(falloff=True)), 0, 1)
    scores = bm.evaluate(gt, photo=falling)
    assert scores["input_rmse_falloff"] == pytest.approx(0.0, abs=1e-6) and scores["input_rmse"] > 0.01


# ------------------------------------------------------------------------------------------------ cases
def test_resize_maps_area_average_and_unit_normals():
    rng = np.random.default_rng(3)
    normal = normalize_normals(rng.normal(0, 0.3, (8, 8, 3)) + [0, 0, 1])
    m = Maps(diffuse=rng.uniform(0, 1, (8, 8, 3)), specular=rng.uniform(0, 1, (8, 8, 1)),
             roughness=rng.uniform(0, 1, (8, 8, 1)), normal=normal)
    small = bc.resize_maps(m, 4)
    assert small.shape == (4, 4)
    assert np.allclose(small.diffuse, m.diffuse.reshape(4, 2, 4, 2, 3).mean((1, 3)), atol=1e-6)
    assert np.allclose(small.roughness, m.roughness.reshape(4, 2, 4, 2, 1).mean((1, 3)), atol=1e-6)
    assert np.allclose(np.linalg.norm(small.normal, axis=-1), 1.0, atol=1e-5)


def test_simulate_photo_camera_and_clip():
    m = _maps(n=32, seed=4, specular=0.9, roughness=0.1)  # a highlight above 1
    clean = bc.simulate_photo(m)
    assert clean.max() == pytest.approx(1.0) and clean.min() >= 0.0
    assert np.allclose(clean, np.clip(render(m, None, ZHAO), 0, 1))
    noisy = bc.simulate_photo(m, camera=Camera(read=0.05), seed=7)
    assert not np.allclose(noisy, clean)
    assert np.array_equal(noisy, bc.simulate_photo(m, camera=Camera(read=0.05), seed=7))  # seeded
    q = bc.simulate_photo(m, camera=Camera(quantize=True))
    codes = linear_to_srgb(q) * 255
    assert np.abs(codes - np.round(codes)).max() < 0.02
    with pytest.raises(ValueError):
        bc.simulate_photo(m, renderer="povray")


def test_prepare_case_realistic_and_clean(tmp_path):
    from svbrdf.trainer.bench.datasets import find_cases

    _make_data(tmp_path)
    (case,) = [c for c in find_cases(tmp_path) if c.kind == "gt"]
    real = bc.prepare_case(case, 32, renderer="ours")
    again = bc.prepare_case(case, 32, renderer="ours")
    assert np.array_equal(real.photo, again.photo)  # the camera and the noise are seeded by the case name
    sim = real.simulation
    assert sim["setting"] == "realistic" and sim["renderer"] == "ours" and sim["camera"]["quantize"]
    assert sim["render_config"]["falloff"] and sim["render_config"]["geometry"] == "smith"
    lo, hi = REALISTIC["ev"]
    assert lo <= sim["camera"]["ev"] <= hi
    clean = bc.prepare_case(case, 32, realistic=False, renderer="ours")
    assert clean.simulation["setting"] == "clean" and not clean.simulation["camera"]["quantize"]
    assert np.allclose(clean.photo, np.clip(render(clean.gt, None, ZHAO), 0, 1))
    assert not np.allclose(real.photo, clean.photo, atol=0.01)
    assert bc.resolve_renderer("auto") in ("ours", "mitsuba")


def test_render_mitsuba_matches_our_physical_settings():
    pytest.importorskip("mitsuba")
    n = 32
    yy, xx = np.mgrid[0:n, 0:n] / n
    normal = normalize_normals(np.stack([0.3 * np.sin(9 * xx), 0.2 * np.cos(7 * yy), np.ones_like(xx)], -1))
    m = Maps(diffuse=np.stack([0.2 + 0.6 * xx, 0.3 + 0.5 * yy, np.full_like(xx, 0.3)], -1),
             specular=np.full((n, n, 1), 0.3), roughness=(0.3 + 0.5 * xx)[..., None], normal=normal)
    light = (0.3, -0.2, 1.2)
    ours = render(m, light, ZHAO.replace(falloff=True, geometry="smith", fresnel="none"))
    ref = bc.render_mitsuba(m, light, ZHAO, spp=32)
    assert bm.rmse(ours, ref) < 0.01  # Monte Carlo noise and bilinear texture lookups
    assert bm.rmse(ours, ref) < 0.3 * bm.rmse(ours[::-1], ref)  # an upside-down texture would be caught


def _case(name):
    from pathlib import Path

    from svbrdf.trainer.bench.datasets import Case

    return Case(name=name, path=Path(name + ".png"), kind="photo", format="photo")


def test_select_cases():
    cs = [_case(n) for n in ("a/x1", "a/x2", "b/y1")]
    assert [c.name for c in bc.select_cases(cs, None)] == ["a/x1", "a/x2", "b/y1"]
    assert [c.name for c in bc.select_cases(cs, "2")] == ["a/x1", "a/x2"]
    assert [c.name for c in bc.select_cases(cs, "b/*")] == ["b/y1"]
    assert [c.name for c in bc.select_cases(cs, "b/y1, x1.png")] == ["a/x1", "b/y1"]  # case or file name
    with pytest.raises(SvbrdfError):
        bc.select_cases(cs, "zzz*")


# ------------------------------------------------------------------------------------------------ summary
def _rec(method, preset, it, seconds, err, case="c1", **kw):
    return {"case": case, "source": case, "kind": "synthetic", "method": method, "preset": preset,
            "iterations": it, "seconds": seconds, "train_seconds": seconds, "eval_seconds": 0.0,
            "truncated": False, "rerender_rmse": err, "input_rmse": err, "burn_in": 0.1, **kw}


def test_aggregate_and_summary_definitions():
    recs = [
        _rec("finetune", "paper", 0, 10.0, 0.5), _rec("finetune", "paper", 100, 100.0, 0.2),
        _rec("finetune", "fast", 0, 1.0, 0.5), _rec("finetune", "fast", 100, 10.0, 0.25),
        _rec("finetune", "fast", 300, 20.0, 0.19),
        _rec("scratch", "fast", 0, 1.0, 0.6), _rec("scratch", "fast", 300, 30.0, 0.3),
        _rec("preview", None, None, 0.5, 0.4),
    ]
    s = report.summarize(recs, ["paper", "fast"])
    assert s["speedup_vs_paper"] == pytest.approx(100.0 / 20.0)  # fast first reaches 0.2 at 20 s
    # 0.3 is crossed between fast's points (1 s, 0.5) and (10 s, 0.25): at 1 + 9 * 0.2 / 0.25 = 8.2 s.
    assert s["details"]["two_stage_speedup"]["fast"]["finetune_seconds"] == pytest.approx(8.2)
    assert s["two_stage_speedup"] == pytest.approx(30.0 / 8.2)  # paper has no scratch run: fast is the reference
    levels = {lv["level"]: lv for lv in s["details"]["two_stage_speedup"]["fast"]["levels"]}
    assert levels[1.0]["speedup"] == pytest.approx(s["two_stage_speedup"])
    # 0.3 * 1.5 = 0.45: scratch crosses it between (1 s, 0.6) and (30 s, 0.3) at 1 + 29 * 0.15 / 0.3 = 15.5 s,
    # the fine-tune between (1 s, 0.5) and (10 s, 0.25) at 1 + 9 * 0.05 / 0.25 = 2.8 s.
    assert levels[1.5]["speedup"] == pytest.approx(15.5 / 2.8)
    assert levels[2.0]["finetune_seconds"] == pytest.approx(1.0)  # 0.6: both already there at their first point
    assert s["preview_time_ratio"] == pytest.approx(0.5 / 100.0)  # against finetune paper, its last point
    assert s["preview_error_ratio"] == pytest.approx(0.4 / 0.2)
    assert s["early_stop_saving"] is None  # no run facts recorded

    rows = report.aggregate(recs + [_rec("finetune", "paper", 100, 300.0, 0.4, case="c2")])
    row = next(r for r in rows if r["method"] == "finetune" and r["preset"] == "paper" and r["iterations"] == "100")
    assert row["n"] == 2
    assert row["seconds"]["mean"] == pytest.approx(200.0) and row["seconds"]["std"] == pytest.approx(100.0)
    assert row["rerender_rmse"]["min"] == pytest.approx(0.2) and row["rerender_rmse"]["max"] == pytest.approx(0.4)


def test_speedup_vs_paper_needs_the_paper_burn_in_too():
    recs = [_rec("finetune", "paper", 16, 200.0, 0.3, burn_in=0.5),
            _rec("finetune", "fast", 0, 1.0, 0.25, burn_in=0.9),   # error reached, burn-in not yet
            _rec("finetune", "fast", 20, 4.0, 0.2, burn_in=0.4)]
    s = report.summarize(recs, ["fast", "paper"])
    assert s["speedup_vs_paper"] == pytest.approx(200.0 / 4.0)
    ref = s["details"]["speedup_vs_paper"]["reference"]
    assert ref["burn_in"] == pytest.approx(0.5) and ref["error"] == pytest.approx(0.3)
    never = [recs[0], _rec("finetune", "fast", 0, 1.0, 0.25, burn_in=0.9)]
    assert report.summarize(never, ["fast", "paper"])["speedup_vs_paper"] is None


@pytest.mark.integration
def test_methods_restricted_to_presets(tmp_path):
    pytest.importorskip("torch")
    data = tmp_path / "data"
    _make_data(data)
    opts = BenchOptions(iters=[0, 1, 3], repeats=1)
    doc = run_benchmark(data, methods=["finetune:tiny@1", "scratch:tiny"], presets=["tiny", "fast"],
                        size=32, cases="gt/*", opts=opts, quick=True)
    assert doc["errors"] == []
    assert {(r["method"], r["preset"]) for r in doc["records"]} == {("finetune", "tiny"), ("scratch", "tiny")}
    its = lambda m: sorted(r["iterations"] for r in doc["records"] if r["method"] == m)  # noqa: E731
    assert its("finetune") == [0, 1] and its("scratch") == [0, 1, 3]
    with pytest.raises(SvbrdfError, match="iteration cap"):
        run_benchmark(data, methods=["finetune@many"], presets=["tiny"], size=32, cases="gt/*", opts=opts)


def test_early_stop_saving_from_run_facts():
    run = {"run_train_seconds": 100.0, "plateau": {"step": 150, "train_seconds": 40.0}}
    recs = [_rec("finetune", "fast", 100, 30.0, 0.3, run=run), _rec("finetune", "fast", 300, 100.0, 0.25, run=run)]
    s = report.summarize(recs, ["fast"])
    assert s["early_stop_saving"] == pytest.approx(0.6)
    assert s["details"]["early_stop"]["fast"]["early_stop_error_ratio"] == pytest.approx(1.0)  # first point >= 150


# ------------------------------------------------------------------------------------------------ CLI
def _make_data(root):
    """A Des19-style 4-panel file (normal, diffuse, roughness, specular) and a small non-square photo."""
    n = 32
    rng = np.random.default_rng(5)
    yy, xx = np.mgrid[0:n, 0:n] / n
    normal = normalize_normals(np.stack([0.2 * np.sin(12 * xx), 0.2 * np.cos(9 * yy), np.ones_like(xx)], -1))
    panels = [encode_normal(normal), rng.uniform(0.1, 0.7, (n, n, 3)),
              np.repeat(0.3 + 0.4 * xx[..., None], 3, -1), np.full((n, n, 3), 10 / 255)]
    (root / "gt").mkdir(parents=True)
    write_image(root / "gt" / "material.png", np.concatenate(panels, axis=1), bits=8)
    photo = np.clip(render(_maps(n=40, seed=6, specular=0.3, roughness=0.3), None, ZHAO)[:, :36], 0, 1)
    write_image(root / "photo (1).png", photo, bits=8, srgb_encode=True)


@pytest.mark.integration
def test_cli_quick_writes_every_output(tmp_path, capsys):
    data, out = tmp_path / "data", tmp_path / "out"
    _make_data(data)
    code = main(["--quick", "--data", str(data), "--out", str(out), "--size", "32", "--iters", "0,1",
                 "--model", str(tmp_path / "missing.onnx")])
    assert code == 0
    # stderr is not a terminal here: the runs' progress is plain lines ending with the last run, no bar
    err = capsys.readouterr().err
    runs = [line.split(" [")[0] for line in err.splitlines() if line.startswith("svbrdf-bench: ")]
    total = runs[-1].split("/")[1]
    assert runs[0] == f"svbrdf-bench: 1/{total}" and runs[-1] == f"svbrdf-bench: {total}/{total}"
    assert "\r" not in err and "| it 1 |" in err  # and the evaluation points' lines
    for name in ("results.md", "pareto.png", "results.json", "summary.json"):
        assert (out / name).is_file(), name
    assert read_image(out / "pareto.png").shape[2] == 3
    doc = json.loads((out / "results.json").read_text())
    assert doc["schema"] == report.SCHEMA
    assert {"command", "date", "machine", "settings", "cases", "skipped", "errors", "records", "summary"} <= set(doc)
    assert doc["errors"] == []
    assert {c["kind"] for c in doc["cases"]} == {"synthetic", "photo"}
    skipped = {s["method"]: s["reason"] for s in doc["skipped"]}
    assert "preview" in skipped and "missing.onnx" in skipped["preview"]
    methods = {r["method"] for r in doc["records"]}
    assert {"baseline", "finetune", "scratch"} <= methods
    base = {"case", "source", "kind", "method", "preset", "iterations", "seconds", "train_seconds", "eval_seconds",
            "truncated", "input_rmse", "burn_in", "run"}
    for r in doc["records"]:
        assert base <= set(r)
        if r["kind"] == "synthetic":
            assert set(bm.MAP_METRICS) | {"rerender_rmse"} <= set(r)
    assert sorted(r["iterations"] for r in doc["records"] if r["method"] == "scratch") == [0, 0, 1, 1]
    summary = json.loads((out / "summary.json").read_text())
    assert {"speedup_vs_paper", "two_stage_speedup", "preview_time_ratio", "preview_error_ratio",
            "early_stop_saving"} <= set(summary)
    md = (out / "results.md").read_text()
    assert "svbrdf-bench --quick" in md and "pareto.png" in md and "preview" in md
    # Outputs exist now: a second run refuses without --force, before doing any work.
    assert main(["--quick", "--data", str(data), "--out", str(out), "--quiet"]) == 2
    # --report re-derives the outputs from the recorded runs: same records, same summary, the command noted.
    (out / "summary.json").unlink()
    assert main(["--report", str(out / "results.json"), "--quiet"]) == 0
    assert json.loads((out / "summary.json").read_text()) == summary
    assert "Report re-derived from the recorded runs" in (out / "results.md").read_text()
    assert json.loads((out / "results.json").read_text())["records"] == doc["records"]
    # Several runs merge into one report (e.g. one preset per core).
    other = json.loads(json.dumps(doc))
    for r in other["records"]:
        r["preset"] = "fast" if r["preset"] else r["preset"]
    other["settings"]["presets"] = ["fast"]
    (tmp_path / "other.json").write_text(json.dumps(other))
    assert main(["--report", str(out / "results.json"), "--report", str(tmp_path / "other.json"), "--quiet"]) == 2
    merged_out = tmp_path / "merged"
    assert main(["--report", str(out / "results.json"), "--report", str(tmp_path / "other.json"),
                 "--out", str(merged_out), "--quiet"]) == 0
    merged = json.loads((merged_out / "results.json").read_text())
    assert len(merged["records"]) == 2 * len(doc["records"]) and merged["settings"]["presets"] == ["tiny", "fast"]
    assert len(merged["cases"]) == len(doc["cases"]) and len(merged["merged_from"]) == 2
    # A run's folder stands for its results.json; a missing or broken one is a one-line error, not a traceback.
    assert main(["--report", str(out), "--report", str(tmp_path / "other.json"), "--out", str(merged_out),
                 "--force", "--quiet"]) == 0
    assert json.loads((merged_out / "results.json").read_text())["records"] == merged["records"]
    # A gzipped results.json (how the repository keeps large raw records), or its folder, reads the same.
    import gzip

    packed = tmp_path / "packed"
    packed.mkdir()
    with gzip.open(packed / "results.json.gz", "wt", encoding="utf-8") as f:
        f.write((out / "results.json").read_text())
    for src in (packed, packed / "results.json.gz"):
        assert main(["--report", str(src), "--out", str(tmp_path / "unpacked"), "--force", "--quiet"]) == 0
        assert json.loads((tmp_path / "unpacked" / "results.json").read_text())["records"] == doc["records"]
    (tmp_path / "broken.json").write_text("{")
    capsys.readouterr()
    for bad in (tmp_path / "missing", tmp_path / "broken.json"):
        assert main(["--report", str(bad), "--out", str(merged_out), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(bad) in err and "Traceback" not in err


@pytest.mark.integration
def test_time_budget_truncates_without_extrapolating(tmp_path):
    pytest.importorskip("torch")
    data = tmp_path / "data"
    _make_data(data)
    opts = BenchOptions(iters=[0, 100000], time_budget=0.3, repeats=1)
    doc = run_benchmark(data, methods=["scratch"], presets=["tiny"], size=32, cases="gt/*", opts=opts)
    recs = doc["records"]
    its = [r["iterations"] for r in recs]
    assert its == sorted(set(its)) and its[-1] < 100000  # stopped where it was: no point beyond, none invented
    last = recs[-1]
    assert last["truncated"] is True and last["train_seconds"] > 0.3
    assert not any(r["truncated"] for r in recs[:-1])
    assert recs[0]["iterations"] == 0  # evaluated at 0 (flagged truncated only if the setup ate the budget)


def test_bad_input_is_a_clear_error(tmp_path, capsys):
    assert main(["--data", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["--data", str(tmp_path), "--out", str(tmp_path / "o"), "--methods", "magic", "--quiet"]) == 2
    assert main(["--data", str(tmp_path), "--out", str(tmp_path / "o"), "--set", "lr", "--quiet"]) == 2
    if torch_available():
        assert main(["--data", str(tmp_path), "--out", str(tmp_path / "o"), "--set", "bogus=1", "--quiet"]) == 2
        assert "bogus" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["--data", str(tmp_path / "empty"), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    assert "no image found" in capsys.readouterr().err


@pytest.mark.integration
def test_shared_data_one_case(shared_data, tmp_path):
    out = tmp_path / "out"
    code = main(["--data", str(shared_data), "--cases", "1", "--methods", "baseline", "--size", "64",
                 "--out", str(out), "--quiet"])
    assert code == 0
    doc = json.loads((out / "results.json").read_text())
    assert len(doc["cases"]) == 1 and doc["records"]


@pytest.mark.slow
def test_preview_method_with_an_exported_model(tmp_path):
    pytest.importorskip("onnxscript")
    import torch

    from svbrdf.export.onnx import export_generator
    from svbrdf.trainer.config import resolve
    from svbrdf.trainer.models import Generator

    torch.manual_seed(0)
    model = tmp_path / "tiny.onnx"
    export_generator(Generator(resolve("tiny").generator), model, sizes=((32, 32),))
    data = tmp_path / "data"
    _make_data(data)
    doc = run_benchmark(data, methods=["preview"], size=32, opts=BenchOptions(model=str(model), repeats=2))
    assert not doc["skipped"] and not doc["errors"]
    assert len(doc["records"]) == 2 and all(r["eval_seconds"] > 0 for r in doc["records"])
    assert doc["records"][0]["run"]["model"] == str(model)


def test_markdown_early_stop_table_with_and_without():
    run = {"run_train_seconds": 100.0, "plateau": {"step": 150, "train_seconds": 40.0},
           "evals": [{"step": 150, "train_seconds": 40.0, "render_l1": 0.1, "map_change": None}]}
    recs = [_rec("finetune", "fast", 100, 30.0, 0.3, run=run), _rec("finetune", "fast", 200, 60.0, 0.26, run=run),
            _rec("finetune", "fast", 300, 100.0, 0.25, run=run)]
    lines = report._early_stop_table(recs)
    assert "| fast | c1 | 150 | 40 / 100 | 60 % | 0.26 / 0.25 |" in lines
    assert report._early_stop_table([_rec("finetune", "fast", 100, 30.0, 0.3)]) == []  # no history recorded


def test_the_run_names_the_model_it_measured(tmp_path):
    from svbrdf.trainer.bench.cli import _describe_model

    packaged = _describe_model(None)
    manifest = json.loads((Path(__file__).resolve().parents[3] / "models" / "manifest.json").read_text())
    assert packaged["file"] == manifest["file"] and packaged["source"] == "packaged"
    assert packaged["sha256"] == manifest["sha256"]
    assert _describe_model(tmp_path / "missing.onnx") is None
