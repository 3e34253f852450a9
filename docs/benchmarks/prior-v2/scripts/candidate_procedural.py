"""Stage-one candidates side by side on held-out procedural materials, through the product's preview path.

Each ONNX model (a ``label=path`` argument; ``label=default`` is the packaged model) previews the same realistic
flash photos of ``N`` procedural materials of seed 987654 (not a training seed of any stage one; never the shared
sets) with :func:`svbrdf.runtime.session.estimate` (post-processing as shipped), and every texture set is scored by
the benchmark's :func:`svbrdf.trainer.bench.metrics.evaluate`. Printed: the mean of each measure per model, the flat
normal map's angle beside the normal angle. Written: OUT.json with the means and every record.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/candidate_procedural.py N OUT.json v1=default cand=runs/cand/model.onnx
"""
import json
import sys
import warnings

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.metrics import angular_error_deg, evaluate
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

warnings.simplefilter("ignore")
KEYS = ["rerender_rmse", "input_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg",
        "flat_angle_deg", "normal_slope_corr", "detail_normal", "detail_diffuse", "detail_roughness",
        "grazing_rmse", "grazing_hp_corr", "burn_in"]
n, out = int(sys.argv[1]), sys.argv[2]
models = dict(a.split("=", 1) for a in sys.argv[3:])
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, _ = simulate_photos(maps, PriorConfig(), rng)
sessions = {label: S.load_session(None if path == "default" else path) for label, path in models.items()}
records = []
for i in range(n):
    photo = photos[i].permute(1, 2, 0).numpy().copy()
    gt = Maps.unpack(gts[i].permute(1, 2, 0).numpy())
    flat = np.zeros_like(gt.normal)
    flat[..., 2] = 1.0
    row = {"material": f"proc{i}", "name": names[i]}
    for label, sess in sessions.items():
        m = S.estimate(photo, sess)
        e = evaluate(m, gt=gt, centre=tuple(m.meta["burn_in"]["centre"]))
        e["flat_angle_deg"] = angular_error_deg(flat, gt.normal)
        row[label] = {k: e.get(k) for k in KEYS}
    records.append(row)
    print(row["material"], row["name"], {lb: (round(row[lb]["rerender_rmse"], 4), round(row[lb]["normal_angle_deg"], 2),
                                          round(row[lb]["normal_slope_corr"], 3)) for lb in sessions}, flush=True)
means = {}
for label in sessions:
    means[label] = {}
    for k in KEYS:
        vals = [r[label][k] for r in records if r[label][k] is not None and np.isfinite(r[label][k])]
        means[label][k] = float(np.median(vals)) if k.startswith("detail_") else float(np.mean(vals))
    print(label, {k: round(v, 4) for k, v in means[label].items()})
with open(out, "w") as f:
    json.dump({"command": "python " + " ".join(sys.argv), "n": n, "means": means, "detail": "median over materials",
               "records": records}, f, indent=1)
