"""The highlight fill over the highlight's shoulder (a probe of issue 27 item 2: "clipped and near-clipped
pixels"): the region is the shipped one (clipped pixels, grown) joined with the connected pixels around the
highlight where the photo is more than T times as bright as its base colour alone would make it (the photo's
luminance, blurred by 1 % of the width, over the model's diffuse fall-off times the photo's level far from the
highlight: the median of that ratio 0.35-0.5 W from the centre). Filled by svbrdf.runtime.highlight_fill with that
mask, on cached maps (``lobe_cache.py``, after the shipped steps), then the flash trend again; ``shoulderlow``: only the fill's smooth change (its box mean over LOW of the width) added to the maps. Benchmark measures per variant; a sheet of the named photos.

    python docs/benchmarks/refine-detail/lobe-and-rings/scripts/shoulder_probe.py CACHE_DIR OUT.json T[,T...] [SHEET.png NAMES]
"""
import pickle, sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime import highlight_fill as hf
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.flash_trend import remove_flash_trend
from svbrdf.runtime.render import ZHAO, light_vectors, shade
from svbrdf.runtime.tiling import box_mean
from svbrdf.trainer.bench.metrics import evaluate, gaussian_blur

sys.path.insert(0, str(Path(__file__).parent))
from rings_lib import write_means  # noqa: E402

warnings.simplefilter("ignore")
cache, out = Path(sys.argv[1]), Path(sys.argv[2])
ts = [float(t) for t in sys.argv[3].split(",")]
sheet = (Path(sys.argv[4]), sys.argv[5].split(",")) if len(sys.argv) > 5 else None
CONFIG = ZHAO.replace(falloff=True)
LOW = 0.03  # box radius of the smooth part, fraction of the width
KEYS = ["rerender_rmse", "input_rmse", "diffuse_rmse", "roughness_rmse", "normal_angle_deg", "grazing_rmse",
        "burn_in", "burn_diffuse", "burn_roughness", "ring_roughness", "detail_roughness", "detail_diffuse",
        "capture_rmse", "capture_ssim", "share"]


def shoulder_mask(photo, centre, t):
    h, w = photo.shape[:2]
    lum = gaussian_blur(photo.mean(-1), 0.01 * w)
    v, l, d2 = light_vectors(h, w, None, CONFIG)
    one = np.ones((h, w), np.float32)
    dw, _ = shade((0 * one, 0 * one, one), (v[..., 0], v[..., 1], v[..., 2]), (l[..., 0], l[..., 1], l[..., 2]),
                  0 * one, one, CONFIG, d2[..., 0])
    ratio = lum / np.maximum(dw, 1e-6)
    r = np.hypot(np.arange(h)[:, None] + 0.5 - centre[0], np.arange(w)[None, :] + 0.5 - centre[1])
    far = (r >= 0.35 * w) & (r <= 0.5 * w)
    level = float(np.median(ratio[far])) if far.any() else float(np.median(ratio))
    bright = ratio > t * level
    seed = (int(min(max(centre[0], 0), h - 1)), int(min(max(centre[1], 0), w - 1)))
    region = hf._component(bright, seed) if bright[seed] else np.zeros((h, w), bool)
    return region | hf.highlight_mask(photo, centre)


rows, per, pics = {}, {}, []
for f in sorted(cache.glob("*.pkl")):
    if sheet and not any(n in f.name for n in sheet[1]):
        continue
    d = pickle.loads(f.read_bytes())
    case = d["case"]
    m0 = d["fast"]
    centre = tuple(photo_burn_in(m0, case.photo)["centre"] or (m0.shape[0] / 2, m0.shape[1] / 2))
    variants = {"fast": m0}
    shares = {"fast": 0.0}
    for t in ts:
        mask = shoulder_mask(case.photo, centre, t)
        filled = hf.fill_highlight(m0, mask=mask, centre=centre)
        variants[f"fast+shoulder{t:g}"] = remove_flash_trend(filled, centre=centre)
        shares[f"fast+shoulder{t:g}"] = float(mask.mean()) if filled.meta["highlight_fill"]["filled"] else 0.0
        # only the fill's smooth part: the maps keep their own detail, their level follows the fill
        r = max(1, round(LOW * m0.shape[1]))
        low = {n: getattr(m0, n) + box_mean(getattr(filled, n) - getattr(m0, n), r).astype(np.float32)
               for n in hf.FILL_MAPS}
        lowmaps = m0._with({**dict(m0.items()), **low}).clipped()
        variants[f"fast+shoulderlow{t:g}"] = remove_flash_trend(lowmaps, centre=centre)
        shares[f"fast+shoulderlow{t:g}"] = shares[f"fast+shoulder{t:g}"]
    for name, m in variants.items():
        e = evaluate(m, gt=case.gt, photo=None if case.gt is not None else case.photo, centre=case.centre,
                     capture=case.capture)
        e["share"] = shares[name]
        rows.setdefault((case.kind, name), []).append(e)
        per.setdefault(case.name, {})[name] = {k: e.get(k) for k in KEYS}
        if sheet:
            from svbrdf.trainer.tools.before_after import row_image
            pics.append(row_image(case.photo, m))
    print(case.name, {n: round(s, 3) for n, s in shares.items()}, flush=True)
write_means(rows, per, KEYS, out)
if sheet:
    from svbrdf.runtime.imageio import write_image
    write_image(sheet[0], np.clip(np.concatenate(pics, axis=0), 0, 1), bits=8, force=True)
