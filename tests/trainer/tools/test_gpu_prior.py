"""trainer/tools/gpu_prior.sh on the CPU at test size: what a device call returns, and that the next call resumes it."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Optional

import pytest

from svbrdf.trainer import checkpoint as ckpt_io

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "trainer" / "tools" / "gpu_prior.sh"
TINY = ["--device", "cpu", "--threads", "1", "--size", "32", "--photo-size", "64", "--batch", "1",
        "--eval-every", "0", "--log-every", "2"]

pytestmark = pytest.mark.skipif(shutil.which("bash") is None or shutil.which("timeout") is None,
                                reason="needs bash and timeout")


def call(tmp_path: Path, out: str, resume: Optional[Path], *extra: str, preflight: str = "0",
         start: Optional[str] = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "OUT": str(tmp_path / out), "RUN": str(tmp_path / "run"),
           "PYTHON": sys.executable, "PREFLIGHT": preflight, "MINUTES": "5", "OMP_NUM_THREADS": "1",
           "WHEELS": str(tmp_path / "no-wheels")}  # not a local .whl/ (the device's wheels, for another Python)
    env.pop("RESUME", None), env.pop("START", None)
    if resume is not None:
        env["RESUME"] = str(resume)
    if start is not None:
        env["START"] = start
    return subprocess.run(["bash", str(SCRIPT), *extra], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=300)


@pytest.mark.integration
def test_a_chunk_returns_its_checkpoint_and_log_and_the_next_call_resumes_it(tmp_path):
    resume = tmp_path / "resume.pt"  # what the first chunk returns: absent before it
    missing = call(tmp_path, "out0", resume, *TINY, "--iters", "3")
    assert missing.returncode == 2 and "no such checkpoint" in missing.stdout and "Traceback" not in missing.stderr
    first = call(tmp_path, "out1", None, *TINY, "--iters", "3", preflight="1", start="--preset v2")
    assert first.returncode == 0, first.stdout + first.stderr
    assert "no RESUME: starting --preset v2" in first.stdout and "exit status 0" in first.stdout
    assert sorted(p.name for p in (tmp_path / "out1").iterdir()) == ["console.txt", "resume.pt", "train_log.jsonl"]
    assert (tmp_path / "out1" / "resume.pt").stat().st_size < 16 * 2 ** 20
    assert ckpt_io.load_checkpoint(tmp_path / "out1" / "resume.pt")["step"] == 3

    shutil.copy(tmp_path / "out1" / "resume.pt", resume)  # "commit" it; run/ stays, as on a warm machine
    second = call(tmp_path, "out2", resume, "--threads", "1", "--iters", "6")
    assert second.returncode == 0, second.stdout + second.stderr
    assert "resuming" in second.stdout and "at iteration 3/6" in second.stdout
    assert ckpt_io.load_checkpoint(tmp_path / "out2" / "resume.pt")["step"] == 6
    steps = [json.loads(line)["step"] for line in (tmp_path / "out2" / "train_log.jsonl").read_text().splitlines()]
    assert steps == [4, 6]  # this chunk's records only, realigned on log_every


#: The device call sends the checkout's tracked and untracked-not-ignored files, 64 MiB at most; this leaves room for
#: a resume file that grows and a chunk's logs.
TREE_BUDGET_MIB = 58.0


def test_the_working_tree_a_device_call_sends_stays_under_its_limit():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                            capture_output=True, check=True).stdout.split(b"\0")
    sizes = {}
    for name in filter(None, listed):
        p = ROOT / os.fsdecode(name)
        if p.is_file() and not p.is_symlink():
            sizes[p.relative_to(ROOT).as_posix()] = p.stat().st_size
    total = sum(sizes.values()) / 2 ** 20
    biggest = ", ".join(f"{k} ({v / 2 ** 20:.1f})" for k, v in sorted(sizes.items(), key=lambda kv: -kv[1])[:5])
    assert total < TREE_BUDGET_MIB, (
        f"the working tree is {total:.1f} MiB: a GPU device call sends at most 64 MiB (guarded at {TREE_BUDGET_MIB}); "
        f"gzip raw records (svbrdf-bench --report reads results.json.gz) or drop superseded artefacts; "
        f"largest: {biggest}")


@pytest.mark.integration
def test_without_resume_a_chunk_starts_the_shipped_recipe(tmp_path):
    """The default start is ``--recipe v2``; it fixes what the run learns, so the tiny flags are refused at once."""
    got = call(tmp_path, "out", None, "--size", "32")
    assert "no RESUME: starting --recipe v2" in got.stdout and got.returncode == 2
    assert "--recipe v2 fixes what the run learns; leave out --size" in got.stdout + got.stderr


V4 = ROOT / "trainer" / "tools" / "gpu_v4.sh"
V4_TINY = ["--device", "cpu", "--threads", "1", "--set", "photos.size=32", "--set", "photos.photo_size=64", "--set",
           "optim.batch=1", "--set", "monitor.eval_every=0", "--set", "monitor.log_every=2"]


def call_v4(tmp_path: Path, out: str, resume: Optional[Path], *extra: str, throughput: str = "0",
            export: str = "0") -> subprocess.CompletedProcess:
    env = {**os.environ, "OUT": str(tmp_path / out), "RUN": str(tmp_path / "run4"), "PYTHON": sys.executable,
           "THROUGHPUT": throughput, "THROUGHPUT_ARGS": "--device cpu --small --threads 1", "MINUTES": "5",
           "EXPORT": export, "OMP_NUM_THREADS": "1", "WHEELS": str(tmp_path / "no-wheels")}
    env.pop("RESUME", None)
    if resume is not None:
        env["RESUME"] = str(resume)
    return subprocess.run(["bash", str(V4), *extra], cwd=ROOT, env=env, capture_output=True, text=True, timeout=400)


@pytest.mark.integration
def test_the_v4_call_times_both_streams_trains_v4_exports_and_the_next_call_resumes(tmp_path):
    """The device command of issue 64 in its smallest mode on the CPU (what a dry run does, in about a minute):
    the throughput JSON of both streams, a v4 chunk on the device stream, the ONNX where onnx is installed, at most
    8 files under 16 MiB; then a second call resumes the first's checkpoint."""
    first = call_v4(tmp_path, "out1", None, *V4_TINY, "--iters", "2", throughput="1", export="1")
    assert first.returncode == 0, first.stdout[-3000:] + first.stderr[-3000:]
    out = tmp_path / "out1"
    names = sorted(p.name for p in out.iterdir())
    assert {"console.txt", "resume.pt", "train_log.jsonl", "gpu-throughput.json"} <= set(names), names
    assert len(names) <= 8 and all(p.stat().st_size < 16 * 2 ** 20 for p in out.iterdir())
    tp = json.loads((out / "gpu-throughput.json").read_text())
    assert set(tp["paths"]) == {"host", "device"} and tp["ratio"] > 0 and tp["device"]
    ckpt = ckpt_io.load_checkpoint(out / "resume.pt")
    assert ckpt["step"] == 2 and ckpt["recipe"]["name"] == "v4" and ckpt["prior_config"]["materials"]["stream"] == "device"
    try:
        import onnx  # noqa: F401
        import onnxscript  # noqa: F401
        import onnxruntime  # noqa: F401
        assert "prior_v4.onnx" in names and "exported" in first.stdout
    except ImportError:
        assert "no onnx/onnxscript/onnxruntime on this machine" in first.stdout

    shutil.copy(out / "resume.pt", tmp_path / "resume.pt")
    second = call_v4(tmp_path, "out2", tmp_path / "resume.pt", "--device", "cpu", "--threads", "1", "--iters", "4")
    assert second.returncode == 0, second.stdout[-3000:] + second.stderr[-3000:]
    assert "resuming" in second.stdout and "at iteration 2/4" in second.stdout
    assert ckpt_io.load_checkpoint(tmp_path / "out2" / "resume.pt")["step"] == 4
    missing = call_v4(tmp_path, "out3", tmp_path / "nothing.pt")
    assert missing.returncode == 2 and "no such checkpoint" in missing.stdout
