"""The fine-tune's flash geometry on the real multi-view capture (bath_tile, 9 views): each view refined with
TrainConfig overrides per variant, its maps relit at the other views (the benchmark's capture measure). Variants may
use the capture's calibration of the refined view (an oracle, to measure what the assumed geometry costs):
``"_oracle_position": true`` puts the flash at the view's calibrated (x, y), ``"_oracle_fov": true`` sets the field
of view so the camera distance is the calibrated height.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/flash-position/scripts/capture_probe.py INIT MODEL 'LABEL=JSON;...' OUT.json [ITERS]

INIT: a stage-one checkpoint (or "default"); MODEL: its ONNX export for the preview (or "default").
"""
import json, math, sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime.burn_in import highlight_centre
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.config import resolve

warnings.simplefilter("ignore")
init, model, spec, out = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
iters = [int(v) for v in (sys.argv[5] if len(sys.argv) > 5 else "0,150").split(",")]
variants = dict((item.split("=", 1)[0], json.loads(item.split("=", 1)[1])) for item in spec.split(";"))
cases = load_cases(Path("/work/shared/data"), 256, "guo*/*")
K = ["capture_rmse", "capture_ssim", "input_rmse", "burn_in"]
res, rows = {}, []
for case in cases:
    cam, _ = case.capture.calibration.scene_units(case.capture.index)
    cy, cx = highlight_centre(case.photo)
    located = (2 * cx / 256 - 1, 1 - 2 * cy / 256)
    for label, ovr in variants.items():
        ovr = dict(ovr)
        if ovr.pop("_oracle_position", False):
            ovr["flash_position"] = [float(cam[0]), float(cam[1])]
        if ovr.pop("_oracle_fov", False):
            ovr["render"] = {**resolve("fast").render, "fov_deg": math.degrees(2 * math.atan(1 / float(cam[2])))}
        opts = BenchOptions(iters=iters, threads=1, repeats=1, train_overrides=ovr,
                            init=None if init == "default" else init, model=None if model == "default" else model)
        pts = []
        METHODS["finetune"].run(case, opts, "fast", pts.append)
        for p in pts:
            m = evaluate(p.maps, photo=case.photo, centre=case.centre, capture=case.capture)
            res.setdefault((label, p.iterations), []).append({k: m.get(k, float("nan")) for k in K})
    rows.append({"case": case.name, "camera": [round(float(v), 3) for v in cam],
                 "located": [round(v, 3) for v in located],
                 **{f"{l}@{it}": round(v[-1]["capture_rmse"], 4) for (l, it), v in res.items()}})
    print(rows[-1], flush=True)
table = {f"{l}@{it}": {k: float(np.mean([r[k] for r in v])) for k in K} for (l, it), v in res.items()}
for k, v in table.items():
    print(k, {m: round(x, 4) for m, x in v.items()})
Path(out).write_text(json.dumps({"variants": variants, "iters": iters, "means": table, "cases": rows}, indent=1))
