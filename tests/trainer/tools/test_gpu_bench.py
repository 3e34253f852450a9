"""trainer/tools/gpu_bench.sh on the CPU: job lines in parallel, globs kept for the bench, one archive back."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "trainer" / "tools" / "gpu_bench.sh"

pytestmark = [pytest.mark.skipif(shutil.which("bash") is None or shutil.which("timeout") is None,
                                 reason="needs bash and timeout"),
              pytest.mark.integration]  # runs the device script in bash


def test_runs_come_back_as_one_archive_and_failures_are_counted(tmp_path):
    jobs = tmp_path / "jobs.txt"
    # `*wood*` would match nothing in the repository root: it must reach the bench unexpanded to select the case.
    jobs.write_text("# a comment, then a blank line\n\n"
                    "ok --data runtime/examples --methods baseline --cases *wood* --size 32 --repeats 1 --quiet\n"
                    "bad --data runtime/examples --methods nosuch\n")
    out = tmp_path / "out"
    env = {**os.environ, "OUT": str(out), "PYTHON": sys.executable, "LIMIT_S": "240",
           "WHEELS": str(tmp_path / "none")}  # not a local .whl/ (the device's wheels, for another Python)
    done = subprocess.run(["bash", str(SCRIPT), str(jobs)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 1, done.stdout + done.stderr  # one run of two failed
    assert sorted(p.name for p in out.iterdir()) == ["console.txt", "runs.tar.gz"]
    with tarfile.open(out / "runs.tar.gz") as tar:
        names = set(tar.getnames())
        assert {"ok/results.json", "ok.txt", "bad.txt"} <= names
        assert "unknown method" in tar.extractfile("bad.txt").read().decode()
        assert b"carved_wood" in tar.extractfile("ok/results.json").read()
