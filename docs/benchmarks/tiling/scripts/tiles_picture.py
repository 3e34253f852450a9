"""Picture: the roughness and base colour of large photos previewed with the old tile layout (top of each pair)
and the new one (below), long side 2048, each panel downsized to 512 px wide.

    OMP_NUM_THREADS=1 python docs/benchmarks/tiling/scripts/tiles_picture.py OUT.jpg PHOTO ...
"""
import sys

import numpy as np
import OpenImageIO as oiio

import svbrdf.runtime.tiling as T
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.session import estimate, load_session

NEW = T.tile_starts, T.tile_weights


def old_starts(length, tile, overlap, align=None):
    return [0] if length <= tile else list(range(0, length - tile, tile - overlap)) + [length - tile]


def old_weights(box, height, width, overlap):
    y0, x0, h, w = box
    return (T.ramp_weights(h, overlap if y0 > 0 else 0, overlap if y0 + h < height else 0)[:, None]
            * T.ramp_weights(w, overlap if x0 > 0 else 0, overlap if x0 + w < width else 0)[None, :])


def small(a, width=512):
    k = a.shape[1] // width
    h, w = (a.shape[0] // k) * k, (a.shape[1] // k) * k
    return a[:h, :w].reshape(h // k, k, w // k, k, -1).mean((1, 3))


out, photos = sys.argv[1], sys.argv[2:]
sess = load_session(threads=1)
rows = []
for photo in photos:
    for layout in ((old_starts, old_weights), NEW):
        T.tile_starts, T.tile_weights = layout
        m = estimate(photo, sess)
        r = m.roughness[..., 0]
        lo, hi = np.percentile(r, [0.5, 99.5])
        rough = np.repeat(np.clip((r - lo) / max(hi - lo, 1e-6), 0, 1)[..., None], 3, -1)
        base = np.clip(linear_to_srgb(m.diffuse), 0, 1)
        rows.append(np.concatenate([small(base), np.ones((small(base).shape[0], 4, 3)), small(rough)], 1))
        rows.append(np.ones((4, rows[-1].shape[1], 3)))
T.tile_starts, T.tile_weights = NEW
img = np.concatenate(rows[:-1], 0).astype(np.float32)
buf = oiio.ImageBuf(np.ascontiguousarray(img))
buf.write(out)
