"""Which map's change makes a fine-tune relight the real capture worse than its stage one: every bath_tile view
previewed (0 iterations) and fine-tuned (``fast``, 150 iterations, TrainConfig overrides as JSON) from one stage
one; then the preview's maps with one map at a time taken from the fine-tune (and the reverse), each scored by the
benchmark's capture relighting (the maps relit at the capture's other views against the real photos).

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/photo-context/scripts/map_swap.py CKPT MODEL OUT.json ['{...}']
"""
import dataclasses, json, sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime.maps import MAP_NAMES
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import evaluate

warnings.simplefilter("ignore")
ckpt, model, out = sys.argv[1], sys.argv[2], sys.argv[3]
ovr = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
res = {}
for case in load_cases(Path("/work/shared/data"), 256, "guo*/*"):
    pts = []
    METHODS["finetune"].run(case, BenchOptions(iters=[0, 150], threads=1, repeats=1, train_overrides=ovr, init=ckpt,
                                               model=model), "fast", pts.append)
    pre, fin = (p.maps for p in sorted(pts, key=lambda p: p.iterations))
    variants = {"preview": pre, "fine-tune": fin}
    for m in MAP_NAMES:
        variants[f"preview + fine-tuned {m}"] = dataclasses.replace(pre, **{m: getattr(fin, m)})
        variants[f"fine-tune + preview {m}"] = dataclasses.replace(fin, **{m: getattr(pre, m)})
    for k, mp in variants.items():
        res.setdefault(k, []).append(evaluate(mp, photo=case.photo, centre=case.centre, capture=case.capture)["capture_rmse"])
    print(case.name, {k: round(v[-1], 4) for k, v in res.items()}, flush=True)
means = {k: float(np.mean(v)) for k, v in res.items()}
for k, v in means.items():
    print(f"{k}: {v:.4f}")
Path(out).write_text(json.dumps({"overrides": ovr, "means": means, "per_view": res}, indent=1))
