"""Where a stage one's height (and roughness) sit on their tanh: the pre-activation level and spread, the tanh's
mean slope there (1 = unsaturated), and the tilt of the normals against the truth's, on held-out procedural photos.

    python docs/benchmarks/prior-v2/scripts/height_probe.py CHECKPOINT [N]

N whole photos (default 8) from the held-out procedural seed of the benchmarks (987654), drawn with the
checkpoint's own prior settings (whole photos, no crops).
"""
import dataclasses
import json
import sys

import torch

from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.checkpoint import generator_from_checkpoint, load_checkpoint
from svbrdf.trainer.prior import PriorConfig, sample_batch

torch.set_num_threads(1)
ckpt = load_checkpoint(sys.argv[1])
n = int(sys.argv[2]) if len(sys.argv) > 2 else 8
g = generator_from_checkpoint(ckpt).eval()
cfg = PriorConfig.from_dict(ckpt["prior_config"]) if "prior_config" in ckpt else PriorConfig()
cfg = dataclasses.replace(cfg, crop_share=0.0, flat_share=0.0)
photos, maps, info = sample_batch(cfg, torch.Generator().manual_seed(987654), batch=n)
with torch.no_grad():
    pre = g._decoded("decoder_nr", g.forward_features(photos)) + g.out_offset[0:2].view(1, 2, 1, 1)
    out = g(photos)


def tilt(m):
    return float(torch.rad2deg(torch.acos(m[:, 2].clamp(-1, 1))).mean())


report = {"checkpoint": sys.argv[1], "step": ckpt.get("step"), "height_activation": g.cfg.height_activation,
          "photos": n, "families": info["families"]}
for c, name in enumerate(("height", "roughness")):
    y = pre[:, c]
    report[name] = {"pre_mean": round(float(y.mean()), 3), "pre_std_within_photo": round(float(y.flatten(1).std(1).mean()), 4),
                    "pre_min": round(float(y.min()), 3), "pre_max": round(float(y.max()), 3),
                    "tanh_mean_slope": (round(float((1 - torch.tanh(y) ** 2).mean()), 4)
                                        if name == "roughness" or g.cfg.height_activation == "tanh" else None)}
report["tilt_deg"] = round(tilt(out[:, SLICES["normal"]]), 3)
report["truth_tilt_deg"] = round(tilt(maps[:, SLICES["normal"]]), 3)
print(json.dumps(report, indent=1))
