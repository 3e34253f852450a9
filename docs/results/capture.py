"""The capture fit (``svbrdf-preview --capture``, :mod:`svbrdf.trainer.capture`) with each view left out in turn:
fitted on the other views, relit at the one left out against its photo, beside the single-view preview and the
trivial baseline relit there from each of the other views (the bench's relighting rule,
:func:`svbrdf.trainer.bench.metrics.relight_view`). Writes ``capture.json`` and ``capture.md`` beside this file.

    python docs/results/capture.py [--data ../shared/data/guo-svbrdf-diff-renderer/bath_tile] [--size 256]
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch

from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO
from svbrdf.runtime.inference.pipeline import estimate
from svbrdf.runtime.inference.session import load_session
from svbrdf.trainer.bench.cases import CaptureViews, _read_photo
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.datasets import capture_view_file, read_capture_calibration
from svbrdf.trainer.bench.metrics import relight_view
from svbrdf.trainer.bench.methods import BASELINE_ROUGHNESS, BASELINE_SPECULAR
from svbrdf.trainer.capture import average_maps, fit_capture
from svbrdf.trainer.losses import guessed_diffuse
from svbrdf.trainer.train import photo_to_tensor

HERE = Path(__file__).resolve().parent


def _rmse(maps: Maps, capture: CaptureViews, view: int) -> float:
    relit, ref, ok = relight_view(maps, capture, view, ZHAO)
    return math.sqrt(float(np.mean((relit[ok] - ref[ok]) ** 2)))


def _baseline(photo: np.ndarray) -> Maps:
    with torch.no_grad():
        guess = guessed_diffuse(photo_to_tensor(photo))[0].permute(1, 2, 0).numpy()
    h, w = photo.shape[:2]
    normal = np.zeros((h, w, 3), np.float32)
    normal[..., 2] = 1.0
    return Maps(diffuse=guess, specular=np.full((h, w, 1), BASELINE_SPECULAR, np.float32),
                roughness=np.full((h, w, 1), BASELINE_ROUGHNESS, np.float32), normal=normal)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=default_data() / "guo-svbrdf-diff-renderer" / "bath_tile")
    p.add_argument("--size", type=int, default=256)
    args = p.parse_args(argv)
    torch.set_num_threads(1)
    calib = read_capture_calibration(args.data)
    photos = {i: _read_photo(capture_view_file(args.data, i), args.size) for i in calib.views}
    capture = CaptureViews(calib, -1, photos)
    session = load_session(threads=1)
    previews = {i: estimate(photo, session) for i, photo in photos.items()}
    baselines = {i: _baseline(photo) for i, photo in photos.items()}
    rows = []
    for held in sorted(photos):
        train = [i for i in photos if i != held]
        prior = average_maps([previews[i] for i in train])
        t0 = time.perf_counter()
        fit = fit_capture({i: photos[i] for i in train}, calib, prior, threads=1)
        row = {"view": held, "fit": _rmse(fit, capture, held), "prior": _rmse(prior, capture, held),
               "preview": float(np.mean([_rmse(previews[i], capture, held) for i in train])),
               "baseline": float(np.mean([_rmse(baselines[i], capture, held) for i in train])),
               "fit_seconds": time.perf_counter() - t0, "train_loss": fit.meta["capture"]["loss"]}
        row["fit_over_baseline"] = row["fit"] / row["baseline"]
        rows.append(row)
        print(f"view {held:02d}: fit {row['fit']:.4f} ({row['fit_over_baseline']:.2f}x baseline), mean previews "
              f"{row['prior']:.4f}, single-view preview {row['preview']:.4f}, baseline {row['baseline']:.4f}",
              flush=True)
    mean = {k: float(np.mean([r[k] for r in rows])) for k in ("fit", "prior", "preview", "baseline",
                                                                "fit_over_baseline", "fit_seconds")}
    doc = {"command": shlex.join(["python", "docs/results/capture.py"] + (argv or sys.argv[1:])),
           "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "capture": str(calib.path.parent.name),
           "size": args.size, "metric": "sRGB RMSE of the maps relit at the view left out (the bench's rule)",
           "views": rows, "mean": mean}
    (HERE / "capture.json").write_text(json.dumps(doc, indent=2) + "\n")
    lines = ["# The capture fit, each view left out in turn", "",
             f"`{doc['command']}` ({doc['date']}, {doc['capture']}, {args.size} px, one thread). sRGB RMSE at the "
             "view left out; the preview and the baseline are the mean over the other views of each one's maps "
             "relit there.", "",
             "| view | fit (`--capture`) | fit / baseline | mean of the previews (the fit's prior) | single-view preview "
             "| trivial baseline |", "|---|---|---|---|---|---|"]
    for r in rows + [dict(mean, view="mean")]:
        view = r["view"] if isinstance(r["view"], str) else f"{r['view']:02d}"
        lines.append(f"| {view} | {r['fit']:.4f} | {r['fit_over_baseline']:.2f} | {r['prior']:.4f} | "
                     f"{r['preview']:.4f} | {r['baseline']:.4f} |")
    (HERE / "capture.md").write_text("\n".join(lines) + "\n")
    print(f"mean: fit {mean['fit']:.4f} ({mean['fit_over_baseline']:.2f}x baseline), single-view preview "
          f"{mean['preview']:.4f}, baseline {mean['baseline']:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
