"""Picture: the roughness and base colour of large photos previewed with the old tile layout (top of each pair)
and the new one (below), long side 2048, each panel downsized to 512 px wide.

    OMP_NUM_THREADS=1 python docs/benchmarks/tiling/scripts/tiles_picture.py OUT.jpg PHOTO ...
"""
import sys

import numpy as np
import OpenImageIO as oiio

from old_layout import use
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.session import estimate, load_session
from svbrdf.runtime.tiling import block_mean


def small(a, width=512):
    return block_mean(a, a.shape[1] // width)


out, photos = sys.argv[1], sys.argv[2:]
sess = load_session(threads=1)
rows = []
for photo in photos:
    for old in (True, False):
        use(old)
        m = estimate(photo, sess)
        r = m.roughness[..., 0]
        lo, hi = np.percentile(r, [0.5, 99.5])
        rough = np.repeat(np.clip((r - lo) / max(hi - lo, 1e-6), 0, 1)[..., None], 3, -1)
        base = np.clip(linear_to_srgb(m.diffuse), 0, 1)
        rows.append(np.concatenate([small(base), np.ones((small(base).shape[0], 4, 3)), small(rough)], 1))
        rows.append(np.ones((4, rows[-1].shape[1], 3)))
use(False)
img = np.concatenate(rows[:-1], 0).astype(np.float32)
buf = oiio.ImageBuf(np.ascontiguousarray(img))
buf.write(out)
