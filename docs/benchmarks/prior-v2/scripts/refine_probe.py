"""The default refine (``fast``, 0 and 150 iterations) from a given stage-one checkpoint on held-out procedural
materials (seed 987654, not a training seed; never the shared sets), with TrainConfig overrides per variant; means
of the benchmark's measures (svbrdf.trainer.bench.metrics.evaluate) per variant and count.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/refine_probe.py N CKPT 'LABEL=JSON;...' OUT.json [ITERS]

ITERS: the counts evaluated, comma-separated (default 0,150; 0 alone: the preview only). A variant's JSON may hold
"_oracle_fov": true: the fine-tune's renderer then takes each photo's true field of view (an oracle, to measure what
the fixed field of view of the preset costs); "_oracle_camera": true: the fine-tune is given the whole photo model
as it was drawn (an oracle): the true field of view, renderer (physical or not) and flash position, and the photo
with its exposure and vignetting divided out (then clipped to [0, 1] again; the learned vignetting off). With LEVELS set (``LEVELS=1``), one more line per material and
variant: the photo's exposure (stops) and renderer, then the median specular, mean base colour and median roughness
of the truth and of the maps at each count.
"""
import json, os, sys, time, warnings
import numpy as np, torch
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.cases import BenchCase
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.runtime.camera import vignette
from svbrdf.runtime.render import physical_config
from svbrdf.trainer.config import resolve
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials
warnings.simplefilter("ignore")
n, init, spec, out = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
iters = [int(v) for v in (sys.argv[5] if len(sys.argv) > 5 else "0,150").split(",")]
variants = {}
for item in spec.split(";"):
    label, ovr = item.split("=", 1); variants[label] = json.loads(ovr)
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, draws = simulate_photos(maps, PriorConfig(), rng)
K = ["rerender_rmse", "input_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg", "normal_slope_corr",
     "burn_in", "grazing_rmse", "grazing_hp_corr", "detail_diffuse", "detail_roughness", "detail_normal"]
res = {}


def levels(mp):
    return [round(float(np.median(mp.specular)), 3), round(float(mp.diffuse.mean()), 3),
            round(float(np.median(mp.roughness)), 3)]


for i in range(n):
    photo = photos[i].permute(1, 2, 0).numpy().copy(); gt = Maps.unpack(gts[i].permute(1, 2, 0).numpy())
    case = BenchCase(f"proc{i}", "", "synthetic", "procedural", photo, gt, (128.0, 128.0), None)
    for label, ovr in variants.items():
        pts = []
        ovr = dict(ovr)
        if ovr.pop("_oracle_fov", False):
            ovr["render"] = {**resolve("fast").render, "fov_deg": draws[i]["fov_deg"]}
        run_case = case
        if ovr.pop("_oracle_camera", False):
            d, rc = draws[i], resolve("fast").render_config.replace(fov_deg=draws[i]["fov_deg"], falloff=True)
            ovr["render"] = (physical_config(rc) if d["physical"] else rc).to_dict()
            ovr["flash_position"] = [float(d["light"][0]), float(d["light"][1])]
            ovr["learn_vignetting"] = False
            cam = d["camera"]
            gain = 2.0 ** cam["ev"] * vignette(256, 256, cam["vignetting"])
            run_case = BenchCase(case.name, "", "synthetic", "procedural", np.clip(photo / gain, 0.0, 1.0).astype(np.float32),
                                 gt, case.centre, None)
        opts = BenchOptions(iters=iters, threads=1, repeats=1, train_overrides=ovr, init=init)
        METHODS["finetune"].run(run_case, opts, "fast", pts.append)
        for p in pts:
            m = evaluate(p.maps, gt=gt, centre=case.centre)
            res.setdefault((label, p.iterations), []).append({k: m.get(k, float("nan")) for k in K})
        if os.environ.get("LEVELS"):
            row = [names[i], label, round(draws[i]["camera"]["ev"], 2), draws[i]["physical"], "gt", *levels(gt)]
            for p in pts:
                row += [p.iterations, *levels(p.maps)]
            print(*row, flush=True)
    print(i, names[i], {f"{l}@{it}": round(v[-1]["rerender_rmse"], 4) for (l, it), v in res.items()}, flush=True)
table = {f"{l}@{it}": {k: float(np.mean([r[k] for r in v])) for k in K} for (l, it), v in res.items()}
for k, v in table.items(): print(k, {a: round(b, 4) for a, b in v.items()})
json.dump(table, open(out, "w"), indent=1)
