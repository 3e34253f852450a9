"""Why the v2 stage one reads glossy materials as rough: (1) its roughness on held-out materials made uniformly
glossy or rough (the trainer's own photos), (2) the prior's relighting loss as a function of the predicted
roughness when everything else is the truth, with the truth's normals and with normals that miss them by a few
degrees (the network's own normal error is 7-10 degrees): is a broad lobe the loss's safe answer?

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/gloss_probe.py CKPT
"""
import dataclasses
import sys

import torch

from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.checkpoint import load_generator
from svbrdf.trainer.models import height_to_normal
from svbrdf.trainer.prior import PriorConfig, draw_materials, photograph, prior_loss

model, meta = load_generator(sys.argv[1])  # the moving average where the run keeps one
config = PriorConfig.from_dict(meta["prior_config"])
cfg = dataclasses.replace(config, crop_share=0.0, flat_share=0.0)
R = SLICES["roughness"]
print("(1) the network's roughness on 24 held-out materials (seed 424242) with one roughness everywhere")
for rough in (0.1, 0.2, 0.3, 0.5, 0.7, 0.9):
    rng = torch.Generator().manual_seed(424242)
    maps, fams, crop = draw_materials(cfg, rng, batch=24)
    maps[:, R] = rough
    photos, maps, _ = photograph(cfg, rng, maps, fams, crop)
    with torch.no_grad():
        pr = model(photos)[:, R]
    print(f"  truth {rough}: predicted mean {float(pr.mean()):.3f}, RMSE {float(((pr - rough) ** 2).mean().sqrt()):.3f}",
          flush=True)

print("(2) the relighting term (render, the prior's lights and views) of the truth with only its roughness changed")
rng = torch.Generator().manual_seed(424243)
maps, fams, crop = draw_materials(cfg, rng, batch=16)
noise = torch.randn(16, 1, maps.shape[-2], maps.shape[-1], generator=torch.Generator().manual_seed(5))
noise = torch.nn.functional.avg_pool2d(noise, 5, 1, 2)
for truth in (0.1, 0.2, 0.4):
    t = maps.clone()
    t[:, R] = truth
    for miss_deg in (0.0, 3.0, 6.0):
        wrong = t.clone()
        if miss_deg:
            # the truth's normals tilted by a smooth random field of about miss_deg degrees
            bump = height_to_normal(noise, 1.0)
            ang = torch.rad2deg(torch.acos(bump[:, 2].clamp(-1, 1))).mean()
            bump = height_to_normal(noise, float(miss_deg / ang))
            n = t[:, SLICES["normal"]] + bump - torch.tensor([0.0, 0.0, 1.0])[None, :, None, None]
            wrong[:, SLICES["normal"]] = n / n.norm(dim=1, keepdim=True)
        row = []
        for r in (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8):
            p = wrong.clone()
            p[:, R] = r
            loss = prior_loss(p, t, cfg, torch.Generator().manual_seed(9))
            row.append(f"{r}: {float(loss['render']):.4f}")
        print(f"  truth {truth}, normals off by ~{miss_deg:g} deg: " + ", ".join(row), flush=True)
