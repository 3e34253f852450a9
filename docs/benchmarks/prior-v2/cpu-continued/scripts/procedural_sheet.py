"""Roughness and normals of stage-one candidates beside the truth, on held-out procedural materials (seed 987654,
the same photos as ``../../scripts/candidate_procedural.py``; never the shared sets), through the product's
preview path (:func:`svbrdf.runtime.session.estimate`). One row per material: the photo, then per model (truth
first) its roughness (grey) and normals ((n + 1) / 2), each 128 px. Written as an 8-bit PNG (the committed JPEG
is a conversion with OpenImageIO).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/cpu-continued/scripts/procedural_sheet.py OUT.png I,J,... A=runs/a.onnx C=default
"""
import sys
import warnings

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.imageio import write_image
from svbrdf.runtime.maps import Maps, encode_normal
from svbrdf.runtime.tiling import block_mean
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

warnings.simplefilter("ignore")
out, picks = sys.argv[1], [int(i) for i in sys.argv[2].split(",")]
models = dict(a.split("=", 1) for a in sys.argv[3:])
n = max(picks) + 1
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, _ = simulate_photos(maps, PriorConfig(), rng)
sessions = {label: S.load_session(None if p == "default" else p) for label, p in models.items()}
grey = lambda a: np.repeat(block_mean(a, 2), 3, axis=-1)  # noqa: E731
rows = []
for i in picks:
    photo = photos[i].permute(1, 2, 0).numpy().copy()
    est = [Maps.unpack(gts[i].permute(1, 2, 0).numpy())] + [S.estimate(photo, s) for s in sessions.values()]
    tiles = [block_mean(photo, 2)]
    for m in est:
        tiles += [grey(m.roughness), block_mean(encode_normal(m.normal), 2)]
    rows.append(np.concatenate(tiles, axis=1))
    print(i, names[i], flush=True)
sheet = np.concatenate(rows, axis=0)
print("columns: photo | " + " | ".join(f"{lb} roughness, normal" for lb in ["truth", *sessions]))
write_image(out, np.clip(sheet, 0, 1).astype(np.float32), bits=8, force=True)
