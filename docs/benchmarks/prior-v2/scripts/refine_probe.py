"""The default refine (``fast``, 0 and 150 iterations) from a given stage-one checkpoint on held-out procedural
materials (seed 987654, not a training seed; never the shared sets), with TrainConfig overrides per variant; means
of the benchmark's measures (svbrdf.trainer.bench.metrics.evaluate) per variant and count.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/refine_probe.py N CKPT 'LABEL=JSON;...' OUT.json
"""
import json, sys, time, warnings
import numpy as np, torch
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.cases import BenchCase
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials
warnings.simplefilter("ignore")
n, init, spec, out = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
variants = {}
for item in spec.split(";"):
    label, ovr = item.split("=", 1); variants[label] = json.loads(ovr)
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, _ = simulate_photos(maps, PriorConfig(), rng)
K = ["rerender_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg", "normal_slope_corr", "burn_in", "grazing_hp_corr"]
res = {}
for i in range(n):
    photo = photos[i].permute(1, 2, 0).numpy().copy(); gt = Maps.unpack(gts[i].permute(1, 2, 0).numpy())
    case = BenchCase(f"proc{i}", "", "synthetic", "procedural", photo, gt, (128.0, 128.0), None)
    for label, ovr in variants.items():
        pts = []
        opts = BenchOptions(iters=[0, 150], threads=1, repeats=1, train_overrides=ovr, init=init)
        METHODS["finetune"].run(case, opts, "fast", pts.append)
        for p in pts:
            m = evaluate(p.maps, gt=gt, centre=case.centre)
            res.setdefault((label, p.iterations), []).append({k: m[k] for k in K})
    print(i, names[i], {f"{l}@{it}": round(v[-1]["rerender_rmse"], 4) for (l, it), v in res.items()}, flush=True)
table = {f"{l}@{it}": {k: float(np.mean([r[k] for r in v])) for k in K} for (l, it), v in res.items()}
for k, v in table.items(): print(k, {a: round(b, 4) for a, b in v.items()})
json.dump(table, open(out, "w"), indent=1)
