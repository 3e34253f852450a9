"""Probe (issue 27, items 2 and 4): does the photo tell a material's roughness level and specular level, when the
rest of the maps is the stage one's?

The glossy-to-matte materials of ``gloss_refine_probe.py`` (seed 31_337_888, one roughness per material in
[0.08, 0.7]). Their preview maps (an ONNX export; the photo as the network's input, the runtime's
post-processing) are re-rendered under each photo's flash (its own field of view and renderer settings: the upper
bound of knowing the camera) with the roughness shifted by d (added, clipped to [0.03, 1]) and the specular set to
one level s, on a grid; per (d, s) the photo loss of the fine-tune (`svbrdf.trainer.losses.render_loss`: sRGB L1,
one-sided where the photo clipped) at the best of a few exposure gains; the (d, s) with the lowest loss is kept.
Scored: roughness and specular RMSE and the re-render error (the benchmark's 10 lights) before and after.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/lobe_level_probe.py MODEL.onnx N OUT.jsonl
"""
import dataclasses
import json
import sys
import warnings

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.maps import SLICES, Maps
from svbrdf.runtime.render import physical_config, render
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.config import resolve
from svbrdf.trainer.losses import render_loss
from svbrdf.trainer.prior import draw_materials, photograph, prior_preset

warnings.simplefilter("ignore")
model, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
S.EVEN_LIGHTING = None
sess = S.load_session(model, threads=1)
cfg = dataclasses.replace(prior_preset("v2"), crop_share=0.0, batch=n, batched=False)
rng = torch.Generator().manual_seed(31_337_888)
maps, fams, crop = draw_materials(cfg, rng)
maps[:, SLICES["roughness"]] = 0.08 + 0.62 * torch.rand(n, 1, 1, 1, generator=rng)
photos, maps, info = photograph(cfg, rng, maps, fams, crop)
base = resolve(cfg.finetune_preset).render_config.replace(falloff=True)
D = (-0.45, -0.35, -0.25, -0.15, -0.05, 0.0, 0.05, 0.15, 0.25)
SPEC = (0.02, 0.04, 0.08, 0.16, 0.32, 0.64)
GAINS = 2.0 ** np.arange(-0.75, 0.76, 0.25)


def with_lobe(m: Maps, d: float, s: float) -> Maps:
    return m._with({**dict(m.items()), "roughness": np.clip(m.roughness + d, 0.03, 1.0),
                    "specular": np.full_like(m.specular, s)})


with open(out, "a") as f:
    for i in range(n):
        photo = photos[i].permute(1, 2, 0).numpy().copy()
        gt = Maps.unpack(maps[i].permute(1, 2, 0).numpy())
        d = info["draws"][i]
        rc = base.replace(fov_deg=d["fov_deg"])
        rc = physical_config(rc) if d["physical"] else rc
        pred = S.estimate(photo, sess)
        pt = torch.from_numpy(photo).permute(2, 0, 1)[None]
        best = None
        for dd in D:
            for s in SPEC:
                img = render(with_lobe(pred, dd, s), d["light"], rc)
                rt = torch.from_numpy(img).permute(2, 0, 1)[None]
                loss = min(float(render_loss(rt * float(g), pt)) for g in GAINS)
                if best is None or loss < best[0]:
                    best = (loss, dd, s)
        fit = with_lobe(pred, best[1], best[2])
        rec = {"material": i, "family": fams[i], "truth_roughness": round(float(gt.roughness.mean()), 3),
               "truth_specular": round(float(gt.specular.mean()), 3),
               "pred_roughness": round(float(pred.roughness.mean()), 3), "pred_specular": round(float(pred.specular.mean()), 3),
               "fit_d": best[1], "fit_s": best[2]}
        for tag, m in (("preview", pred), ("fit", fit)):
            e = evaluate(m, gt=gt, centre=(photo.shape[0] / 2, photo.shape[1] / 2))
            rec.update({f"{tag}_{k}": round(e[k], 4) for k in ("roughness_rmse", "specular_rmse", "rerender_rmse")})
        f.write(json.dumps(rec) + "\n")
        print(json.dumps(rec), flush=True)
