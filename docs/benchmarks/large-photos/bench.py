"""Peak memory and wall time of ``svbrdf-preview`` on large photos, before and after the strip reader (issue 16).

Usage (from the repository root; BEFORE is a checkout of the commit before the change with its own venv):

    python docs/benchmarks/large-photos/bench.py --before /work/wt-before/.venv/bin/svbrdf-preview \
        --after .venv/bin/svbrdf-preview --out docs/benchmarks/large-photos --threads 2

Test photos are made from the bundled example (tiled, a smooth gradient on top so no two tiles are equal) as
8-bit JPEG at 1K, 4K, 8K and 16K on the long side (4:3), in a temporary folder. Each photo is run once by each
CLI, in turns; peak RSS comes from ``os.wait4`` (the child's ``ru_maxrss``), wall time from the parent.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

SIZES = {"1K": 1024, "4K": 4096, "8K": 8192, "16K": 16384}


def make_photo(path: Path, long_side: int, example: Path) -> None:
    """A 4:3 JPEG of ``long_side`` x 3/4 of it, written in strips so the generator stays small too."""
    src = oiio.ImageBuf(str(example))
    tile = np.asarray(src.get_pixels(oiio.FLOAT))[..., :3]
    th, tw = tile.shape[:2]
    w, h = long_side, long_side * 3 // 4
    out = oiio.ImageOutput.create(str(path))
    spec = oiio.ImageSpec(w, h, 3, oiio.UINT8)
    spec.attribute("Compression", "jpeg:90")
    out.open(str(path), spec)
    strip = 256
    xs = np.arange(w)
    for y0 in range(0, h, strip):
        y1 = min(h, y0 + strip)
        ys = np.arange(y0, y1)
        block = tile[ys[:, None] % th, xs[None, :] % tw]
        grad = 0.75 + 0.25 * (xs[None, :, None] / w) * (ys[:, None, None] / h)
        out.write_scanlines(y0, y1, 0, np.clip(block * grad * 255 + 0.5, 0, 255).astype(np.uint8))
    out.close()


def run(cli: str, photo: Path, out: Path, threads: int) -> dict:
    cmd = [cli, str(photo), "-o", str(out), "--force", "-q", "--threads", str(threads)]
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    stderr = proc.stderr.read().decode(errors="replace").strip()
    proc.stdout.close()
    proc.stderr.close()
    return {"seconds": round(wall, 2), "peak_rss_mib": round(usage.ru_maxrss / 1024, 1),
            "exit": os.waitstatus_to_exitcode(status), "stderr": stderr.splitlines()[-1:] if stderr else []}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", required=True, help="svbrdf-preview of the old checkout")
    p.add_argument("--after", required=True, help="svbrdf-preview of this checkout")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--sizes", default=",".join(SIZES))
    args = p.parse_args()
    example = Path(__file__).resolve().parents[3] / "runtime" / "examples" / "carved_wood.png"
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for label in args.sizes.split(","):
            photo = tmp / f"photo_{label}.jpg"
            make_photo(photo, SIZES[label], example)
            mb = photo.stat().st_size / 2 ** 20
            for which, cli in (("before", args.before), ("after", args.after)):
                r = run(cli, photo, tmp / f"out_{which}", args.threads)
                r.update(size=label, long_side=SIZES[label], file_mib=round(mb, 1), version=which)
                print(json.dumps(r), file=sys.stderr, flush=True)
                rows.append(r)
    args.out.mkdir(parents=True, exist_ok=True)
    doc = {"command": " ".join([Path(sys.argv[0]).as_posix()] + sys.argv[1:]), "threads": args.threads,
           "cpu_count": os.cpu_count(), "rows": rows}
    (args.out / "results.json").write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    lines = ["| photo | file MiB | before: peak RSS MiB | after: peak RSS MiB | before: s | after: s |",
             "|---|---|---|---|---|---|"]
    for label in args.sizes.split(","):
        b = next(r for r in rows if r["size"] == label and r["version"] == "before")
        a = next(r for r in rows if r["size"] == label and r["version"] == "after")
        lines.append(f"| {label} ({a['long_side']} x {a['long_side'] * 3 // 4}) | {a['file_mib']} | "
                     f"{b['peak_rss_mib']} | {a['peak_rss_mib']} | {b['seconds']} | {a['seconds']} |")
    (args.out / "results.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
