"""Wall time of the user's final-quality command, ``svbrdf-preview PHOTO --refine``, on real photos.

Run as ``python -m svbrdf.trainer.bench.final [--size 1024] [--cases GLOBS] [--modes auto,fixed]``. Each selected
real photo of ``--data`` is centre-cropped and area-averaged to ``--size`` (as :mod:`svbrdf.trainer.bench.cases`
prepares photos), written as a 16-bit sRGB PNG, and given to the installed ``svbrdf-preview`` in a subprocess:
``--refine --quality auto`` (mode ``auto``: the default fine-tune length with early stopping, or no fine-tune at
all when the preview already explains the photo) and ``--refine`` (mode ``fixed``: the preset's full fine-tune).
The wall time covers everything the user waits for: start-up, reading, the preview, the fine-tune, the full-photo
prediction, the relit panel and writing the texture set. Modes alternate per photo so that machine load affects
them alike. Writes ``results.md`` and ``results.json`` to ``--out`` (default
``docs/benchmarks/final-<size>/``).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.images import write_image

from .cases import load_cases
from .common import default_data, repo_root, results_paths, write_results

MODES = {"auto": ["--refine", "--quality", "auto"], "fixed": ["--refine"]}


def time_final(photo: Path, out: Path, mode: str, threads: Optional[int]) -> Dict[str, Any]:
    """Run ``svbrdf-preview`` once on ``photo``; returns wall seconds and the refine facts of its sidecar."""
    cmd = [sys.executable, "-m", "svbrdf.runtime.cli.preview", str(photo), "-o", str(out), "--force", "-q", *MODES[mode]]
    if threads:
        cmd += ["--threads", str(threads)]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise SvbrdfError(f"{photo.name} ({mode}): svbrdf-preview exited {done.returncode}: "
                          f"{done.stderr.strip().splitlines()[-1] if done.stderr.strip() else ''}")
    meta = json.loads((out / f"{photo.stem}.json").read_text())
    refine = meta.get("refine") or meta.get("meta", {}).get("refine") or {}
    return {"seconds": seconds, "refine": refine}


def run(data: Path, size: int, cases: str, modes: Sequence[str], threads: Optional[int],
        say=lambda _m: None) -> Dict[str, Any]:
    """Time every mode on every selected photo; returns the results document."""
    photos = [c for c in load_cases(data, size, cases) if c.kind == "photo"]
    if not photos:
        raise SvbrdfError(f"--cases {cases!r}: no real photo selected")
    rows: List[Dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="svbrdf-final-") as tmp:
        for case in photos:
            src = Path(tmp) / (case.name.replace("/", "_") + ".png")
            write_image(src, case.photo, bits=16, srgb_encode=True)
            for mode in modes:
                res = time_final(src, Path(tmp) / mode, mode, threads)
                row = {"case": case.name, "mode": mode, **res}
                rows.append(row)
                say(f"{case.name} | {mode} | {res['seconds']:.1f} s | {json.dumps(res['refine'])[:160]}")
    summary = {}
    for mode in modes:
        secs = [r["seconds"] for r in rows if r["mode"] == mode]
        summary[mode] = {"median_seconds": statistics.median(secs), "min_seconds": min(secs),
                         "max_seconds": max(secs), "photos": len(secs)}
    return {"size": size, "cases": cases, "modes": list(modes), "threads": threads, "rows": rows,
            "summary": summary}


def markdown(doc: Dict[str, Any]) -> str:
    out = [f"# Final quality at {doc['size']} px: `svbrdf-preview --refine` wall time", "", "```",
           doc["command"], "```", "", f"- date: {doc['date']}", f"- threads: {doc['threads'] or 'default'}", "",
           "| mode | photos | median s | min s | max s |", "|---|---|---|---|---|"]
    for mode, s in doc["summary"].items():
        out.append(f"| {mode} | {s['photos']} | {s['median_seconds']:.1f} | {s['min_seconds']:.1f} | "
                   f"{s['max_seconds']:.1f} |")
    out += ["", "| photo | mode | seconds | fine-tune |", "|---|---|---|---|"]
    for r in doc["rows"]:
        ref = r["refine"]
        what = "skipped (preview explains the photo)" if ref.get("skipped") else \
            f"{ref.get('iterations')} it" + (", stopped early" if ref.get("stopped_early") else "")
        out.append(f"| {r['case']} | {r['mode']} | {r['seconds']:.1f} | {what} |")
    return "\n".join(out) + "\n"


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.bench.final", description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None, help="data folder (default ../shared/data)")
    p.add_argument("--size", type=int, default=1024, help="photo side, px (default 1024)")
    p.add_argument("--cases", default="henzler-flash/*/2003/*,henzler-flash/*/2025/*,henzler-flash/*/0285/*",
                   help="comma-separated globs of real photos (default: three Henzler photos)")
    p.add_argument("--modes", default="auto,fixed", help="comma list of auto, fixed")
    p.add_argument("--threads", type=int, default=None, help="threads given to svbrdf-preview")
    p.add_argument("--out", type=Path, default=None, help="output folder (default docs/benchmarks/final-SIZE)")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    args = p.parse_args(argv)
    try:
        modes = [m.strip() for m in args.modes.split(",") if m.strip()]
        if not modes or any(m not in MODES for m in modes):
            raise SvbrdfError(f"--modes: expected some of {', '.join(MODES)}, got {args.modes!r}")
        if args.size < 64:
            raise SvbrdfError(f"--size must be >= 64, got {args.size}")
        out = args.out or repo_root() / "docs" / "benchmarks" / f"final-{args.size}"
        paths = results_paths(out, args.force)
        doc = run(args.data or default_data(), args.size, args.cases, modes, args.threads,
                  say=lambda m: print(m, file=sys.stderr, flush=True))
    except SvbrdfError as e:
        print(f"final: error: {e}", file=sys.stderr)
        return 2
    write_results(paths, "svbrdf.trainer.bench.final", argv, doc, markdown)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
