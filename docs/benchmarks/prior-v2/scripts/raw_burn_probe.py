"""How much of the flash does a stage one leave in its own maps? The label-free burn-in
(`svbrdf.runtime.burn_in.photo_burn_in`, disc and ring scores per map) of the preview with and without the runtime's
flash-trend removal (`svbrdf.runtime.session.FLASH_TREND`), on held-out procedural materials (seed 31_337_555, never a
training or validation seed), photographed whole at 512 px by the checkpoint's photo model and given to the
runtime at 256 px, beside the truth's own score (its chance level). Issue 26 asks for the burn-in without the trend
removal to be at most the truth's + 0.05.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/raw_burn_probe.py MODEL.onnx CKPT [N]
"""
import dataclasses
import sys

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

KEYS = ("burn_diffuse", "ring_diffuse", "burn_roughness", "ring_roughness", "burn_normal", "ring_normal", "burn_in")
model, ckpt = sys.argv[1], sys.argv[2]
n = int(sys.argv[3]) if len(sys.argv) > 3 else 8
cfg = PriorConfig.from_dict(torch.load(ckpt, weights_only=True)["prior_config"])
cfg = dataclasses.replace(cfg, crop_share=0.0, flat_share=0.0)
sess = S.load_session(model, threads=1)
g = torch.Generator().manual_seed(31_337_555)
maps, fams = sample_materials(n, 512, g)
photos, truths, _ = simulate_photos(maps, cfg, g)
rows = {"truth": [], "with trend removal": [], "without": []}
for i in range(n):
    photo = S._as_image(photos[i].permute(1, 2, 0).numpy().copy(), 256)[1]  # downsized as the runtime does
    truth = Maps.unpack(torch.nn.functional.interpolate(truths[i:i + 1], size=256, mode="area")[0]
                        .permute(1, 2, 0).numpy())
    rows["truth"].append([photo_burn_in(truth, photo)[k] for k in KEYS])
    for label, flash in (("with trend removal", True), ("without", False)):
        S.FLASH_TREND = flash
        rows[label].append([S.estimate(photo, sess, max_size=256).meta["burn_in"][k] for k in KEYS])
    print(fams[i], {k: round(v[-1][-1], 3) for k, v in rows.items()}, flush=True)
print("| maps | " + " | ".join(KEYS) + " |")
print("|---" * (len(KEYS) + 1) + "|")
for label, v in rows.items():
    print(f"| {label} | " + " | ".join(f"{x:.3f}" for x in np.mean(v, axis=0)) + " |")
