"""The preview of large photos with the tile layout before 2026-11-25 (windows ``tile - overlap`` apart, the last
aligned to the border, 64 px ramps) and now (windows spread evenly on a 32 px grid, ramps over the whole overlap).

Each photo is previewed at the default size (long side 2048, 1024 px tiles, overlap 64) both ways, in turns, one
thread. Per map: ``edge_jump``, the mean |step| of the map box-blurred over 9 px across the rows (columns) where a
layout's ramps begin or end, over the median step of all rows (columns): about 1 where nothing happens at an edge,
above where a seam is; given at the old layout's edges and at the new one's. Also the label-free burn-in
(``meta["burn_in"]``) and the seconds of the model.

    OMP_NUM_THREADS=1 python docs/benchmarks/tiling/scripts/tiles_before_after.py OUT.json PHOTO ...
"""
import json
import sys
import time

import numpy as np

from old_layout import NEW, old_starts, use
from svbrdf.runtime.session import DEFAULT_OVERLAP, DEFAULT_TILE, estimate, load_session


def edges(starts, tile, overlap, ramps_whole):
    """Rows/columns where a tile's blend ramp begins or ends."""
    out = set()
    for k, s in enumerate(starts):
        if k > 0:
            out |= {s, (starts[k - 1] + tile) if ramps_whole else s + overlap}
        if k + 1 < len(starts):
            out |= {s + tile, starts[k + 1] if ramps_whole else s + tile - overlap}
    return sorted(out)


def box9(a, axis):
    k = np.ones(9) / 9
    return np.apply_along_axis(lambda v: np.convolve(np.pad(v, 4, mode="edge"), k, "valid"), axis, a)


def edge_jump(arr, cols, rows):
    a = np.asarray(arr, np.float64).mean(-1)
    b = box9(box9(a, 0), 1)
    dx = np.abs(np.diff(b, axis=1)).mean(0)
    dy = np.abs(np.diff(b, axis=0)).mean(1)
    pick = lambda d, e: float(np.mean([d[min(max(i - 1, 0), len(d) - 1)] for i in e]) / np.median(d)) if e else None
    return {"x": pick(dx, cols), "y": pick(dy, rows)}


out, photos = sys.argv[1], sys.argv[2:]
sess = load_session(threads=1)
records = []
for photo in photos:
    row = {"photo": photo}
    for label in ("before", "after"):
        use(label == "before")
        t = time.perf_counter()
        m = estimate(photo, sess)
        sec = time.perf_counter() - t
        h, w = m.shape
        row[label] = {"burn_in": m.meta["burn_in"]["burn_in"], "burn_in_model": m.meta["burn_in_model"]["burn_in"],
                      "seconds": sec, "infer_s": m.meta["timings"]["infer"], "tiles": m.meta["tiles"]}
        for lay, (sf, whole) in {"old_edges": (old_starts, False), "new_edges": (NEW[0], True)}.items():
            cols = edges(sf(w, DEFAULT_TILE, DEFAULT_OVERLAP), DEFAULT_TILE, DEFAULT_OVERLAP, whole) if w > DEFAULT_TILE else []
            rows = edges(sf(h, DEFAULT_TILE, DEFAULT_OVERLAP), DEFAULT_TILE, DEFAULT_OVERLAP, whole) if h > DEFAULT_TILE else []
            row[label][lay] = {n: edge_jump(getattr(m, n), cols, rows) for n in ("diffuse", "roughness", "normal")}
    use(False)
    records.append(row)
    print(photo, {lb: (round(row[lb]["burn_in"], 3), round(row[lb]["infer_s"], 1),
                       {n: round(row[lb]["old_edges"][n]["x"] or 0, 2) for n in ("diffuse", "roughness")})
                  for lb in ("before", "after")}, flush=True)
summary = {}
for lb in ("before", "after"):
    s = {"burn_in": float(np.mean([r[lb]["burn_in"] for r in records])),
         "infer_s": float(np.mean([r[lb]["infer_s"] for r in records]))}
    for lay in ("old_edges", "new_edges"):
        for n in ("diffuse", "roughness", "normal"):
            for ax in ("x", "y"):
                vals = [r[lb][lay][n][ax] for r in records if r[lb][lay][n][ax] is not None]
                s[f"{lay}/{n}/{ax}"] = float(np.mean(vals)) if vals else None
    summary[lb] = s
    print(lb, {k: (round(v, 3) if v is not None else None) for k, v in s.items()})
with open(out, "w") as f:
    json.dump({"command": "python " + " ".join(sys.argv), "summary": summary, "records": records}, f, indent=1)
