"""A radial-profile removal on cached maps (``lobe_cache.py``): the part of each map that depends only on the
distance to the flash highlight (annulus means, shrunk towards the map's mean where an annulus has few pixels)
subtracted from the diffuse and roughness, as an extra step after the shipped post-processing. Benchmark measures
averaged per variant.

    python docs/benchmarks/refine-detail/lobe-and-rings/scripts/radial_probe.py CACHE_DIR OUT.json N0[,N0...] [MAPS]
"""
import pickle, sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime.burn_in import photo_burn_in
sys.path.insert(0, str(Path(__file__).parent))
from rings_lib import profile_beyond_chance, write_means  # noqa: E402
from svbrdf.trainer.bench.metrics import evaluate

warnings.simplefilter("ignore")
cache, out = Path(sys.argv[1]), Path(sys.argv[2])
n0s = [float(x) for x in sys.argv[3].split(",") if x not in ("", "-")]
names = (sys.argv[4] if len(sys.argv) > 4 else "diffuse,roughness").split(",")
KEYS = ["rerender_rmse", "input_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "grazing_rmse", "burn_in",
        "ring_roughness", "ring_diffuse", "detail_roughness", "detail_diffuse", "capture_rmse", "capture_ssim"]


def radial_profile(field, centre, n0, bin_px=2.0):
    """(H, W) the radial part of ``field`` (H, W, C) around ``centre``: annulus means minus the mean, times
    n / (n + n0) (n the annulus's pixels), per channel."""
    h, w, c = field.shape
    yy, xx = np.mgrid[0:h, 0:w]
    r = np.hypot(yy + 0.5 - centre[0], xx + 0.5 - centre[1])
    k = (r / bin_px).astype(int)
    n = np.bincount(k.ravel())
    out = np.zeros_like(field, dtype=np.float64)
    for j in range(c):
        g = field[..., j].astype(np.float64)
        s = np.bincount(k.ravel(), g.ravel(), minlength=len(n))
        dev = np.where(n > 0, s / np.maximum(n, 1) - g.mean(), 0.0) * n / (n + n0)
        out[..., j] = dev[k]
    return out


rows, per = {}, {}
for f in sorted(cache.glob("*.pkl")):
    d = pickle.loads(f.read_bytes())
    case = d["case"]
    for src in ("preview", "fast"):
        m0 = d[src]
        centre = photo_burn_in(m0, case.photo)["centre"] or (m0.shape[0] / 2, m0.shape[1] / 2)
        variants = {src: m0}
        for n0 in n0s:
            new = dict(m0.items())
            for nm in names:
                a = np.asarray(getattr(m0, nm), np.float32)
                new[nm] = np.clip(a - radial_profile(a, centre, n0), 0, 1).astype(np.float32)
            variants[f"{src}+radial{n0:g}"] = m0._with(new)
        rough = np.asarray(m0.roughness, np.float32)
        variants[f"{src}+profile"] = m0._with({**dict(m0.items()), "roughness": np.clip(
            rough - profile_beyond_chance(rough, centre), 0, 1).astype(np.float32)})
        for name, m in variants.items():
            e = evaluate(m, gt=case.gt, photo=None if case.gt is not None else case.photo, centre=case.centre,
                         capture=case.capture)
            rows.setdefault((case.kind, name), []).append(e)
            per.setdefault(case.name, {})[name] = {k: e.get(k) for k in KEYS}
    print(case.name, flush=True)
write_means(rows, per, KEYS, out)
