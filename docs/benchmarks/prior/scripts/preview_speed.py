"""Preview time at 1024 px, two models side by side (interleaved repeats, median), on a real photo.

    python docs/benchmarks/prior/scripts/preview_speed.py models/A.onnx models/B.onnx --out docs/benchmarks/prior/preview_speed.json
"""

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from svbrdf.runtime.imageio import read_image
from svbrdf.runtime.session import estimate, load_session, resize_long_side


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("models", nargs=2)
    p.add_argument("--photo", type=Path, default=Path(__file__).resolve().parents[5] / "shared" / "data" /
                   "henzler-flash" / "test" / "2003" / "IMG_9392.JPG")
    p.add_argument("--size", type=int, default=1024)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--threads", type=int, default=None, help="onnxruntime threads (default: all cores)")
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    img = read_image(args.photo)[..., :3]
    h, w = img.shape[:2]
    s = min(h, w)
    img = resize_long_side(np.ascontiguousarray(img[(h - s) // 2:(h - s) // 2 + s, (w - s) // 2:(w - s) // 2 + s]),
                           args.size)
    sessions = [load_session(m, threads=args.threads) for m in args.models]
    for sess in sessions:  # warm-up
        estimate(img, sess)
    times = [[] for _ in sessions]
    for _ in range(args.repeats):
        for i, sess in enumerate(sessions):
            t = time.perf_counter()
            estimate(img, sess)
            times[i].append(time.perf_counter() - t)
    med = [statistics.median(t) for t in times]
    for m, t, md in zip(args.models, times, med):
        print(f"{m}: median {md:.3f} s ({', '.join(f'{x:.3f}' for x in t)})")
    print(f"ratio {Path(args.models[1]).name} / {Path(args.models[0]).name}: {med[1] / med[0]:.3f}")
    if args.out:
        args.out.write_text(json.dumps({"command": " ".join(["python", *sys.argv]), "size": args.size,
                                        "threads": args.threads, "photo": args.photo.name,
                                        "models": args.models, "seconds": times, "median": med,
                                        "ratio": med[1] / med[0]}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
