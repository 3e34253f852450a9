"""Per material: its photo's exposure (stops) and renderer, then the median specular, mean base colour and median
roughness of the truth, of the stage one's maps (0) and of the fine-tune's (150), on held-out procedural materials
(seed 987654, never the shared sets); ``fast`` with the JSON overrides given.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/v2-refine/scripts/level_probe.py 12 runs/v2C2/checkpoint.pt '{}'
"""
import json, sys, warnings
import numpy as np, torch
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.cases import BenchCase
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials
warnings.simplefilter("ignore")
n, init, ovr = int(sys.argv[1]), sys.argv[2], json.loads(sys.argv[3])
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, draws = simulate_photos(maps, PriorConfig(), rng)
for i in range(n):
    photo = photos[i].permute(1, 2, 0).numpy().copy(); gt = Maps.unpack(gts[i].permute(1, 2, 0).numpy())
    case = BenchCase(f"proc{i}", "", "synthetic", "procedural", photo, gt, (128.0, 128.0), None)
    pts = []
    METHODS["finetune"].run(case, BenchOptions(iters=[0, 150], threads=1, repeats=1, train_overrides=ovr, init=init), "fast", pts.append)
    row = [names[i], round(draws[i]["camera"]["ev"], 2), draws[i]["physical"]]
    row += ["gt", round(float(np.median(gt.specular)), 3), round(float(gt.diffuse.mean()), 3), round(float(np.median(gt.roughness)), 3)]
    for p in pts:
        row += [p.iterations, round(float(np.median(p.maps.specular)), 3), round(float(p.maps.diffuse.mean()), 3), round(float(np.median(p.maps.roughness)), 3)]
    print(*row, flush=True)
