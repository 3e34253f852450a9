"""Run time and peak memory of ``svbrdf-preview`` against the photo's size, this checkout against an earlier commit, in
one run (issue 54, item 4). From the repository root, with the package installed (the light install is enough):

    python docs/results/sizes.py --before 8477f92,17cb175 --out docs/results/sizes      # ~20 minutes on 2 cores

For every size (256, 1024, 2048, 4096, 8192 px) a photo is made once in a temporary folder: the centre square of a
real photo (default: a Henzler et al. 4032 x 3024 iPhone flash photo from ``../shared/data``; ``--photo``) resized
to that size (OpenImageIO, blackman-harris down, lanczos3 up), plus the issue's own 1024 px photo (bath_tile/00,
as taken). Each is run ``--repeats`` times through the command line of every version, taking turns (``--max-size``
raised to the photo's size, ``--threads 2``, a fresh process and output folder each time); the seconds are those the
CLI reports on its line (reading the photo to the files on disk, as the issue asks), the peak memory that of the
process (``wait4``). Each earlier version (``--before``, comma-separated commits) runs from a ``git worktree`` of it
put first on ``PYTHONPATH``, with the same installed libraries. Writes ``sizes.json`` (every run), ``sizes.md`` (medians) and ``sizes.png`` (seconds
against megapixels and against peak memory).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data"
PHOTO = SHARED / "henzler-flash" / "test" / "2003" / "IMG_9392.JPG"
CAPTURE = SHARED / "guo-svbrdf-diff-renderer" / "bath_tile" / "00.png"
SIZES = (256, 1024, 2048, 4096, 8192)
LINE = re.compile(r"  (\d+)x(\d+)  ([0-9.]+) s \(")


def make_photos(photo: Path, sizes, folder: Path) -> dict:
    """``{label: path}``: the centre square of ``photo`` at each size (8-bit PNG, sRGB as read), and bath_tile/00."""
    import OpenImageIO as oiio

    src = oiio.ImageBuf(str(photo))
    spec = src.spec()
    side = min(spec.width, spec.height)
    x0, y0 = (spec.width - side) // 2, (spec.height - side) // 2
    square = oiio.ImageBufAlgo.cut(src, oiio.ROI(x0, x0 + side, y0, y0 + side, 0, 1, 0, 3))
    out = {}
    for n in sizes:
        filt = "blackman-harris" if n <= side else "lanczos3"
        img = oiio.ImageBufAlgo.resize(square, filtername=filt, roi=oiio.ROI(0, n, 0, n, 0, 1, 0, 3))
        path = folder / f"photo{n}.png"
        img.write(str(path), "uint8")
        out[str(n)] = path
    if CAPTURE.is_file():
        out["1024 bath_tile/00"] = CAPTURE
    return out


def run_cli(env: dict, photo: Path, size: int, out: Path) -> dict:
    """One ``svbrdf-preview`` run in a fresh process: the seconds it reports, its peak RSS, its exit code."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-m", "svbrdf.runtime.cli.preview", str(photo), "-o", str(out), "--threads", "2",
           "--max-size", str(max(size, 256)), "--force"]
    with tempfile.TemporaryFile("w+") as log:  # a file, not a pipe: a talkative run cannot block before wait4
        proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        log.seek(0)
        text = log.read()
    m = LINE.search(text)
    shutil.rmtree(out, ignore_errors=True)
    return {"seconds": float(m.group(3)) if m else None, "peak_rss_mb": usage.ru_maxrss / 1024,
            "rc": os.waitstatus_to_exitcode(status), "line": text.strip().splitlines()[-1] if text.strip() else ""}


def plot(rows: list, path: Path) -> None:
    """The benchmark's plot (:func:`svbrdf.trainer.bench.plot.plot_pareto`): seconds on the x axis, the photo's
    megapixels and the peak memory (GiB) on the two panels, one line per version."""
    from svbrdf.trainer.bench.plot import plot_pareto

    series = []
    versions = list(rows[0]["versions"])
    for version in versions:
        pts = [(r["versions"][version]["seconds"], r["pixels"] / 1e6, r["versions"][version]["peak_rss_mb"] / 1024)
               for r in rows if r["label"].isdigit() and r["versions"][version]["seconds"] is not None]
        series.append({"label": version, "method": "preview" if version == "now" else "baseline", "points": pts})
    plot_pareto(series, path, titles=("photo size (megapixels)", "peak memory (GiB)"), force=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", default="8477f92", help="git commits of the earlier versions, comma-separated "
                   "(default: 8477f92, before issue 54)")
    p.add_argument("--photo", type=Path, default=PHOTO, help="the real photo the sizes are made from")
    p.add_argument("--sizes", default=",".join(map(str, SIZES)))
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--out", type=Path, default=Path("docs/results/sizes"))
    args = p.parse_args(argv)
    if not args.photo.is_file():
        print(f"sizes.py: error: {args.photo} not found (pass --photo)", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    commits = [c for c in args.before.split(",") if c]
    versions = commits + ["now"]
    with tempfile.TemporaryDirectory(prefix="svbrdf-sizes-") as tmp:
        tmp = Path(tmp)
        base = {**os.environ, "OMP_WAIT_POLICY": "PASSIVE"}
        envs = {"now": base}
        try:
            for commit in commits:
                tree, path = tmp / f"tree-{commit}", tmp / f"pp-{commit}"
                subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(tree), commit],
                               check=True)
                path.mkdir()
                (path / "svbrdf").symlink_to(tree)  # the import name svbrdf is the repository root
                envs[commit] = {**base, "PYTHONPATH": str(path)}
            photos = make_photos(args.photo, [int(s) for s in args.sizes.split(",")], tmp)
            records = []
            for label, photo in photos.items():
                size = int(label.split()[0])
                for i in range(args.repeats):
                    for version in versions if i % 2 == 0 else versions[::-1]:  # taking turns
                        rec = run_cli(envs[version], photo, size, tmp / "out")
                        rec.update(label=label, version=version, repeat=i, load=os.getloadavg()[0])
                        records.append(rec)
                        print(f"{label:>18} {version:8} {rec['seconds']} s  {rec['peak_rss_mb']:.0f} MB  rc {rec['rc']}",
                              flush=True)
        finally:
            for commit in commits:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tmp / f"tree-{commit}")],
                               check=False)
    rows = []
    for label in photos:
        row = {"label": label, "pixels": int(label.split()[0]) ** 2, "versions": {}}
        for version in versions:
            rs = [r for r in records if r["label"] == label and r["version"] == version]
            secs = [r["seconds"] for r in rs if r["seconds"] is not None]
            row["versions"][version] = {"seconds": statistics.median(secs) if secs else None,
                                        "runs": [r["seconds"] for r in rs],
                                        "peak_rss_mb": max(r["peak_rss_mb"] for r in rs),
                                        "failed": sum(r["rc"] != 0 for r in rs)}
        rows.append(row)
    doc = {"command": " ".join(sys.argv), "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
           "before": commits, "machine": {"cores": os.cpu_count(), "platform": platform.platform()},
           "rows": rows, "records": records}
    (args.out / "sizes.json").write_text(json.dumps(doc, indent=1) + "\n")
    fmt = lambda v: "failed" if v["seconds"] is None else f"{v['seconds']:.2f}"  # noqa: E731
    lines = ["| photo | " + " | ".join(f"{v}: s" for v in versions) + " | now: runs | "
             + " | ".join(f"{v}: peak MiB" for v in versions) + " |", "|---" * (2 * len(versions) + 2) + "|"]
    for r in rows:
        vs = [r["versions"][v] for v in versions]
        runs = ", ".join("failed" if x is None else f"{x:.2f}" for x in r["versions"]["now"]["runs"])
        lines.append(f"| {r['label']} px | " + " | ".join(fmt(v) for v in vs) + f" | {runs} | "
                     + " | ".join(f"{v['peak_rss_mb']:.0f}" for v in vs) + " |")
    loads = [r["load"] for r in records]
    lines.append(f"\nMedian of {args.repeats} runs each, taking turns; load average {min(loads):.1f}-{max(loads):.1f} "
                 f"during the run; peak = the process's maximum resident set (wait4). Command: `{doc['command']}`.")
    (args.out / "sizes.md").write_text("\n".join(lines) + "\n")
    plot(rows, args.out / "sizes.png")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
