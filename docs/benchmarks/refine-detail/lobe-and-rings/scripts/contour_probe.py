"""The roughness's dependence on the flash's brightness removed (a probe): the photo's log luminance blurred to the
scale of the flash's fall-off (sigma = SIGMA of the width) labels every pixel with how strongly the flash lit it;
the roughness's mean per level (BINS equal-count levels) minus its mean, shrunk like the radial profile of
svbrdf.runtime.flash_trend (chance variance of a level's mean), is subtracted, interpolated over the level. The
radial profile follows circles around the highlight; this follows the highlight's own shape (the ovals a network
draws along an iso-brightness contour of the photo). On cached maps (``lobe_cache.py``), after the shipped steps.

    python docs/benchmarks/refine-detail/lobe-and-rings/scripts/contour_probe.py CACHE_DIR OUT.json [SHEET.png NAMES]
"""
import pickle, sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime.burn_in import photo_burn_in
sys.path.insert(0, str(Path(__file__).parent))
from svbrdf.runtime.tiling import block_mean
from svbrdf.trainer.bench.metrics import evaluate, gaussian_blur

warnings.simplefilter("ignore")
from rings_lib import profile_beyond_chance, write_means  # noqa: E402
SIGMA, BINS, CHANCE = 0.03, 64, 4.0
cache, out = Path(sys.argv[1]), Path(sys.argv[2])
sheet = (Path(sys.argv[3]), sys.argv[4].split(",")) if len(sys.argv) > 4 else None
KEYS = ["rerender_rmse", "input_rmse", "roughness_rmse", "grazing_rmse", "burn_in", "ring_roughness",
        "burn_roughness", "detail_roughness", "capture_rmse", "capture_ssim"]


def flash_levels(photo):
    lum = np.log(np.asarray(photo, np.float64).mean(-1) + 1e-3)
    return gaussian_blur(lum, SIGMA * photo.shape[1])


def contour_profile(field, level):
    """(H, W) what ``field`` (H, W) owes to ``level`` (H, W) beyond chance."""
    g = field.astype(np.float64) - field.mean()
    edges = np.quantile(level, np.linspace(0, 1, BINS + 1))
    k = np.clip(np.searchsorted(edges, level.ravel(), side="right") - 1, 0, BINS - 1)
    n = np.bincount(k, minlength=BINS).astype(float)
    dev = np.bincount(k, g.ravel(), minlength=BINS) / np.maximum(n, 1)
    mid = np.bincount(k, level.ravel(), minlength=BINS) / np.maximum(n, 1)
    rest = g.ravel() - dev[k]
    s2 = float(np.mean(rest ** 2))
    if s2 > 0:
        bm = block_mean(rest.reshape(field.shape)[..., None].astype(np.float32), 8)
        area = float(np.clip(64 * np.var(bm, dtype=np.float64) / s2, 1, 64))
        dev = dev * np.maximum(0.0, 1 - CHANCE * s2 * area / np.maximum(n, 1) / np.maximum(dev ** 2, 1e-30))
    ok = n > 0
    return np.interp(level, mid[ok], dev[ok])


def contour_removed(maps, photo):
    r = maps.roughness[..., 0]
    new = np.clip(r - contour_profile(r, flash_levels(photo)), 0, 1).astype(np.float32)[..., None]
    return maps._with({**dict(maps.items()), "roughness": new})


rows, per, pics = {}, {}, []
for f in sorted(cache.glob("*.pkl")):
    d = pickle.loads(f.read_bytes())
    case = d["case"]
    if sheet and not any(n in f.name for n in sheet[1]):
        continue
    for src in ("preview", "fast"):
        m0 = d[src]
        centre = photo_burn_in(m0, case.photo)["centre"]
        rough = np.asarray(m0.roughness, np.float32)
        variants = {src: m0, f"{src}+profile": m0._with({**dict(m0.items()), "roughness": np.clip(
                        rough - profile_beyond_chance(rough, centre), 0, 1).astype(np.float32)}),
                    f"{src}+contour": contour_removed(m0, case.photo)}
        for name, m in variants.items():
            e = evaluate(m, gt=case.gt, photo=None if case.gt is not None else case.photo, centre=case.centre,
                         capture=case.capture)
            if case.gt is None:
                e.update({k: v for k, v in photo_burn_in(m, case.photo).items() if k in KEYS})
            rows.setdefault((case.kind, name), []).append(e)
            per.setdefault(case.name, {})[name] = {k: e.get(k) for k in KEYS}
            if sheet and src == "fast":
                from svbrdf.trainer.tools.before_after import row_image
                pics.append(row_image(case.photo, m))
    print(case.name, flush=True)
write_means(rows, per, KEYS, out)
if sheet:
    from svbrdf.runtime.imageio import write_image
    write_image(sheet[0], np.clip(np.concatenate(pics, axis=0), 0, 1), bits=8, force=True)
