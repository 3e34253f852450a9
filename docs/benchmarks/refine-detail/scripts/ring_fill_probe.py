"""Probe (issue 27, item 2): the highlight fill's region taken as far as the maps' own radial trace reaches.

The runtime fills the photo's clipped highlight and its shoulder (:func:`svbrdf.runtime.highlight_fill.highlight_mask`,
from the photo alone). Around a real phone photo's highlight the v2 stage one's maps carry a ring just outside that
region (roughness, base colour). Here the region is widened to the radius where the maps' radial profile around the
highlight returns to its far level: per map (base colour's channel mean, roughness) the mean in annuli of 0.01 W,
compared with the median of the annuli between 0.25 and 0.5 W; walking out from the photo region's outer radius
while an annulus lies more than Z robust standard deviations (1.4826 MAD of the far annuli) from it, at most 0.3 W;
the radius times MARGIN. Two orders: the fill then the flash-trend removal (the runtime's), or the trend removed
first (the radius measured on the de-trended maps) and the fill after it. Writes a sheet (rows: photos; columns:
base colour and roughness as the runtime gives them, then with the widened region) and prints the burn-in scores.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/ring_fill_probe.py MODEL SIZE OUT.png [--z 3]
        [--margin 1.3] [--trend-first] PHOTO...
"""
import argparse

import numpy as np
import OpenImageIO as oiio

import svbrdf.runtime.session as S
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.flash_trend import postprocess, remove_flash_trend, uniform_specular
from svbrdf.runtime.highlight_fill import fill_highlight, highlight_mask


def radius_map(h: int, w: int, centre) -> np.ndarray:
    return np.hypot(np.arange(h)[:, None] + .5 - centre[0], np.arange(w)[None] + .5 - centre[1]) / w


def trace_radius(maps, r: np.ndarray, r0: float, z: float, bins: int = 100, far=(0.25, 0.5), rmax=0.3) -> float:
    """The radius (fraction of W) out to which the maps' radial profile stays off its far level (see above)."""
    k_all = np.minimum((r * bins).astype(int), bins)
    out = r0
    for name in ("diffuse", "roughness"):
        f = getattr(maps, name).mean(-1)
        n = np.bincount(k_all.ravel(), minlength=bins + 1)[:bins]
        s = np.bincount(k_all.ravel(), weights=f.ravel(), minlength=bins + 1)[:bins]
        p = np.where(n > 0, s / np.maximum(n, 1), np.nan)
        idx = np.arange(bins) / bins
        fm = (idx >= far[0]) & (idx < far[1]) & np.isfinite(p)
        ref = np.median(p[fm])
        sig = 1.4826 * np.median(np.abs(p[fm] - ref)) + 1e-6
        k = int(np.ceil(r0 * bins))
        while k < int(rmax * bins) and np.isfinite(p[k]) and abs(p[k] - ref) / sig > z:
            k += 1
        out = max(out, k / bins)
    return out


def small(a: np.ndarray, width: int = 256) -> np.ndarray:
    b = oiio.ImageBuf(np.ascontiguousarray(a.astype(np.float32)))
    h = int(width * a.shape[0] / a.shape[1])
    return oiio.ImageBufAlgo.resize(b, roi=oiio.ROI(0, width, 0, h, 0, 1, 0, 3)).get_pixels(oiio.FLOAT)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("model"), ap.add_argument("size", type=int), ap.add_argument("out")
    ap.add_argument("photos", nargs="+")
    ap.add_argument("--z", type=float, default=3.0)
    ap.add_argument("--margin", type=float, default=1.0)
    ap.add_argument("--trend-first", action="store_true")
    a = ap.parse_args()
    S.FLASH_TREND = S.UNIFORM_SPECULAR = S.HIGHLIGHT_FILL = False  # the network's maps, photo-coloured
    sess = S.load_session(a.model, threads=1)
    rows = []
    for path in a.photos:
        _, img, _ = S._as_image(path, a.size)
        raw = S.estimate(img, sess, max_size=a.size)
        h, w = img.shape[:2]
        c = raw.meta["burn_in_model"]["centre"]
        shipped = postprocess(raw, img, highlight_fill=True)
        mask = highlight_mask(img)
        r = radius_map(h, w, c)
        r0 = float(r[mask].max()) if mask.any() else 0.0
        m = remove_flash_trend(raw, centre=c) if a.trend_first else raw
        R = trace_radius(m, r, r0, a.z) * a.margin
        wide = fill_highlight(m, img, mask=mask | (r <= R), centre=tuple(c))
        wide = uniform_specular(wide if a.trend_first else remove_flash_trend(wide, centre=c))
        fill = wide.meta["highlight_fill"]
        print(f"{path.split('/')[-1]}: photo region to {r0:.3f} W, widened to {R:.3f} W; burn-in "
              f"{shipped.meta['burn_in']['burn_in']:.3f} -> {photo_burn_in(wide, img)['burn_in']:.3f}; "
              f"filled {fill['filled']} {fill.get('reason') or ''}", flush=True)
        rows.append([linear_to_srgb(shipped.diffuse), np.repeat(shipped.roughness, 3, -1),
                     linear_to_srgb(wide.diffuse), np.repeat(wide.roughness, 3, -1)])
    grid = np.concatenate([np.concatenate([small(x) for x in row], 1) for row in rows], 0)
    oiio.ImageBuf(np.ascontiguousarray(np.clip(grid, 0, 1))).write(a.out)


if __name__ == "__main__":
    main()
