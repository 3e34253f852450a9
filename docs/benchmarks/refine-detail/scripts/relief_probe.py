"""Probe (issue 27, item 1): is the photo's relief recoverable from the flash's oblique shading, to first order?

For each ground-truth case: the correlation of the photo's high-passed log luminance with the first-order shading
of the true normals, ``-(slope . l_xy / l_z)``, and with the true base colour's; then a stationary Wiener (MAP)
estimate of a height field from the photo's detail, the prior variances fitted from how the detail's local
variance grows with ``|l_xy / l_z|^2``, scored by slope correlation and normal angle against the flat map's.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/relief_probe.py '*Des19*'
"""
import sys, json
import numpy as np
from pathlib import Path
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.metrics import gaussian_blur, _corr, _slopes, angular_error_deg
from svbrdf.runtime.render import light_vectors, ZHAO, RenderConfig
from svbrdf.runtime.maps import normalize_normals

DATA = Path(__file__).resolve().parents[4].parent / "shared" / "data"
spec = sys.argv[1] if len(sys.argv) > 1 else "*Des19*"
size = 256
cases = load_cases(DATA, size, spec)


def grad(h):  # forward differences, periodic-free (last = 0); returns hx (along +x = columns), hy (+y = up rows)
    gx = np.zeros_like(h); gy = np.zeros_like(h)
    gx[:, :-1] = h[:, 1:] - h[:, :-1]
    gy[:-1, :] = h[:-1, :] - h[1:, :]  # +y up: row i is above row i+1
    return gx, gy


def gradT(px, py):  # adjoint of grad
    out = np.zeros_like(px)
    out[:, 1:] += px[:, :-1]; out[:, :-1] -= px[:, :-1]
    out[:-1, :] += py[:-1, :]; out[1:, :] -= py[:-1, :]
    return out


def cg(Aop, b, x0, iters=300):
    x = x0.copy(); r = b - Aop(x); p = r.copy(); rs = np.sum(r * r)
    for _ in range(iters):
        Ap = Aop(p); a = rs / max(np.sum(p * Ap), 1e-30)
        x += a * p; r -= a * Ap; rn = np.sum(r * r)
        if rn < 1e-12 * np.sum(b * b): break
        p = r + rn / rs * p; rs = rn
    return x


rows = []
for bc in cases:
    photo, gt = bc.photo, bc.gt
    h, w = photo.shape[:2]
    cfg = RenderConfig(**bc.simulation["render_config"]) if (bc.simulation or {}).get("render_config") else ZHAO
    _, l, _ = light_vectors(h, w, None, cfg)
    gxl, gyl = l[..., 0] / l[..., 2], l[..., 1] / l[..., 2]
    luma = photo @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    valid = (photo.max(-1) < 0.98) & (luma > 1e-3)
    L = np.log(np.maximum(luma, 1e-3))
    sig = 8.0
    D = L - gaussian_blur(L, sig)
    D[~valid] = 0
    # GT shading, first order: -(slope . g) where slope per scene unit; pixel size = 2 / w scene units
    s = _slopes(gt.normal)
    S = -(s[..., 0] * gxl + s[..., 1] * gyl)
    S_hp = S - gaussian_blur(S, sig)
    alb = np.log(np.maximum(gt.diffuse @ np.array([0.2126, 0.7152, 0.0722], np.float32), 1e-3))
    A_hp = alb - gaussian_blur(alb, sig)
    m = valid
    c_shade = _corr(D[m], S_hp[m]); c_alb = _corr(D[m], A_hp[m])
    # stationarity fit: local var of D vs |g|^2
    loc = gaussian_blur((D * D), 16)
    g2 = gxl ** 2 + gyl ** 2
    X = np.stack([np.ones(m.sum()), g2[m]], 1)
    coef, *_ = np.linalg.lstsq(X, loc[m], rcond=None)
    varA, varS = float(coef[0]), float(coef[1])  # varS: var of slope-projected (per unit g) shading
    # Wiener/MAP: h in pixel units -> slope per scene unit = grad(h) * (w / 2)
    k = w / 2.0
    sx_var = max(varS, 0.0)
    res = {"case": bc.name, "corr_D_shading": round(c_shade, 3), "corr_D_albedo": round(c_alb, 3),
           "varA": varA, "varS": varS}
    if sx_var > 0:
        lam = varA / sx_var
        wgt = valid.astype(np.float64)

        def G(hh):
            hx, hy = grad(hh)
            return -(hx * gxl + hy * gyl) * k

        def GT(r):
            return gradT(-r * gxl * k, -r * gyl * k)

        def Aop(hh):
            hx, hy = grad(hh)
            return GT(wgt * G(hh)) + lam * gradT(hx * k, hy * k)

        b = GT(wgt * D)
        hh = cg(Aop, b, np.zeros_like(D), 400)
        hx, hy = grad(hh)
        est = np.stack([hx * k, hy * k], -1)
        est -= est.reshape(-1, 2).mean(0)
        res["slope_corr"] = round(_corr(est, s), 3)
        # high-pass slope corr (as in band)
        n_est = np.concatenate([-est, np.ones_like(est[..., :1])], -1)
        n_est = normalize_normals(n_est.astype(np.float32))
        flat = np.zeros_like(n_est); flat[..., 2] = 1
        res["angle_est"] = round(angular_error_deg(n_est, gt.normal), 2)
        res["angle_flat"] = round(angular_error_deg(flat, gt.normal), 2)
        res["std_ratio"] = round(float(np.sqrt((est ** 2).sum(-1).mean() / (s ** 2).sum(-1).mean())), 3)
    rows.append(res)
    print(json.dumps(res), flush=True)

keys = ["corr_D_shading", "corr_D_albedo", "slope_corr", "angle_est", "angle_flat", "std_ratio"]
print({k: round(float(np.mean([r[k] for r in rows if k in r])), 3) for k in keys})
