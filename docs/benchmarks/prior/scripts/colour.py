"""The preview's base colour with and without :func:`svbrdf.runtime.session.photo_colour`, on held-out procedural
materials (ground truth known; seed 987654, not a training seed) and on the shared ground-truth sets.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior/scripts/colour.py [N]

Prints, per variant, over N (default 48) procedural materials at 256 px rendered as realistic flash photos
(:func:`svbrdf.trainer.prior.simulate_photos`): diffuse sRGB RMSE, the chroma of the mean base colour (ground truth
vs preview) and the re-render RMSE against the ground truth (9 novel lights + the flash, :func:`svbrdf.runtime.render.rerender_rmse`).
"""

import json
import sys
import warnings

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.render import novel_lights, rerender_rmse
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

warnings.simplefilter("ignore")
n = int(sys.argv[1]) if len(sys.argv) > 1 else 48
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, _ = simulate_photos(maps, PriorConfig(), rng)
session = S.load_session(threads=1)
cfg = session.render_config


def mean_chroma(d):
    m = linear_to_srgb(np.clip(d.reshape(-1, 3).mean(0), 0, 1))
    return float(m.max() - m.min())


out = {}
for flag in (False, True):
    S.COLOUR_FROM_PHOTO = flag
    rows = []
    for photo, gt in zip(photos, gts):
        img = photo.permute(1, 2, 0).numpy()
        g = Maps.unpack(gt.permute(1, 2, 0).numpy())
        p = S.estimate(img, session)
        d_rmse = float(np.sqrt(np.mean((linear_to_srgb(p.diffuse, clip=True) - linear_to_srgb(g.diffuse, clip=True)) ** 2)))
        rows.append((d_rmse, mean_chroma(g.diffuse), mean_chroma(p.diffuse),
                     rerender_rmse(p, g, list(novel_lights(cfg)) + [None], cfg)))
    r = np.array(rows).mean(0)
    out["photo_colour" if flag else "model only"] = {"diffuse_rmse_srgb": r[0], "gt_mean_chroma": r[1],
                                                     "preview_mean_chroma": r[2], "rerender_rmse": r[3]}
print(json.dumps({"materials": n, "seed": 987654, **out}, indent=1))
