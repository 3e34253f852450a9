"""Metrics of dumped maps (dump_maps.py, dump_procedural.py) as they are and after post-processing variants:
flash-trend removal with several sets of widths (svbrdf.runtime.flash_trend), a non-parametric annular profile
removal (annN: the mean of every N px ring around the highlight), and the normals scaled towards flat (SHRINKS).

    python docs/benchmarks/accuracy/scripts/post_variants.py runs/flashfree/maps preview,fast150,fast300 1,0.5,0
"""
import sys, glob, numpy as np, warnings
from collections import defaultdict
from svbrdf.runtime.maps import Maps, normalize_normals
from svbrdf.runtime.flash_trend import remove_flash_trend
from svbrdf.trainer.bench.metrics import evaluate
warnings.simplefilter("ignore")
files = sorted(glob.glob(sys.argv[1] + "/*.npz"))
methods = sys.argv[2].split(",")
widthsets = {"none": None, "w4": (0.05, 0.1, 0.2, 0.4), "w3": (0.1, 0.2, 0.4), "w5": (0.03, 0.06, 0.12, 0.25, 0.5), "w2": (0.1, 0.3), "w4n": (0.03, 0.07, 0.15, 0.3)}
shrinks = [1.0]
if len(sys.argv) > 3: shrinks = [float(s) for s in sys.argv[3].split(",")]
from svbrdf.runtime.burn_in import highlight_centre
def annular(maps, photo, binw):
    h, w = maps.shape
    cy, cx = highlight_centre(photo)
    r = np.hypot(np.arange(h)[:, None] + 0.5 - cy, np.arange(w)[None, :] + 0.5 - cx)
    idx = (r / binw).astype(int).ravel()
    cnt = np.bincount(idx)
    out = dict(maps.items())
    for n in ("diffuse", "specular", "roughness"):
        a = getattr(maps, n).astype(np.float64)
        res = a.copy()
        for c in range(a.shape[-1]):
            v = a[..., c].ravel()
            prof = np.bincount(idx, v) / np.maximum(cnt, 1)
            res[..., c] -= (prof[idx] - v.mean()).reshape(h, w)
        out[n] = np.clip(res, 0, 1).astype(np.float32)
    return maps._with(out)
widthsets.update({"ann2": None, "ann4": None, "ann1": None})
acc = defaultdict(lambda: defaultdict(list))
KEYS = ["rerender_rmse", "input_rmse", "input_rmse_falloff", "burn_in", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg", "burn_normal", "burn_diffuse", "burn_specular", "burn_roughness"]
for f in files:
    z = np.load(f)
    photo = z["photo"]; centre = tuple(z["centre"])
    gt = Maps(**{n: z[f"gt_{n}"] for n in ("diffuse", "specular", "roughness", "normal")}) if "gt_diffuse" in z else None
    kind = "syn" if gt is not None else "photo"
    for m in methods:
        if f"{m}_diffuse" not in z: continue
        maps = Maps(**{n: z[f"{m}_{n}"] for n in ("diffuse", "specular", "roughness", "normal")})
        for wn, ws in widthsets.items():
            if wn.startswith("ann"):
                pm = annular(maps, photo, float(wn[3:]))
            else:
                pm = maps if ws is None else remove_flash_trend(maps, photo=photo, widths=ws)
            for s in shrinks:
                mm = pm
                if s != 1.0:
                    n = pm.normal.copy(); n[..., :2] *= s
                    mm = pm._with({**dict(pm.items()), "normal": normalize_normals(n)})
                r = evaluate(mm, gt=gt, photo=None if gt is not None else photo, centre=centre)
                for k in KEYS:
                    if k in r: acc[(kind, m, wn, s)][k].append(r[k])
print("kind  method  widths shrink  n  " + " ".join(k[:12] for k in KEYS))
for key in sorted(acc):
    d = acc[key]
    n = len(d["burn_in"])
    print(*key, n, " ".join(f"{np.mean(d[k]):.4f}" if k in d else "-" for k in KEYS))
