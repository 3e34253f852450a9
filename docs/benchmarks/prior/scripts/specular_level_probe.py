"""Probe (not adopted): the preview's specular level fitted to the photo (the level, among 24 from 0.005 to 1, whose
flash re-render at half size is closest to the photo; the other maps as the preview gives them, after the
flash-trend removal), against the level the preview predicts (its mean). On dumped maps
(docs/benchmarks/accuracy/scripts/dump_maps.py, dump_procedural.py).

    python docs/benchmarks/prior/scripts/specular_level_probe.py runs/flashfree/maps
    python docs/benchmarks/prior/scripts/specular_level_probe.py runs/flashfree/proc_raw
"""
import sys, glob, numpy as np, warnings
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.flash_trend import remove_flash_trend, uniform_specular
from svbrdf.runtime.render import rerender_rmse
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.config import resolve
warnings.simplefilter("ignore")
cfg = resolve("fast").render_config
levels = np.geomspace(0.005, 1.0, 24)
res = {"mean": [], "fit": []}
for f in sorted(glob.glob(sys.argv[1] + "/*.npz")):
    z = np.load(f)
    if "gt_diffuse" not in z: continue
    gt = Maps(**{n: z[f"gt_{n}"] for n in ("diffuse", "specular", "roughness", "normal")})
    m = uniform_specular(remove_flash_trend(Maps(**{n: z[f"preview_{n}"] for n in ("diffuse", "specular", "roughness", "normal")}), photo=z["photo"]))
    photo = z["photo"]
    small = lambda a: a[::2, ::2]
    ms = Maps(**{n: small(a) for n, a in m.items()})
    errs = []
    for s in levels:
        cand = ms._with({**dict(ms.items()), "specular": np.full_like(ms.specular, s)})
        errs.append(rerender_rmse(cand, small(photo), [None], cfg))
    best = levels[int(np.argmin(errs))]
    fit = m._with({**dict(m.items()), "specular": np.full_like(m.specular, best)})
    for k, v in (("mean", m), ("fit", fit)):
        r = evaluate(v, gt=gt)
        res[k].append((r["specular_rmse"], r["rerender_rmse"], float(v.specular.mean()), float(gt.specular.mean())))
for k, v in res.items():
    a = np.array(v); print(k, len(a), "spec %.4f rerender %.4f" % tuple(a[:, :2].mean(0)))
