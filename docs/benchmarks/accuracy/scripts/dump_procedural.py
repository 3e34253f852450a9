"""The held-out procedural tuning set: 32 (or N) procedural materials, seed 987654 (not a training seed of the
prior), rendered as realistic flash photos (svbrdf.trainer.prior.simulate_photos); preview and fast fine-tune
(150 it) maps dumped as npz like dump_maps.py. PART/PARTS split the materials over processes.

    OMP_NUM_THREADS=1 python docs/benchmarks/accuracy/scripts/dump_procedural.py 32 0 2 runs/flashfree/proc 0,150 &
    OMP_NUM_THREADS=1 python docs/benchmarks/accuracy/scripts/dump_procedural.py 32 1 2 runs/flashfree/proc 0,150
"""
import sys, time, numpy as np, torch, warnings
from pathlib import Path
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.cases import BenchCase
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials
warnings.simplefilter("ignore")
n, part, parts, out = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4])
iters = [int(i) for i in (sys.argv[5] if len(sys.argv) > 5 else "0,150").split(",")]
out.mkdir(parents=True, exist_ok=True)
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, draws = simulate_photos(maps, PriorConfig(), rng)
import os, json
import svbrdf.runtime.session as S
S.FLASH_TREND = False  # the raw maps: the variants are applied afterwards
opts = BenchOptions(iters=iters, threads=1, repeats=1,
                    train_overrides={"flash_trend": False, **json.loads(os.environ.get("OVR", "{}"))})
for i in range(part, n, parts):
    f = out / f"proc{i:03d}_{names[i]}.npz"
    if f.exists(): continue
    t = time.time()
    photo = photos[i].permute(1, 2, 0).numpy().copy()
    gt = Maps.unpack(gts[i].permute(1, 2, 0).numpy())
    c = BenchCase(f"proc{i}", "", "synthetic", "procedural", photo, gt, (128.0, 128.0), None)
    arrs = {"photo": photo, "centre": np.array(c.centre)}
    for k, a in gt.items(): arrs[f"gt_{k}"] = a
    pts = []
    METHODS["preview"].run(c, opts, None, pts.append)
    for k, a in pts[0].maps.items(): arrs[f"preview_{k}"] = a
    pts = []
    METHODS["finetune"].run(c, opts, "fast", pts.append)
    for p in pts:
        if p.iterations:
            for k, a in p.maps.items(): arrs[f"fast{p.iterations}_{k}"] = a
    np.savez_compressed(f, **arrs)
    print(i, names[i], f"{time.time()-t:.1f}s", flush=True)
