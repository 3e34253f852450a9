"""Probe (issue 54): does a stage one see a photo in 512 px blocks as well as the photo at its own size?

The preview runs the network on a 1024 px photo's 512 px block means (`Upsampling`, the shipped path). With v2 that
relights better and is twice as fast, but its maps carry more of the flash than the network's at 1024 px (the
label-free burn-in of the artist measures) and keep less of the material's texture under the highlight. A candidate
stage one closes that gap when its figures at 512 px are those at 1024 px. For every case of the shared sets at
``SIZE`` (default 1024 px; the tune and the check part of ``docs/data-split.md``) and every network size ``S``, the
photo is brought to ``S`` px (``estimate(..., max_size=S, upsampling=Upsampling(network_size=None))``, the runtime's
downsizing) and the maps at ``S`` px are scored, all with the shipped post-processing:

- ``burn_in``: :func:`svbrdf.runtime.quality.burn_in.burn_in_scores` (the benchmark's, the highlight centre scaled to
  ``S``);
- ``detail_<map>`` for the base colour (its channels' mean) and the roughness: the texture kept under the highlight,
  the mean local standard deviation (windows of ``2 r + 1`` px, ``r = DETAIL_RADIUS`` of the width, at least 1 px)
  within the burn-in's disc over that within its ring (``(s_disc + e) / (s_ring + e)``, ``e = DETAIL_EPS``). A
  stationary texture scores about 1 (a ground truth's score, ``gt_detail_<map>``, is the chance level); a haze or a
  flat fill under the highlight scores below 1;
- ``seconds``: the estimate's time (one thread).

The row ``shipped`` is the preview as it ships at ``SIZE`` (the default :class:`Upsampling`: the network's maps
brought back to ``SIZE`` with the photo's detail). Evaluation only: nothing is tuned here.

    OMP_NUM_THREADS=1 python docs/lab/network_size_probe.py MODEL.onnx OUT.json [SIZES]

``SIZES``: comma-separated network sizes (default ``512,768,1024``). ``DATA=DIR`` (default ``../shared/data``),
``SIZE=N`` (default 1024), ``SPLIT`` (``tune``, ``check``, ``tune,check`` (default) or ``all``) and ``CASES`` (the
benchmark's ``--cases``; default the sets that exist at 1024 px or more: bath_tile's views, the Henzler photos,
Des18 and Des19) in the environment. Writes ``OUT.json`` (``rows``: one per case and size; ``summary``: means per
part, kind and size) and prints the summary.
"""
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime.core.filters import box_mean
from svbrdf.runtime.io.images import ImageWarning
from svbrdf.runtime.inference.guided import Upsampling
from svbrdf.runtime.inference.pipeline import estimate
from svbrdf.runtime.inference.session import load_session
from svbrdf.runtime.quality.burn_in import DISC_RADIUS, RING_RADII, burn_in_scores
from svbrdf.trainer.bench.cases import load_cases

DATA = Path(os.environ.get("DATA", "../shared/data"))
SIZE = int(os.environ.get("SIZE", "1024"))
SPLIT = os.environ.get("SPLIT", "tune,check")
CASES = os.environ.get("CASES", "*bath_tile*,*henzler*,*Des18*,*Des19*")
#: Half-width of the local standard deviation's window, a fraction of the width (4 px at 1024 px).
DETAIL_RADIUS = 0.004
#: Added to both means of the detail ratio (map units), so that a near-constant map does not score its noise.
DETAIL_EPS = 1e-3
DETAIL_MAPS = ("diffuse", "roughness")


def detail_ratio(field: np.ndarray, centre, width: int) -> float:
    """Mean local standard deviation of ``field`` (H, W) within the burn-in's disc around ``centre`` over that
    within its ring (module docstring)."""
    r = max(1, round(DETAIL_RADIUS * width))
    f = np.asarray(field, np.float64)[..., None]
    mean = box_mean(f, r)[..., 0]
    std = np.sqrt(np.maximum(box_mean(f * f, r)[..., 0] - mean * mean, 0.0))
    h, w = std.shape
    d = np.hypot(np.arange(h)[:, None] + 0.5 - centre[0], np.arange(w)[None] + 0.5 - centre[1]) / width
    disc, ring = std[d < DISC_RADIUS], std[(d >= RING_RADII[0]) & (d < RING_RADII[1])]
    if not disc.size or not ring.size:
        return float("nan")
    return float((disc.mean() + DETAIL_EPS) / (ring.mean() + DETAIL_EPS))


def scores(maps, centre) -> dict:
    """Burn-in and detail ratios of a texture set (``centre`` in its pixels)."""
    width = maps.shape[1]
    out = {"burn_in": burn_in_scores(maps, centre)["burn_in"]}
    for n in DETAIL_MAPS:
        a = getattr(maps, n)
        out[f"detail_{n}"] = detail_ratio(a.mean(-1), centre, width)
    return out


def main(model: str, out: str, sizes) -> None:
    warnings.simplefilter("ignore", ImageWarning)  # every photo is downsized on purpose
    session = load_session(model, threads=1)
    parts = [None] if SPLIT == "all" else SPLIT.split(",")
    rows = []
    for part in parts:
        for case in load_cases(DATA, SIZE, CASES, split=part, renderer="ours"):
            kind = "capture" if case.capture is not None else case.kind
            side = case.photo.shape[1]
            gt = scores(case.gt, case.centre) if case.gt is not None else {}
            for s in ["shipped", *sizes]:
                t = time.perf_counter()
                if s == "shipped":
                    maps = estimate(case.photo, session, max_size=SIZE)
                else:
                    maps = estimate(case.photo, session, max_size=s, upsampling=Upsampling(network_size=None))
                seconds = time.perf_counter() - t
                f = maps.shape[1] / side
                row = {"part": part or "all", "case": case.name, "kind": kind, "size": s, "seconds": seconds,
                       **scores(maps, (case.centre[0] * f, case.centre[1] * f))}
                row.update({f"gt_{k}": v for k, v in gt.items() if k.startswith("detail_")})
                rows.append(row)
            print(f"{case.name}: " + ", ".join(f"{r['size']} {r['burn_in']:.3f}/{r['detail_diffuse']:.2f}"
                                               for r in rows[-len(sizes) - 1:]), file=sys.stderr, flush=True)
    keys = ["burn_in", *[f"detail_{n}" for n in DETAIL_MAPS], *[f"gt_detail_{n}" for n in DETAIL_MAPS], "seconds"]
    summary = []
    for part in dict.fromkeys(r["part"] for r in rows):
        for kind in ("synthetic", "photo", "capture"):
            for s in ["shipped", *sizes]:
                sel = [r for r in rows if r["part"] == part and r["kind"] == kind and r["size"] == s]
                if sel:
                    summary.append({"part": part, "kind": kind, "size": s, "n": len(sel),
                                    **{k: float(np.nanmean([r[k] for r in sel])) for k in keys if k in sel[0]}})
    Path(out).write_text(json.dumps({"model": model, "size": SIZE, "sizes": list(sizes), "rows": rows,
                                     "summary": summary}, indent=1))
    print("| part | kind | network size | n | burn-in | detail diffuse (truth) | detail roughness (truth) | s |")
    print("|---|---|---|---|---|---|---|---|")
    for m in summary:
        truth = lambda n: f" ({m[f'gt_detail_{n}']:.2f})" if f"gt_detail_{n}" in m else ""  # noqa: E731
        print(f"| {m['part']} | {m['kind']} | {m['size']} | {m['n']} | {m['burn_in']:.4f} | "
              f"{m['detail_diffuse']:.3f}{truth('diffuse')} | {m['detail_roughness']:.3f}{truth('roughness')} | "
              f"{m['seconds']:.2f} |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], [int(s) for s in (sys.argv[3] if len(sys.argv) > 3 else "512,768,1024").split(",")])
