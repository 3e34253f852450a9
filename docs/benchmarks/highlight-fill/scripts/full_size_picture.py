"""The preview of whole photos at full size, without and with the highlight fill: one row per photo, columns the
photo (the fill's region outlined in red), base colour and roughness without the fill, then with it; each panel
block-averaged to about 384 px high. Prints the fill's record and the post-processing seconds.

    OMP_NUM_THREADS=1 python docs/benchmarks/highlight-fill/scripts/full_size_picture.py OUT.png MAX_SIZE PHOTO [PHOTO ...]
"""
import sys
import warnings

import numpy as np

from svbrdf.runtime import session as S
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.highlight_fill import highlight_mask
from svbrdf.runtime.imageio import write_image
from svbrdf.runtime.tiling import block_mean

warnings.simplefilter("ignore")
out_path, max_size, photos = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
sess = S.load_session(threads=1)
rows = []
for path in photos:
    name, image, _ = S._as_image(path, max_size)
    k = max(1, max(image.shape[:2]) // 384)
    mask = highlight_mask(image)
    edge = mask ^ np.roll(mask, 1, 0) | mask ^ np.roll(mask, 1, 1)
    for _ in range(k):
        edge = edge | np.roll(edge, 1, 0) | np.roll(edge, 1, 1)
    photo = linear_to_srgb(np.clip(image, 0, 1)).copy()
    photo[edge] = [1, 0, 0]
    panels = [block_mean(photo, k)]
    for fill in (False, True):
        S.HIGHLIGHT_FILL = fill
        maps = S.estimate(image, sess)
        print(name, "fill" if fill else "no fill", f"post {maps.meta['timings']['post']:.2f} s",
              maps.meta.get("highlight_fill"), flush=True)
        base = linear_to_srgb(maps.diffuse)
        base = np.clip(base / max(float(np.quantile(base, 0.99)), 1e-6), 0, 1)
        panels += [block_mean(base, k), block_mean(np.repeat(maps.roughness, 3, -1), k)]
    h = min(p.shape[0] for p in panels)
    w = min(p.shape[1] for p in panels)
    rows.append(np.concatenate([p[:h, :w] for p in panels], 1))
width = max(r.shape[1] for r in rows)
rows = [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0))) for r in rows]
write_image(out_path, np.concatenate(rows, 0).astype(np.float32), bits=8)
