"""The specular map after the flash-trend removal, blurred (Gaussian sigma 0, 1, 2, 4, 8 px) or made constant (its
mean, "99"): specular and re-render RMSE against the ground truth, on dumped maps (dump_maps.py, dump_procedural.py).

    python docs/benchmarks/accuracy/scripts/specular_detail.py runs/flashfree/maps fast150
    python docs/benchmarks/accuracy/scripts/specular_detail.py runs/flashfree/proc_raw preview
"""
import sys, glob, numpy as np, torch, kornia, warnings
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.flash_trend import remove_flash_trend
from svbrdf.trainer.bench.metrics import evaluate
warnings.simplefilter("ignore")
res = {}; M = sys.argv[2]
for f in sorted(glob.glob(sys.argv[1] + "/*.npz")):
    z = np.load(f)
    if "gt_diffuse" not in z: continue
    gt = Maps(**{n: z[f"gt_{n}"] for n in ("diffuse", "specular", "roughness", "normal")})
    m = remove_flash_trend(Maps(**{n: z[f"{M}_{n}"] for n in ("diffuse", "specular", "roughness", "normal")}), photo=z["photo"])
    for s in (0, 1, 2, 4, 8, 99):
        sp = m.specular
        if s == 99: sp = np.full_like(sp, sp.mean())
        elif s:
            t = torch.from_numpy(sp.transpose(2, 0, 1))[None]
            sp = kornia.filters.gaussian_blur2d(t, (6*s+1, 6*s+1), (float(s), float(s)), border_type="reflect")[0].numpy().transpose(1, 2, 0)
        r = evaluate(m._with({**dict(m.items()), "specular": sp}), gt=gt)
        res.setdefault(s, []).append((r["specular_rmse"], r["rerender_rmse"]))
for s, v in res.items(): print("blur", s, len(v), "spec %.4f rerender %.4f" % tuple(np.mean(v, 0)))
