"""Highlight fill: replace what the maps say under a clipped flash highlight with the material's own texture
from elsewhere in the set (pure numpy).

Where a flash photo clipped, it holds no information about the material: every map there is the estimator's
guess, and the guess shows (a dark or texture-less disc in the base colour, a roughness blob or a ring at the
disc's edge). A flat material is stationary, so what belongs there looks like the
rest of it. :func:`fill_highlight` does what an artist would do with a clone brush:

1. **The region** (:func:`highlight_mask`): the photo's clipped pixels (any channel at or above
   :data:`CLIP_LEVEL`, linear) within :data:`SEARCH_RADIUS` of the highlight centre
   (:func:`svbrdf.runtime.quality.burn_in.highlight_centre`; clipped pixels further away are the material, e.g. a white
   fleck), grown by :data:`GROW` times their equivalent radius ``sqrt(area / pi)`` (at least :data:`MIN_GROW_PX`):
   the pixels next to a clipped highlight are near-clipped and specular-dominated, and the estimators' discs are
   that much wider than the clipped area. Joined with the highlight's **shoulder** (:func:`shoulder_mask`): the
   connected pixels around the centre where the photo is more than :data:`SHOULDER` times as bright as a matte
   material's flash fall-off would make it there. An estimator draws its disc, and the dark ring around it, where
   the highlight dominates the photo, not only where it clipped (on the before/after grid's red card nothing
   clipped covers the roughness's dark disc). A shoulder that would take the region past :data:`MAX_SHARE` is
   left out: the clipped highlight alone is filled, as before.
2. **The source**: for a small region (its box with the band at most :data:`PATCH_SIDE` px on a copy no longer
   than :data:`SEARCH_MAX_SIDE`), one offset for the whole region, the one whose copy best continues the maps
   around it: the sum of squared differences over a band around the region (each map weighted by its inverse
   variance, :func:`svbrdf.runtime.post.tileable.map_weights`), for every offset at once by FFT correlation on the
   small copy, refined at full size. A larger region is filled patch by patch (:data:`PATCH_SIDE` px, a quarter
   overlap, in raster order): each patch from the offset whose window best matches the pixels already known
   there (outside the region, or put down by earlier patches), plus :data:`UNTYPICAL_WEIGHT` times how far the
   source's local mean lies from the maps' median level (around a large highlight the maps often carry a ring,
   and one copy or an unpenalised patch would bring a piece of it). Sources lie inside the maps and miss the
   region grown by twice the band. ``patches=False`` (:func:`fill_highlight`): always one copy.
3. **The join**: the copy is pasted, and the steps left at the region's edge and between patches are removed by
   a screened Poisson solve (:func:`svbrdf.runtime.post.tileable.screened_poisson`): every gradient between two
   pixels copied together is kept; across any other pair, the gradient into the source of the pixel inside the
   region is asked for; the level difference is spread over about one region radius (half a patch with patches;
   at most :data:`SPREAD_MAX_PX`) on both sides. Every detail in the region is a pixel of the material; only a
   smooth correction is added.

The base colour, roughness and normals (:data:`FILL_MAPS`) are filled with the same offsets (they stay registered);
normals are renormalised and every map is clipped to its range. The specular map is kept: the highlight is where
the photo shows the specular level best, and the runtime's single specular level (the median,
:func:`svbrdf.runtime.post.flash_trend.uniform_specular`) loses that evidence when the region is filled from elsewhere.
Nothing is filled (``meta["highlight_fill"]["filled"]`` False, with the reason) when the photo
has neither a clipped highlight nor a shoulder, when the region covers more than :data:`MAX_SHARE` of the maps, or when no source fits.
Decision: docs/decisions/006-highlight-fill.md.
"""

from __future__ import annotations

import math
from typing import Any, Dict, Optional, Tuple

import numpy as np

from ..quality.burn_in import RING_RADII, highlight_centre
from ..core.maps import Maps
from ..core.render import ZHAO, light_vectors, shade
from .tileable import map_weights, screened_poisson
from ..core.filters import block_mean, box_mean

#: A photo pixel is clipped when any linear channel reaches this (8-bit sRGB 254.5/255 and above: 0.99).
CLIP_LEVEL = 0.98
#: Clipped pixels further than this fraction of the width from the highlight centre are not the highlight.
SEARCH_RADIUS = 0.2
#: The region is the clipped highlight grown by this times its equivalent radius ...
GROW = 1.0
#: ... and by at least this many pixels.
MIN_GROW_PX = 2
#: The highlight's shoulder: where the photo (blurred) is more than this times as bright as a matte material's flash
#: fall-off, scaled to the photo's level far from the highlight, would make it (None: no shoulder). The specular
#: lobe then gives at least twice what the base colour does (006-highlight-fill.md).
SHOULDER: Optional[float] = 3.0
#: Half-width of the box blur of the shoulder's photo, fraction of the width (about a Gaussian of 1 %: texture
#: averaged out, the highlight's shape kept).
SHOULDER_BLUR = 0.017
#: Where the photo's level is taken: between these distances from the highlight centre, fractions of the width
#: (the burn-in score's ring, :data:`svbrdf.runtime.quality.burn_in.RING_RADII`).
SHOULDER_LEVEL_RADII = RING_RADII
#: The flash geometry of the fall-off: a co-located flash with inverse-square fall-off at the project's field of
#: view (the fine-tune's flash model, ``fast``).
SHOULDER_GEOMETRY = ZHAO.replace(falloff=True)
#: The maps that are filled (the specular is kept: see the module docstring).
FILL_MAPS = ("diffuse", "roughness", "normal")
#: Nothing is filled when the region covers more than this share of the maps (no room to copy from).
MAX_SHARE = 0.2
#: The offset search runs on a block-averaged copy no longer than this.
SEARCH_MAX_SIDE = 256
#: Width of the band compared around the region, as a fraction of its radius (at least 2 px of the search grid).
BAND = 0.35
#: The Poisson solve runs on a window around the region, this many spreads wider on each side (the correction
#: has fallen to exp(-3) = 5 % of the step there).
WINDOW_SPREADS = 3
#: The step at the region's edge is spread over about the region's radius, at most this many pixels (a wider
#: spread looks the same at 1024-2048 px and would make the solve's window the whole photo).
SPREAD_MAX_PX = 64
#: Regions whose box (with the band) is wider than this on the search grid are filled patch by patch (the
#: patches this wide, overlapping by a quarter), each copied from where it best continues what is around it and
#: what the patches before it put down; smaller ones with one copy (``fill_highlight(..., patches=False)``: always
#: one copy).
PATCH_SIDE = 24
#: Weight of a patch source's distance from the material's typical level against its fit to the known pixels.
UNTYPICAL_WEIGHT = 1.0
#: The full-size refinement of the offset compares at most about this many band pixels (evenly strided).
REFINE_SAMPLES = 20000

__all__ = ["fill_highlight", "highlight_mask", "shoulder_mask", "FILL_MAPS", "CLIP_LEVEL", "SEARCH_RADIUS", "GROW",
           "MIN_GROW_PX", "MAX_SHARE", "SHOULDER"]


def _disc_dilate(mask: np.ndarray, radius: float) -> np.ndarray:
    """``mask`` (H, W) bool grown by a disc of ``radius`` pixels (FFT convolution; outside the image is empty)."""
    if radius <= 0 or not mask.any():
        return mask.copy()
    r = int(math.ceil(radius))
    h, w = mask.shape
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    disc = (yy * yy + xx * xx <= radius * radius + 1e-9).astype(np.float32)
    H, W = h + 2 * r, w + 2 * r  # padded: no wrap-around
    a = np.zeros((H, W), np.float32)
    a[:h, :w] = mask
    k = np.zeros((H, W), np.float32)
    k[:2 * r + 1, :2 * r + 1] = disc
    conv = np.fft.irfft2(np.fft.rfft2(a) * np.fft.rfft2(k), s=(H, W))
    return conv[r:r + h, r:r + w] > 0.5


def _component(mask: np.ndarray, seed: Tuple[int, int]) -> np.ndarray:
    """The 8-connected component of ``mask`` (h, w) bool that holds ``seed`` (row, column)."""
    comp = np.zeros_like(mask)
    comp[seed] = True
    while True:
        grown = comp.copy()
        grown[1:] |= comp[:-1]
        grown[:-1] |= comp[1:]
        g = grown.copy()
        grown[:, 1:] |= g[:, :-1]
        grown[:, :-1] |= g[:, 1:]
        grown &= mask
        if np.array_equal(grown, comp):
            return comp
        comp = grown


def highlight_mask(photo: np.ndarray, centre: Optional[Tuple[float, float]] = None,
                   shoulder: bool = True, fov_deg: Optional[float] = None) -> np.ndarray:
    """The region of the maps that a flash highlight leaves unknown (see the module docstring, step 1).

    The clipped highlight is the connected patch of clipped pixels nearest the highlight centre (within
    :data:`SEARCH_RADIUS`), found on a copy no longer than :data:`SEARCH_MAX_SIDE` where clipped pixels one
    block apart count as connected (a speckled highlight is one patch); other clipped pixels are the material's
    own glints and stay. It is grown (:data:`GROW`) and joined with the shoulder (:func:`shoulder_mask`) unless
    the two cover more than :data:`MAX_SHARE` of the photo.

    Args:
        photo: (H, W, 3) linear photo, [0, 1].
        centre: (row, column) of the highlight in pixels (default :func:`highlight_centre` of the small copy).
        shoulder: join the shoulder at :data:`SHOULDER` (when that is not None); False: the clipped highlight
            alone.
        fov_deg: the photo's field of view across its width, for the shoulder's matte fall-off (None:
            :data:`SHOULDER_GEOMETRY`'s).

    Returns:
        (H, W) bool, True where the maps should be filled (all False without a clipped highlight or a shoulder).
    """
    photo = np.asarray(photo, dtype=np.float32)
    h, w = photo.shape[:2]
    k = _search_step(h, w)
    if centre is None:
        cy, cx = highlight_centre(block_mean(photo, k))
        centre = (cy * k, cx * k)
    core = _clipped_highlight(photo, centre, k)
    if not shoulder or SHOULDER is None:
        return core
    region = core | shoulder_mask(photo, centre, SHOULDER, fov_deg)
    return region if region.sum() <= MAX_SHARE * h * w else core


def shoulder_mask(photo: np.ndarray, centre: Tuple[float, float], ratio: float,
                  fov_deg: Optional[float] = None) -> np.ndarray:
    """The highlight's shoulder: the connected pixels around ``centre`` where the photo is more than ``ratio``
    times as bright as a matte material would be there.

    On a block-mean copy no longer than :data:`SEARCH_MAX_SIDE`: the photo's luminance (mean of the linear
    channels) box-blurred over :data:`SHOULDER_BLUR` of the width, divided by the diffuse weight of a flat matte
    plane under :data:`SHOULDER_GEOMETRY`'s flash with the photo's field of view ``fov_deg`` (:func:`svbrdf.runtime.core.render.shade`: cosine and inverse-square
    fall-off), is compared with ``ratio`` times its median between :data:`SHOULDER_LEVEL_RADII` of the width from
    ``centre`` (the photo's level where the highlight has faded); the 8-connected part above it that holds
    ``centre``, at full size.

    Args:
        photo: (H, W, 3) linear photo.
        centre: (row, column) of the highlight in pixels.
        ratio: brightness over the matte level that counts as the highlight's (:data:`SHOULDER`).
        fov_deg: the photo's field of view across its width, degrees (None: :data:`SHOULDER_GEOMETRY`'s).

    Returns:
        (H, W) bool (all False when the centre itself is not that bright).
    """
    h, w = photo.shape[:2]
    k = _search_step(h, w)
    small = block_mean(np.asarray(photo, np.float32), k, partial=True)
    hs, ws = small.shape[:2]
    lum = box_mean(small.mean(axis=-1, keepdims=True), max(1, round(SHOULDER_BLUR * ws)))[..., 0]
    geometry = SHOULDER_GEOMETRY if fov_deg is None else SHOULDER_GEOMETRY.replace(fov_deg=float(fov_deg))
    v, l, d2 = light_vectors(hs, ws, None, geometry)
    one = np.ones((hs, ws), np.float32)
    matte, _ = shade((0 * one, 0 * one, one), (v[..., 0], v[..., 1], v[..., 2]), (l[..., 0], l[..., 1], l[..., 2]),
                     0 * one, one, geometry, d2[..., 0])
    rel = lum / np.maximum(matte, 1e-6)
    r = np.hypot((np.arange(hs)[:, None] + 0.5) * k - centre[0], (np.arange(ws)[None, :] + 0.5) * k - centre[1]) / w
    far = (r >= SHOULDER_LEVEL_RADII[0]) & (r <= SHOULDER_LEVEL_RADII[1])
    level = float(np.median(rel[far] if far.any() else rel))
    bright = rel > ratio * level
    seed = (min(max(int(centre[0] // k), 0), hs - 1), min(max(int(centre[1] // k), 0), ws - 1))
    if not bright[seed]:
        return np.zeros((h, w), bool)
    comp = _component(bright, seed)
    return np.repeat(np.repeat(comp, k, axis=0), k, axis=1)[:h, :w]


def _clipped_highlight(photo: np.ndarray, centre: Tuple[float, float], k: int) -> np.ndarray:
    """(H, W) bool: the clipped highlight nearest ``centre``, grown (:func:`highlight_mask`); ``k`` the search
    grid's block size."""
    h, w = photo.shape[:2]
    clipped = photo.max(axis=-1) >= CLIP_LEVEL
    small = block_mean(clipped[..., None].astype(np.float32), k, partial=True)[..., 0] > 0
    near = _disc_dilate(small, 1.5)  # gaps of one block closed
    hs, ws = small.shape
    r = np.hypot((np.arange(hs)[:, None] + 0.5) * k - centre[0], (np.arange(ws)[None, :] + 0.5) * k - centre[1])
    r = np.where(small, r, np.inf)
    i = int(np.argmin(r))
    if not np.isfinite(r.flat[i]) or r.flat[i] > SEARCH_RADIUS * w:
        return np.zeros((h, w), bool)
    comp = _component(near, np.unravel_index(i, r.shape))
    core = clipped & np.repeat(np.repeat(comp, k, axis=0), k, axis=1)[:h, :w]
    n = int(core.sum())
    return _disc_dilate(core, max(float(MIN_GROW_PX), GROW * math.sqrt(n / math.pi)))


def _search_step(h: int, w: int) -> int:
    """Block size of the search grid: maps (h, w) averaged over k x k blocks are at most SEARCH_MAX_SIDE long."""
    return max(1, math.ceil(max(h, w) / SEARCH_MAX_SIDE))


def _signed(n: int) -> np.ndarray:
    """The offsets 0 .. n-1 of a periodic axis as signed shifts (those above n // 2 are negative), (n,) int."""
    o = np.arange(n)
    return np.where(o > n // 2, o - n, o)


def _corr(f: np.ndarray, spec_g: np.ndarray) -> np.ndarray:
    """``c[o] = sum_p f(p) g(p + o)`` for every periodic offset ``o``, ``g`` given by its ``rfft2``; (h, w) float64."""
    return np.fft.irfft2(np.conj(np.fft.rfft2(f)) * spec_g, s=f.shape)


class _Source:
    """The search-grid maps ``xs`` (h, w, C) a copy may come from, with the spectra every offset search needs."""

    def __init__(self, xs: np.ndarray, wts: np.ndarray, keep_out: np.ndarray):
        self.xs = xs.astype(np.float64)
        self.wts = wts
        self.chans = np.flatnonzero(wts)
        self.spec = {c: np.fft.rfft2(self.xs[..., c]) for c in self.chans}
        # the squares' term of every channel in one spectrum: sum_c w_c corr(b, xs_c^2) = corr(b, sum_c w_c xs_c^2)
        self.spec2 = np.fft.rfft2(np.einsum("hwc,c->hw", self.xs[..., self.chans] ** 2, self.wts[self.chans]))
        self.spec_keep = np.fft.rfft2(keep_out.astype(np.float64))

    def ssd(self, b: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Weighted SSD between ``target`` (h, w, C) on the pixels weighted by ``b`` (h, w) and the source
        shifted by every offset: ``sum_p b(p) |target(p) - xs(p + o)|^2``, (h, w). The channels' correlations are
        added in the frequency domain: one inverse FFT in all (the same sums up to float64 rounding)."""
        const = 0.0
        spec = np.conj(np.fft.rfft2(b)) * self.spec2
        for c in self.chans:
            t = target[..., c].astype(np.float64)
            const += self.wts[c] * float((b * t * t).sum())
            spec -= (2.0 * self.wts[c]) * np.conj(np.fft.rfft2(b * t)) * self.spec[c]
        return const + np.fft.irfft2(spec, s=b.shape)

    def valid(self, region: np.ndarray, margin: int) -> np.ndarray:
        """(h, w) bool over periodic offsets ``o``: ``region + o`` stays ``margin`` px inside the grid and misses
        the keep-out area."""
        h, w = region.shape
        ys, xs = np.nonzero(region)
        oy, ox = _signed(h), _signed(w)
        inside = (((ys.min() + oy >= margin) & (ys.max() + oy < h - margin))[:, None]
                  & ((xs.min() + ox >= margin) & (xs.max() + ox < w - margin))[None, :])
        return inside & (_corr(region.astype(np.float64), self.spec_keep) < 0.5)

    def best(self, cost: np.ndarray, valid: np.ndarray) -> Tuple[int, int]:
        """The valid offset (dy, dx) of least ``cost``."""
        i = int(np.argmin(np.where(valid, cost, np.inf)))
        h, w = cost.shape
        return int(_signed(h)[i // w]), int(_signed(w)[i % w])


def _best_offset(x: np.ndarray, mask: np.ndarray, wts: np.ndarray, radius: float) -> Optional[Tuple[int, int]]:
    """The offset (dy, dx) of the copy that fills ``mask`` (step 2 of the module docstring), or None."""
    h, w = mask.shape
    k = _search_step(h, w)
    xs = block_mean(x, k, partial=True)
    ms = block_mean(mask[..., None].astype(np.float32), k, partial=True)[..., 0] > 0
    rs = radius / k
    band_w = max(2.0, BAND * rs)
    grown = _disc_dilate(ms, band_w)
    band = grown & ~ms
    src = _Source(xs, wts, _disc_dilate(ms, 2.0 * band_w))  # the copied region and its band miss the region's band
    valid = src.valid(grown, 1)
    if not valid.any():
        return None
    oy, ox = src.best(src.ssd(band.astype(np.float64), xs), valid)
    if k == 1:
        return int(oy), int(ox)
    # Refine at full size within one block of the coarse offset, on the full-size band.
    grown_f = _disc_dilate(mask, band_w * k)
    band_f = grown_f & ~mask
    by, bx = np.nonzero(band_f)
    stride = max(1, by.size // REFINE_SAMPLES)
    by, bx = by[::stride], bx[::stride]
    gy, gx = np.nonzero(grown_f)
    best, best_o = np.inf, None
    for dy in range(-k + 1, k):
        for dx in range(-k + 1, k):
            o = (oy * k + dy, ox * k + dx)
            if gy.min() + o[0] < 1 or gy.max() + o[0] >= h - 1 or gx.min() + o[1] < 1 or gx.max() + o[1] >= w - 1:
                continue
            d = x[by, bx].astype(np.float64) - x[by + o[0], bx + o[1]].astype(np.float64)
            e = float(np.einsum("nc,c->", d * d, wts))
            if e < best:
                best, best_o = e, o
    return best_o


def _patch_offsets(x: np.ndarray, mask: np.ndarray, wts: np.ndarray, radius: float) -> Optional[np.ndarray]:
    """Per-pixel offsets (H, W, 2) int of a patch-by-patch copy that fills ``mask`` (0 elsewhere), or None when a
    patch finds no source. Planned on the search grid in raster order: each patch of :data:`PATCH_SIDE` px,
    overlapping its neighbours by a quarter, is copied from the offset whose window best matches the pixels of
    the window already known (outside the region, or put down by earlier patches); its source window must lie
    inside the grid and miss the region grown by twice the band."""
    h, w = mask.shape
    k = _search_step(h, w)
    ms = block_mean(mask[..., None].astype(np.float32), k, partial=True)[..., 0] > 0
    hs, ws = ms.shape
    src = _Source(block_mean(x, k, partial=True), wts, _disc_dilate(ms, 2.0 * max(2.0, BAND * radius / k)))
    xs = src.xs
    # How unlike the material a source pixel is: its local mean's squared distance from the median level of the
    # maps outside the region, in variance units (a stain or a piece of a ring around the flash is far from it).
    local = box_mean(xs, max(1, PATCH_SIDE // 4))
    level = np.median(local[~ms], axis=0)
    spec_untypical = np.fft.rfft2(np.einsum("hwc,c->hw", (local - level) ** 2, wts))
    comp = xs.copy()
    known = ~ms
    off = np.zeros((hs, ws, 2), np.int64)
    p = PATCH_SIDE
    step = max(1, p - p // 4)
    rows, cols = np.nonzero(ms)
    for y in range(rows.min(), rows.max() + 1, step):
        for x0 in range(cols.min(), cols.max() + 1, step):
            y1, x1 = min(hs, y + p), min(ws, x0 + p)
            todo = ms[y:y1, x0:x1] & ~known[y:y1, x0:x1]
            if not todo.any():
                continue
            window = np.zeros((hs, ws))
            window[y:y1, x0:x1] = 1.0
            valid = src.valid(window, 1)
            if not valid.any():
                return None
            cost = UNTYPICAL_WEIGHT * _corr(window, spec_untypical) / window.sum()
            b = np.zeros((hs, ws))
            b[y:y1, x0:x1] = known[y:y1, x0:x1]
            if b.any():
                cost = cost + src.ssd(b, comp) / b.sum()
            o = src.best(cost, valid)
            sel = np.zeros((hs, ws), bool)
            sel[y:y1, x0:x1] = todo
            py, px = np.nonzero(sel)
            comp[py, px] = xs[py + o[0], px + o[1]]
            off[py, px] = o
            known |= sel
    # Full size: every pixel of the region takes its block's offset, times the block size.
    full = np.zeros((h, w, 2), np.int64)
    blk = off[np.minimum(np.arange(h) // k, hs - 1)[:, None], np.minimum(np.arange(w) // k, ws - 1)[None, :]]
    full[mask] = blk[mask] * k
    return full


def _paste(x: np.ndarray, mask: np.ndarray, offsets: np.ndarray, spread: float) -> np.ndarray:
    """``x`` with each pixel of ``mask`` copied from its offset (``offsets`` (H, W, 2) int) and the joins removed
    (step 3 of the module docstring): the gradient between two pixels copied with the same offset (or both
    outside the region) is kept; across any other pair, the gradient into the source of the pixel inside the
    region is asked for."""
    h, w = mask.shape
    ys, xs = np.nonzero(mask)
    pad = int(math.ceil(WINDOW_SPREADS * spread)) + 1
    y0, y1 = max(0, ys.min() - pad), min(h, ys.max() + 1 + pad)
    x0, x1 = max(0, xs.min() - pad), min(w, xs.max() + 1 + pad)
    m = mask[y0:y1, x0:x1]
    off = offsets[y0:y1, x0:x1]
    gy, gx = np.mgrid[y0:y1, x0:x1]
    sy, sx = np.clip(gy + off[..., 0], 0, h - 1), np.clip(gx + off[..., 1], 0, w - 1)  # each pixel's source
    u0 = x[sy, sx].astype(np.float32)
    grads = []
    for axis, (dy, dx) in ((1, (0, 1)), (0, (1, 0))):
        g = np.roll(u0, -1, axis=axis) - u0
        same = np.all(np.roll(off, -1, axis=axis) == off, axis=-1)
        m_next = np.roll(m, -1, axis=axis)
        # The pixel whose source gives the gradient: the next one where it is in the region, else this one.
        qy = np.where(m_next, np.roll(sy, -1, axis=axis), sy + dy)
        qx = np.where(m_next, np.roll(sx, -1, axis=axis), sx + dx)
        qy, qx = np.clip(qy, 0, h - 1), np.clip(qx, 0, w - 1)
        py, px = np.clip(qy - dy, 0, h - 1), np.clip(qx - dx, 0, w - 1)
        g_src = x[qy, qx].astype(np.float32) - x[py, px].astype(np.float32)
        grads.append(np.where(same[..., None], g, g_src))
    u = screened_poisson(u0, grads[0], grads[1], 1.0 / spread ** 2)
    out = x.astype(np.float32, copy=True)
    out[y0:y1, x0:x1] = u
    return out


def fill_highlight(maps: Maps, photo: Optional[np.ndarray] = None, mask: Optional[np.ndarray] = None,
                   centre: Optional[Tuple[float, float]] = None, *, patches: bool = True) -> Maps:
    """The maps with the region of a clipped flash highlight filled from the material elsewhere (module docstring).

    Args:
        maps: a texture set (H, W), any subset of the four maps.
        photo: (H, W, 3) linear photo the maps were estimated from (for the region; not needed with ``mask``).
        mask: (H, W) bool region to fill (default :func:`highlight_mask` of ``photo``, its shoulder with the field of
            view of ``maps.render_config``, the photo's camera, when the maps carry one).
        centre: (row, column) of the highlight, for :func:`highlight_mask`.
        patches: fill a region wider than :data:`PATCH_SIDE` patch by patch (False: always one copy).

    Returns:
        A new :class:`Maps` (:data:`FILL_MAPS` filled, the specular as it was) with ``meta["highlight_fill"]``: ``{"filled": bool, "pixels": region size, "share":
        of the maps, "radius": equivalent radius in px, "offset": [dy, dx] of the one copy or None (patches),
        "patches": the number of distinct offsets (filled only), "reason": why nothing was filled or None}``. Ranges as :meth:`Maps.clipped`; normals unit length.

    Raises:
        ValueError: neither ``photo`` nor ``mask``, or a mask of another size than the maps.
    """
    h, w = maps.shape
    if mask is None:
        if photo is None:
            raise ValueError("fill_highlight needs the photo or a mask")
        camera = maps.render_config
        mask = highlight_mask(photo, centre, fov_deg=None if camera is None else camera.fov_deg)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (h, w):
        raise ValueError(f"mask of {mask.shape[1]}x{mask.shape[0]} px for maps of {w}x{h} px")
    n = int(mask.sum())
    radius = math.sqrt(n / math.pi)
    record: Dict[str, Any] = {"filled": False, "pixels": n, "share": n / float(h * w), "radius": radius,
                              "offset": None, "reason": None}
    out = maps._with(dict(maps.items()))
    out.meta["highlight_fill"] = record
    if n == 0:
        record["reason"] = "no clipped highlight and no shoulder"
        return out
    if n > MAX_SHARE * h * w:
        record["reason"] = f"the highlight covers {n / (h * w):.0%} of the maps (more than {MAX_SHARE:.0%})"
        return out
    names = [nm for nm in maps.names if nm in FILL_MAPS]
    if not names:
        record["reason"] = "no map to fill"
        return out
    arrays = [np.asarray(getattr(maps, nm), dtype=np.float32) for nm in names]
    groups, start = [], 0
    for a in arrays:
        groups.append(slice(start, start + a.shape[-1]))
        start += a.shape[-1]
    x = np.concatenate(arrays, axis=-1)
    k = _search_step(h, w)
    wts = map_weights(x[::k, ::k], groups)  # variances of a strided copy
    if not wts.any():
        record["reason"] = "constant maps"
        return out
    ys, xs = np.nonzero(mask)
    box = (max(ys.max() - ys.min(), xs.max() - xs.min()) + 1) / k + 2 * max(2.0, BAND * radius / k)
    offset = offsets = None
    if not patches or box <= PATCH_SIDE:
        offset = _best_offset(x, mask, wts, radius)
        if offset is not None:
            offsets = np.zeros((h, w, 2), np.int64)
            offsets[mask] = offset
        spread = radius
    if offsets is None and patches:
        offsets = _patch_offsets(x, mask, wts, radius)
        spread = min(radius, PATCH_SIDE * k / 2.0)
    if offsets is None:
        record["reason"] = "no source region fits beside the highlight"
        return out
    filled = _paste(x, mask, offsets, min(max(2.0, spread), float(SPREAD_MAX_PX)))
    result = maps._with({**dict(maps.items()), **{nm: filled[..., sl] for nm, sl in zip(names, groups)}}).clipped()
    patches = len({tuple(o) for o in offsets[mask].tolist()})
    result.meta["highlight_fill"] = {**record, "filled": True, "patches": patches,
                                     "offset": None if offset is None else [int(offset[0]), int(offset[1])]}
    return result
