"""Probe (issue 27, items 2 and 4): what the default refine does to a glossy material's roughness, from a stage one
that reads gloss as roughness (the v2 run: ../../prior-v2/gloss/).

N held-out procedural materials (seed 31_337_888, every family) given one roughness per material drawn in
[0.08, 0.7] (glossy to matte), their texture otherwise as drawn; photographed by the trainer's photo model (whole 256 px photos).
Per material: the preview (an ONNX export, the photo as the network's input or evenly lit) and the default refine
(``fast``, 150 iterations, from the export's checkpoint, with ``even_lighting`` as given), scored with the
benchmark's metrics (:func:`svbrdf.trainer.bench.metrics.evaluate`) and the roughness's mean inside 0.15 W of the
flash against outside 0.3 W (a disc: the highlight's roughness differs from the rest).

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/gloss_refine_probe.py MODEL.onnx CKPT.pt N OUT.jsonl [EVEN]
"""
import json
import sys
import warnings

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.maps import SLICES, Maps
from svbrdf.trainer.bench.cases import BenchCase
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.prior import draw_materials, photograph, prior_preset
import dataclasses

warnings.simplefilter("ignore")
model, ckpt, n, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
even = float(sys.argv[5]) if len(sys.argv) > 5 else 0.0
S.EVEN_LIGHTING = even or None
cfg = dataclasses.replace(prior_preset("v2"), crop_share=0.0, batch=n)
rng = torch.Generator().manual_seed(31_337_888)
maps, fams, crop = draw_materials(cfg, rng)
maps[:, SLICES["roughness"]] = 0.08 + 0.62 * torch.rand(n, 1, 1, 1, generator=rng)
photos, maps, _ = photograph(cfg, rng, maps, fams, crop)
size = photos.shape[-1]
r = np.hypot(np.arange(size)[:, None] + .5 - size / 2, np.arange(size)[None] + .5 - size / 2) / size


def near_far(m: Maps) -> tuple:
    g = m.roughness[..., 0]
    return round(float(g[r <= 0.15].mean()), 4), round(float(g[r >= 0.3].mean()), 4)


opts = BenchOptions(iters=[150], threads=1, repeats=1, model=model, init=ckpt,
                    train_overrides={"even_lighting": even})
with open(out, "a") as f:
    for i in range(n):
        photo = photos[i].permute(1, 2, 0).numpy().copy()
        gt = Maps.unpack(maps[i].permute(1, 2, 0).numpy())
        case = BenchCase(f"gloss{i}", "", "synthetic", "procedural", photo, gt, (size / 2, size / 2), None)
        pts = []
        METHODS["preview"].run(case, opts, None, pts.append)
        METHODS["finetune"].run(case, opts, "fast", pts.append)
        truth = float(gt.roughness.mean())
        for kind, p in zip(("preview", "refine"), pts):
            m = evaluate(p.maps, gt=gt, centre=case.centre)
            rec = {"material": i, "family": fams[i], "method": kind, "even": even, "truth_roughness": round(truth, 3),
                   "mean_roughness": round(float(p.maps.roughness.mean()), 3), "near_far": near_far(p.maps),
                   **{k: m[k] for k in ("rerender_rmse", "roughness_rmse", "specular_rmse", "diffuse_rmse",
                                        "normal_angle_deg", "burn_in") if k in m}}
            f.write(json.dumps(rec) + "\n")
            print(json.dumps(rec), flush=True)
