"""Probe (not adopted): normals from the photo's shading under the flash. First order, the high-passed log photo s is
(n_x l_x + n_y l_y) / l_z, so n_xy = a s l_z l_xy / (|l_xy|^2 + eps); prints its correlation with the true normals and
the mean angle error for several strengths a, on dumped maps (dump_maps.py, dump_procedural.py).

    python docs/benchmarks/accuracy/scripts/shading_normals_probe.py runs/flashfree/maps photo
    python docs/benchmarks/accuracy/scripts/shading_normals_probe.py runs/flashfree/proc_raw photo
"""
import sys, glob, numpy as np, torch, kornia
from svbrdf.trainer.bench.metrics import angular_error_deg
from svbrdf.runtime.maps import normalize_normals
files = sorted(glob.glob(sys.argv[1] + "/*.npz"))
src = sys.argv[2]
for eps in (0.05, 0.2):
  cs = []; errs = {a: [] for a in (0, 0.01, 0.02, 0.04, 0.08, 0.15)}
  for f in files:
    z = np.load(f)
    if "gt_normal" not in z: continue
    g = z["gt_normal"]; photo = z["photo"]
    h, w = g.shape[:2]
    dist = 0.5 / np.tan(np.radians(33)) * w
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    L = np.stack([(w/2 - xx), -(h/2 - yy), np.full((h, w), dist)], -1); L /= np.linalg.norm(L, axis=-1, keepdims=True)
    img = photo if src == "photo" else photo / np.clip(z[src], 1e-3, None)
    t = torch.from_numpy(np.log(np.clip(img.mean(-1), 1e-3, None)))[None, None].float()
    s = (t - kornia.filters.gaussian_blur2d(t, (49, 49), (8., 8.), border_type="reflect"))[0, 0].numpy()
    lxy2 = L[..., 0]**2 + L[..., 1]**2
    nx = s * L[..., 2] * L[..., 0] / (lxy2 + eps); ny = s * L[..., 2] * L[..., 1] / (lxy2 + eps)
    def c(a, b): a = a - a.mean(); b = b - b.mean(); return float((a*b).mean() / (a.std()*b.std() + 1e-9))
    cs.append([c(nx, g[..., 0]), c(ny, g[..., 1])])
    for a in errs:
        n = np.stack([a * nx, a * ny, np.ones_like(nx)], -1)
        errs[a].append(angular_error_deg(normalize_normals(n), g))
  print(src, "eps", eps, "corr", np.round(np.mean(cs, 0), 3), " ".join(f"a={a}: {np.mean(v):.3f}" for a, v in errs.items()))
