"""Dump the maps of the preview and of the fast fine-tune (150, 300 it) of every shared case as npz, for offline
post-processing experiments (the flash-trend ablation of docs/benchmarks/accuracy/README.md).

    OMP_NUM_THREADS=1 python docs/benchmarks/accuracy/scripts/dump_maps.py "*Des18*,henzler-flash/test/0*" runs/flashfree/maps 0,150,300
    OMP_NUM_THREADS=1 python docs/benchmarks/accuracy/scripts/dump_maps.py "*Des19*,*img_highlight_aware*,henzler-flash/test/2*" runs/flashfree/maps 0,150,300

OVR='{"key": value}' in the environment adds training overrides. The maps are dumped raw (no flash-trend removal
in the preview nor in the fine-tune); the variants are applied afterwards by post_variants.py.
"""
import sys, time, numpy as np
from pathlib import Path
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.methods import METHODS, BenchOptions

spec, out = sys.argv[1], Path(sys.argv[2])
iters = [int(i) for i in (sys.argv[3] if len(sys.argv) > 3 else "0,150").split(",")]
presets = (sys.argv[4] if len(sys.argv) > 4 else "fast").split(",")
out.mkdir(parents=True, exist_ok=True)
cases = load_cases(default_data(), 256, spec)
import os, json
import svbrdf.runtime.session as S
S.FLASH_TREND = False  # the raw maps: the variants are applied afterwards
opts = BenchOptions(iters=iters, threads=1, repeats=1,
                    train_overrides={"flash_trend": False, **json.loads(os.environ.get("OVR", "{}"))})
for c in cases:
    key = c.name.replace("/", "__").replace(";", "_")
    f = out / f"{key}.npz"
    if f.exists():
        continue
    t = time.time()
    arrs = {"photo": c.photo, "centre": np.array(c.centre)}
    if c.gt is not None:
        for n, a in c.gt.items():
            arrs[f"gt_{n}"] = a
    pts = []
    METHODS["preview"].run(c, opts, None, pts.append)
    for n, a in pts[0].maps.items():
        arrs[f"preview_{n}"] = a
    for preset in presets:
        pts = []
        METHODS["finetune"].run(c, opts, preset, pts.append)
        for p in pts:
            if p.iterations == 0:
                continue
            for n, a in p.maps.items():
                arrs[f"{preset}{p.iterations}_{n}"] = a
    np.savez_compressed(f, **arrs)
    print(c.name, f"{time.time()-t:.1f}s", flush=True)
