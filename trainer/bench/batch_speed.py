"""Throughput of ``svbrdf-batch``: one photo at a time vs the local process pool vs ``--ray`` on a local instance.

::

    python -m svbrdf.trainer.bench.batch_speed --out docs/benchmarks/batch [--repeats 1] [--force] [-- extra options]

The photos are the shared real photos (``../shared/data``: the 54 of :data:`PHOTO_GLOBS`), listed in one list
file. Each engine runs the real command in a fresh process into a fresh library (a temporary folder), the engines
taking turns ``--repeats`` times, so a load on the shared machine touches all of them alike. Measured: the wall
time of the whole command (start-up, model load, pool or Ray start, every photo, the contact sheet), and photos
per minute = photos / wall time. Writes ``results.md`` and ``results.json`` in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import List, Optional

from svbrdf.runtime.io.files import atomic_write

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data"
#: The shared real photos, relative to the data folder.
PHOTO_GLOBS = ("deschaintre18-real/*.png", "xuejiao-lgd/dataset/*.png", "weiyi-auxrender/test_data/real/*",
               "henzler-flash/test/*/*", "guo-svbrdf-diff-renderer/bath_tile/*.png")
ENGINES = {
    "one at a time": ["--workers", "1"],
    "local pool": [],
    "ray (local)": ["--ray"],
}


def main(argv: Optional[List[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="batch_speed", description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--data", type=Path, default=SHARED)
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument("--glob", action="append", metavar="PATTERN",
                   help="photos relative to --data (repeatable; default: the 54 of PHOTO_GLOBS)")
    p.add_argument("--force", action="store_true")
    p.add_argument("extra", nargs="*", help="more svbrdf-batch options (after --)")
    args = p.parse_args(argv)
    if not args.data.is_dir():
        print(f"batch_speed: error: no shared data at {args.data}", file=sys.stderr)
        return 1
    photos = sorted(str(f) for g in (args.glob or PHOTO_GLOBS) for f in args.data.glob(g) if f.is_file())
    args.out.mkdir(parents=True, exist_ok=True)
    runs = []
    with tempfile.TemporaryDirectory(prefix="batch-speed-") as tmp:
        listing = Path(tmp) / "photos.txt"
        listing.write_text("\n".join(photos) + "\n")
        for rep in range(args.repeats):
            for engine, flags in ENGINES.items():
                lib = Path(tmp) / f"lib-{rep}-{len(runs)}"
                cmd = [sys.executable, "-m", "svbrdf.runtime.cli.batch", f"@{listing}", "-o", str(lib), "-q",
                       *flags, *args.extra]
                start = time.perf_counter()
                res = subprocess.run(cmd, capture_output=True, text=True)
                wall = time.perf_counter() - start
                manifest = json.loads((lib / "library.json").read_text())["photos"]
                done = sum(r["status"] == "done" for r in manifest.values())
                runs.append({"engine": engine, "flags": flags, "repeat": rep, "wall_s": round(wall, 2),
                             "photos": len(photos), "done": done, "exit": res.returncode,
                             "photos_per_min": round(60 * done / wall, 1), "stderr": res.stderr[-500:]})
                print(f"{engine}: {done}/{len(photos)} in {wall:.1f} s = {60 * done / wall:.1f} photos/min",
                      file=sys.stderr)
                shutil.rmtree(lib, ignore_errors=True)
    doc = {"command": "python -m svbrdf.trainer.bench.batch_speed " + " ".join(argv or sys.argv[1:]),
           "machine": {"cpus": len(os.sched_getaffinity(0)), "platform": platform.platform(),
                       "load_before": os.getloadavg()}, "runs": runs}
    with atomic_write(args.out / "results.json", force=args.force) as t:
        t.write_text(json.dumps(doc, indent=1) + "\n")
    lines = ["# svbrdf-batch throughput", "", f"`{doc['command']}` on {doc['machine']['cpus']} CPUs "
             f"(load average before the run {doc['machine']['load_before'][0]:.1f}); {len(photos)} shared real photos, "
             f"previews with the default options.", "",
             "| engine | flags | repeat | photos done | wall s | photos / min |", "|---|---|---|---|---|---|"]
    for r in runs:
        lines.append(f"| {r['engine']} | `{' '.join(r['flags']) or '(default)'}` | {r['repeat']} | "
                     f"{r['done']}/{r['photos']} | {r['wall_s']} | {r['photos_per_min']} |")
    with atomic_write(args.out / "results.md", force=args.force) as t:
        t.write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
