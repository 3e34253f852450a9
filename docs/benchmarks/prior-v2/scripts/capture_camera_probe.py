"""What the fine-tune's model of the camera costs on the real multi-view capture (bath_tile): every view in turn is
the input photo, refined (``fast`` from a stage-one checkpoint, its recorded recipe) with TrainConfig overrides per
variant, and the maps relit at the other views (``capture_rmse``, :func:`svbrdf.trainer.bench.metrics.evaluate`).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/capture_camera_probe.py CKPT 'LABEL=JSON;...' OUT.json [ITERS] [VIEWS]

A variant's JSON may hold "_calib": "fov" (the renderer's field of view from the input view's calibrated camera
height), "xy" (the flash over the calibrated camera's (x, y)) or "both": an oracle of the view's geometry, which a
user does not have; it measures what estimating it could buy. VIEWS: comma-separated indices (default all).
"""
import json, math, sys, warnings
import numpy as np
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.config import resolve
warnings.simplefilter("ignore")
init, spec, out = sys.argv[1], sys.argv[2], sys.argv[3]
iters = [int(v) for v in (sys.argv[4] if len(sys.argv) > 4 else "0,150").split(",")]
views = None if len(sys.argv) <= 5 else {int(v) for v in sys.argv[5].split(",")}
variants = {}
for item in spec.split(";"):
    label, ovr = item.split("=", 1); variants[label] = json.loads(ovr)
cases = load_cases(__import__("pathlib").Path("../shared/data"), 256, "guo*/0*")
res = {}
for case in cases:
    cap = case.capture
    if views is not None and cap.index not in views:
        continue
    cam, _ = cap.calibration.scene_units(cap.index)
    for label, ovr in variants.items():
        ovr = dict(ovr)
        calib = ovr.pop("_calib", None)
        if calib in ("fov", "both"):
            ovr["render"] = {**resolve("fast").render, "fov_deg": math.degrees(2 * math.atan(1.0 / cam[2]))}
        if calib in ("xy", "both"):
            ovr["flash_position"] = [float(cam[0]), float(cam[1])]
        pts = []
        METHODS["finetune"].run(case, BenchOptions(iters=iters, threads=1, repeats=1, train_overrides=ovr, init=init),
                                "fast", pts.append)
        for p in pts:
            m = evaluate(p.maps, photo=case.photo, capture=cap)
            res.setdefault(f"{label}@{p.iterations}", {})[cap.index] = m["capture_rmse"]
        print(case.name, label, {k: round(v[cap.index], 4) for k, v in res.items() if k.startswith(label + "@")},
              flush=True)
table = {k: {"mean": float(np.mean(list(v.values()))), "views": v} for k, v in res.items()}
for k, v in table.items():
    print(k, round(v["mean"], 4))
json.dump(table, open(out, "w"), indent=1)
