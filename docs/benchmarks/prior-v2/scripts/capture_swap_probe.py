"""Which map's change makes the refine relight the real capture (bath_tile) worse than its preview: every view in
turn is the input, refined (``fast`` from CKPT, its recorded recipe, ITERS iterations), and the refined maps relit
at the other views with one map at a time put back to the preview's (``capture_rmse``, mean over the views).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/capture_swap_probe.py CKPT OUT.json [ITERS] [OVERRIDES_JSON]
"""
import dataclasses, json, sys, warnings
import numpy as np
from pathlib import Path
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import capture_errors
warnings.simplefilter("ignore")
init, out = sys.argv[1], sys.argv[2]
it = int(sys.argv[3]) if len(sys.argv) > 3 else 150
ovr = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
NAMES = ("diffuse", "specular", "roughness", "normal")
res = {}
for case in load_cases(Path("../shared/data"), 256, "guo*/0*"):
    pts = []
    METHODS["finetune"].run(case, BenchOptions(iters=[0, it], threads=1, repeats=1, train_overrides=dict(ovr), init=init),
                            "fast", pts.append)
    pre, ref = pts[0].maps, pts[-1].maps
    rows = {"preview": pre, "refine": ref}
    for n in NAMES:
        rows[f"refine, {n} of the preview"] = dataclasses.replace(ref, **{n: getattr(pre, n)})
        rows[f"preview, {n} of the refine"] = dataclasses.replace(pre, **{n: getattr(ref, n)})
    for label, mp in rows.items():
        res.setdefault(label, []).append(capture_errors(mp.clipped(), case.capture)["capture_rmse"])
    print(case.name, {k: round(v[-1], 4) for k, v in res.items()}, flush=True)
table = {k: float(np.mean(v)) for k, v in res.items()}
for k, v in table.items():
    print(f"{k}: {v:.4f}")
json.dump({"iters": it, "overrides": ovr, "mean": table, "views": res}, open(out, "w"), indent=1)
