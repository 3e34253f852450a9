"""Seams of a tiled preview: per map, the mean over rows of |d/dx| of the map box-blurred over 9 px (what a line
across the image looks like), as a profile over the columns (and over the rows for d/dy); printed: its largest
value away from the 16 px borders over its median, and where. A tile seam is a peak at a tile edge.

    python docs/benchmarks/tiling/scripts/seam_profile.py OUT.json LABEL=PREVIEW_FOLDER ...
"""
import json
import sys
from pathlib import Path

import numpy as np

from svbrdf.runtime.viewer import read_texture_set

out, runs = sys.argv[1], dict(a.split("=", 1) for a in sys.argv[2:])


def box(a, r, axis):
    c = np.cumsum(np.pad(a, [(r + 1, r) if ax == axis else (0, 0) for ax in range(a.ndim)], mode="edge"), axis=axis)
    n = a.shape[axis]
    return (np.take(c, np.arange(2 * r + 1, 2 * r + 1 + n), axis=axis) - np.take(c, np.arange(n), axis=axis)) / (2 * r + 1)


res = {}
for label, folder in runs.items():
    maps, _ = read_texture_set(next(Path(folder).glob("*.json")))
    res[label] = {}
    for name in ("diffuse", "roughness", "normal"):
        a = np.asarray(getattr(maps, name), np.float64).mean(-1)
        row = {}
        for axis, key in ((1, "x"), (0, "y")):
            b = box(box(a, 4, 0), 4, 1)
            d = np.abs(np.diff(b, axis=axis)).mean(axis=1 - axis)[16:-16]
            k = int(np.argmax(d))
            row[key] = {"peak_over_median": float(d[k] / np.median(d)), "at": k + 16}
        res[label][name] = row
        print(label, name, {k: (round(v["peak_over_median"], 2), v["at"]) for k, v in row.items()})
Path(out).write_text(json.dumps(res, indent=1))
