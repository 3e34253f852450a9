"""Probe (not adopted): fill the maps where the photo was clipped (grown by its radius) with OpenImageIO push-pull
plus the high-pass of a shifted, unclipped copy, after the flash-trend removal; scored on the dumped maps
(dump_maps.py) of the cases with clipped pixels, and a picture grid of the four real photos of the README.

    python docs/benchmarks/accuracy/scripts/fill_clipped_probe.py runs/flashfree/maps fast150
"""
import numpy as np, OpenImageIO as oiio, math

CLIPPED = 0.98

def _buf(a, alpha=None):
    h, w, c = a.shape
    n = c + (alpha is not None)
    b = oiio.ImageBuf(oiio.ImageSpec(w, h, n, oiio.FLOAT))
    if alpha is not None:
        b.specmod().alpha_channel = c
        a = np.concatenate([a * alpha[..., None], alpha[..., None]], -1)
    b.set_pixels(oiio.ROI(), np.ascontiguousarray(a, np.float32))
    return b

def _blur(a, sigma):
    k = oiio.ImageBufAlgo.make_kernel("gaussian", 2 * int(3 * sigma) + 1, 2 * int(3 * sigma) + 1)
    out = oiio.ImageBuf()
    oiio.ImageBufAlgo.convolve(out, _buf(a), k)
    return out.get_pixels(oiio.FLOAT)

def _dilate(mask, r):
    out = oiio.ImageBuf()
    oiio.ImageBufAlgo.dilate(out, _buf(mask[..., None].astype(np.float32)), 2 * r + 1, 2 * r + 1)
    return out.get_pixels(oiio.FLOAT)[..., 0] > 0.5

def fill_clipped(maps, photo, grow=1.0, feather=3.0):
    clipped = photo.max(-1) >= CLIPPED
    h, w = clipped.shape
    frac = clipped.mean()
    if frac == 0 or frac > 0.2:
        return maps, None
    r_eq = math.sqrt(clipped.sum() / math.pi)
    g = int(math.ceil(grow * r_eq)) + 2
    mask = _dilate(clipped, g)
    ys, xs = np.nonzero(mask)
    bh, bw = ys.max() - ys.min() + 1, xs.max() - xs.min() + 1
    # shift: the smallest of the 8 directions that moves the mask's box entirely onto unmasked pixels in the image
    best = None
    for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (1, -1), (-1, 1), (-1, -1)):
        s = (dy * (bh + 2 * g), dx * (bw + 2 * g))
        y0, y1, x0, x1 = ys.min() + s[0], ys.max() + s[0], xs.min() + s[1], xs.max() + s[1]
        if y0 < 0 or x0 < 0 or y1 >= h or x1 >= w:
            continue
        if mask[ys + s[0], xs + s[1]].any():
            continue
        n = abs(s[0]) + abs(s[1])
        if best is None or n < best[0]:
            best = (n, s)
    # feathered weight: 1 inside the mask, falling to 0 over `feather` px outside
    wgt = _blur(mask[..., None].astype(np.float32), feather)[..., 0]
    wgt = np.clip(2 * wgt, 0, 1) if True else wgt
    wgt = np.maximum(wgt, mask)
    out = dict(maps.items())
    sigma = max(2.0, r_eq / 2)
    for n in ("diffuse", "specular", "roughness", "normal"):
        a = np.asarray(getattr(maps, n), np.float32)
        pp = oiio.ImageBuf()
        oiio.ImageBufAlgo.fillholes_pushpull(pp, _buf(a, (~mask).astype(np.float32)))
        low = pp.get_pixels(oiio.FLOAT)[..., :a.shape[-1]]
        fill = low
        if best is not None:
            hp = a - _blur(a, sigma)
            sy, sx = best[1]
            src = np.roll(hp, (-sy, -sx), axis=(0, 1))
            fill = low + src
        res = a * (1 - wgt[..., None]) + fill * wgt[..., None]
        if n == "normal":
            res = res / np.linalg.norm(res, axis=-1, keepdims=True)
        else:
            res = np.clip(res, 0, 1)
        out[n] = res.astype(np.float32)
    return maps._with(out), {"clipped": float(frac), "grow": g, "shift": None if best is None else list(best[1])}
import sys, glob, numpy as np, warnings
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.flash_trend import remove_flash_trend
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.tools.before_after import row_image
from svbrdf.runtime.imageio import write_image
from collections import defaultdict
warnings.simplefilter("ignore")
m = sys.argv[2]
acc = defaultdict(lambda: defaultdict(list)); rows = []
KEYS = ["rerender_rmse", "input_rmse", "burn_in", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg"]
for f in sorted(glob.glob(sys.argv[1] + "/*.npz")):
    z = np.load(f); photo = z["photo"]; centre = tuple(z["centre"])
    gt = Maps(**{n: z[f"gt_{n}"] for n in ("diffuse", "specular", "roughness", "normal")}) if "gt_diffuse" in z else None
    maps = Maps(**{n: z[f"{m}_{n}"] for n in ("diffuse", "specular", "roughness", "normal")})
    t = remove_flash_trend(maps, photo=photo)
    fl, info = fill_clipped(t, photo)
    clip = info is not None
    for name, v in (("trend", t), ("trend+fill", fl)):
        r = evaluate(v, gt=gt, photo=None if gt is not None else photo, centre=centre)
        for k in KEYS:
            if k in r:
                acc[(gt is not None, clip, name)][k].append(r[k])
    if any(s in f for s in ("2003__IMG_9392", "0281__IMG_0790", "2008__IMG_9399", "2058__IMG_9482")):
        rows += [row_image(photo, t), row_image(photo, fl)]
        print(f.split("__")[-1], info)
for k in sorted(acc): print(k, len(acc[k]["burn_in"]), " ".join(f"{np.mean(acc[k][x]):.4f}" if acc[k][x] else "-" for x in KEYS))
if rows: write_image("runs/flashfree/grid_fill.png", np.concatenate(rows, 0), bits=8, force=True)
