"""A library run killed with SIGKILL mid-run, then resumed: nothing lost, nothing duplicated (issue 17).

    python docs/benchmarks/batch/kill_resume.py LIBRARY KILL_AFTER -- <svbrdf-batch arguments without -o>

Starts ``svbrdf-batch ARGS -o LIBRARY``, SIGKILLs it once ``library.json`` records at least KILL_AFTER photos,
runs the same command again to the end, and checks: every photo has one record, "done" or "failed" (with its
error); every done photo has exactly one complete texture set folder (its sidecar names the photo's sha256); no
staging leftovers. Prints one JSON line with the counts and times.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

lib, kill_after, rest = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[sys.argv.index("--") + 1:]
bin_dir = Path(sys.executable).parent
cmd = [str(bin_dir / "svbrdf-batch"), *rest, "-o", str(lib), "-q"]
manifest = lib / "library.json"


def records():
    try:
        return json.loads(manifest.read_text(encoding="utf-8"))["photos"]
    except (OSError, ValueError, KeyError):
        return {}


t0 = time.perf_counter()
proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
while proc.poll() is None and len(records()) < kill_after:
    time.sleep(0.2)
killed_at = len(records())
if proc.poll() is None:
    proc.send_signal(signal.SIGKILL)
proc.wait()
first = time.perf_counter() - t0
assert proc.returncode == -signal.SIGKILL, f"the first run ended by itself (exit {proc.returncode})"
sets_after_kill = sorted(p.name for p in lib.iterdir() if p.is_dir() and not p.name.startswith(".")
                         and p.name != "thumbs")
t0 = time.perf_counter()
second = subprocess.run(cmd, capture_output=True, text=True)
resume = time.perf_counter() - t0
recs = records()
done = {n: r for n, r in recs.items() if r["status"] == "done"}
failed = {n: r for n, r in recs.items() if r["status"] != "done"}
folders = sorted(p.name for p in lib.iterdir() if p.is_dir() and not p.name.startswith(".") and p.name != "thumbs")
# The lock file and the (empty) staging folder stay by design; anything staged is a leftover.
leftovers = sorted(str(p.relative_to(lib)) for p in (lib / ".staging").glob("*")) if (lib / ".staging").is_dir() else []
leftovers += sorted(p.name for p in lib.iterdir() if p.name.startswith(".")
                    and p.name not in (".staging", ".svbrdf-batch.lock"))
problems = []
for name, r in done.items():
    side = lib / name / f"{name}.json"
    meta = json.loads(side.read_text(encoding="utf-8"))["meta"]["batch"]
    if meta["sha256"] != r["sha256"]:
        problems.append(f"{name}: sidecar hash differs")
if sorted(done) != folders:
    problems.append(f"folders {folders} != done {sorted(done)}")
if leftovers:
    problems.append(f"leftovers {leftovers}")
print(json.dumps({"records_when_killed": killed_at, "sets_on_disk_when_killed": len(sets_after_kill),
                  "first_run_s": round(first, 1), "resume_s": round(resume, 1), "resume_exit": second.returncode,
                  "photos": len(recs), "done": len(done), "failed": len(failed),
                  "failed_errors": {n: r.get("error") for n, r in failed.items()}, "problems": problems}))
sys.exit(1 if problems else 0)
