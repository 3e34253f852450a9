"""Flash-trend removal: take out of the maps the smooth radial pattern centred on the flash highlight (numpy).

A stationary material looks the same everywhere; a photo lit by a flash does not: it is brightest under the flash,
with a highlight lobe there and a fall-off around it. Whatever of that pattern an estimator leaves in its maps (a
brighter or darker base colour under the flash, a specular or roughness that dips there, the "hole" a clipped
highlight leaves) is not the material: it is the light, baked in, and it shows when the maps are relit from
elsewhere (the burn-in score of :mod:`svbrdf.runtime.quality.burn_in` measures it).

:func:`remove_flash_trend` projects it out. Each scalar field ``g`` (the base colour's luminance, the mean of its
channels; the specular; the roughness) is fitted by least squares with a constant and the radial bumps

.. math::

    b_k(x) = \\exp\\left(-\\frac{1}{2} \\left(\\frac{|x - c|}{\\sigma_k W}\\right)^2\\right),
    \\quad \\sigma_k \\in \\texttt{TREND_WIDTHS}

around the highlight centre ``c`` (``W`` = image width). From the specular and the roughness the fitted bumps,
centred to zero mean, are subtracted. The base colour is divided by its fitted luminance field ``f`` and multiplied
by its mean ``m``: one gain ``m / f`` per pixel, the same for the three channels (:func:`luminance_gain`), so the
trend goes and every pixel keeps its hue and saturation (a fit subtracted per channel takes a dark channel to 0
where a bump is as large as its level: a maroon blotch on brown wood, teal in its dark grooves). Every map keeps
its mean and everything that is not round about the flash (a stationary texture projects onto a few smooth radial
functions with a weight near zero, so it is hardly changed). Given the photo, the base colour then loses the coarse
colour casts the photo does not show (:func:`svbrdf.runtime.post.photo_colour.local_colour`: the network's tint
under the flash or on one side; after the highlight fill, whose copy it sees). The normal map is left as it is
(its burn-in, the tilt of a bulge, is small).

This is the hard form of the trainer's flash-correlation loss (:func:`svbrdf.trainer.losses.flash_correlation_loss`,
which only discourages the same pattern during the fine-tune): applied to the final maps of the preview and of the
refine, it is what makes them highlight-free, and the renderer's specular lobe is left to reproduce the highlight.
Decision: docs/decisions/004-flash-trend-removal.md.

:func:`even_lighting` is the same idea on the network's *input*: the photo divided by its own smooth lighting
(the flash's fall-off and the broad part of its highlight), so that the network sees the material evenly lit and
has no bright disc to paint into its maps. The preview runs the network on it
(:attr:`svbrdf.runtime.post.PostProcess.even_lighting`; docs/decisions/007-network-input-lighting.md); the
post-processing still reads the photo itself.
"""

from __future__ import annotations

import math
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from ..quality.burn_in import highlight_centre, photo_burn_in
from .highlight_fill import fill_highlight
from ..core.filters import block_mean, box_mean
from ..core.maps import MAP_RANGES, Maps
from .settings import EVEN_LIGHTING_WIDTH

#: Widths of the radial bumps, as fractions of the image width: the highlight lobe (and a clipped highlight's
#: hole) to the broad fall-off.
TREND_WIDTHS: Tuple[float, ...] = (0.05, 0.1, 0.2, 0.4)
#: The maps whose trend is removed (the base colour by its luminance); normals are kept.
TREND_MAPS: Tuple[str, ...] = ("diffuse", "specular", "roughness")
#: The largest gain :func:`luminance_gain` gives a pixel of the base colour (where the fitted luminance is a quarter
#: of its mean or less).
GAIN_MAX = 4.0
#: The fit runs on a block-averaged copy no longer than this (the trend is smooth); the subtraction at full size.
FIT_MAX_SIDE = 256
#: :func:`lighting_field` is computed on a block-mean copy no longer than this and interpolated (it is smooth).
LIGHTING_MAX_SIDE = 64


def radial_basis(shape: Tuple[int, int], centre: Tuple[float, float], widths: Sequence[float] = TREND_WIDTHS,
                 scale: Optional[float] = None) -> np.ndarray:
    """The radial bumps of the fit, one per width.

    Args:
        shape: (H, W) of the grid.
        centre: (row, column) of the flash highlight in pixels of this grid (pixel centres at integer + 0.5).
        widths: the bumps' standard deviations as fractions of ``scale``.
        scale: the length the widths are fractions of, in pixels of this grid (default the grid's width ``W``).

    Returns:
        (K, H, W) float64 bumps in (0, 1], 1 at the centre.
    """
    h, w = shape
    widths_px = np.asarray(widths, np.float64) * float(w if scale is None else scale)
    return np.einsum("hk,wk->khw", _axis_bumps(h, centre[0], widths_px), _axis_bumps(w, centre[1], widths_px))


def _axis_bumps(n: int, c: float, widths_px: np.ndarray) -> np.ndarray:
    """(n, K) one axis of the separable bumps, ``exp(-(x - c)^2 / 2 s^2)`` at pixel centres ``x = i + 0.5``."""
    return np.exp(-0.5 * ((np.arange(n, dtype=np.float64) + 0.5 - c)[:, None] / widths_px[None]) ** 2)


def fit_flash_trend(fields: np.ndarray, centre: Tuple[float, float],
                    widths: Sequence[float] = TREND_WIDTHS) -> np.ndarray:
    """Least-squares weights of the radial bumps in each channel of ``fields``.

    Args:
        fields: (h, w, C) the channels to fit (any units).
        centre: (row, column) of the highlight in pixels of ``fields``.
        widths: see :func:`radial_basis`.

    Returns:
        (K, C) float64 weights of the bumps (the constant's weight is dropped).
    """
    h, w, c = fields.shape
    basis = radial_basis((h, w), centre, widths).reshape(len(widths), -1)
    design = np.concatenate([np.ones((1, basis.shape[1])), basis]).T  # (h*w, 1+K)
    coef, *_ = np.linalg.lstsq(design, fields.reshape(-1, c).astype(np.float64), rcond=None)
    return coef[1:]


def _full_trend(coef: np.ndarray, shape: Tuple[int, int], centre: Tuple[float, float],
                widths: Sequence[float]) -> np.ndarray:
    """(H, W, C) float32 the bumps weighted by ``coef`` (K, C) at full size, each channel minus its mean. Each bump is
    separable, exp(-y^2/2s^2) exp(-x^2/2s^2): channel c is gy diag(coef_c) gx, a small matrix product, minus the
    bumps' means mean(gy) mean(gx) weighted."""
    h, w = shape
    widths_px = np.asarray(widths, np.float64) * w
    gy, gx = _axis_bumps(h, centre[0], widths_px), _axis_bumps(w, centre[1], widths_px)  # (H, K), (W, K)
    means = gy.mean(axis=0) * gx.mean(axis=0)  # (K,)
    return np.stack([((gy * coef[:, j]) @ gx.T - float(means @ coef[:, j])).astype(np.float32)
                     for j in range(coef.shape[1])], axis=-1)


def luminance_gain(diffuse: np.ndarray, trend: np.ndarray, level: float) -> np.ndarray:
    """The base colour without a luminance trend: every pixel times ``level / (level + trend)``, one gain for its
    three channels (hue and saturation kept).

    Args:
        diffuse: (H, W, 3) linear base colour in [0, 1].
        trend: (H, W) the fitted luminance trend (zero mean), in the units of ``level``.
        level: the luminance's mean, > 0.

    Returns:
        (H, W, 3) float32 in [0, 1]. The gain is at most :data:`GAIN_MAX` (where ``level + trend`` is small or
        negative); a pixel it would take above 1 is scaled down as a whole (its hue kept), not clipped per channel.
    """
    gain = np.float32(level) / np.maximum(np.float32(level) + trend.astype(np.float32), np.float32(level / GAIN_MAX))
    out = np.asarray(diffuse, np.float32) * gain[..., None]
    peak = np.maximum(np.maximum(out[..., 0:1], out[..., 1:2]), out[..., 2:3])  # faster than max(axis=-1)
    np.divide(out, np.maximum(peak, np.float32(1)), out=out)
    return np.maximum(out, np.float32(0), out=out)


def remove_flash_trend(maps: Maps, centre: Optional[Tuple[float, float]] = None, photo: Optional[np.ndarray] = None,
                       widths: Sequence[float] = TREND_WIDTHS) -> Maps:
    """The maps without their radial trend around the flash highlight (see the module docstring).

    Args:
        maps: a texture set (H, W); maps that are ``None`` stay ``None``, normals are kept.
        centre: (row, column) of the highlight in the maps' pixels; default :func:`highlight_centre` of
            ``photo``, or the image centre without a photo.
        photo: (H, W, 3) linear photo the maps were estimated from: the default centre, and the base colour's
            coarse colours are made the photo's (:func:`svbrdf.runtime.post.photo_colour.local_colour`: the casts
            the photo does not show go).
        widths: see :func:`radial_basis`.

    Returns:
        A new :class:`Maps` (same meta plus ``meta["flash_trend"]``: ``{"centre": [row, col], "widths",
        "removed": {map: RMS of the change}}``), values in :data:`MAP_RANGES`. The base colour has its luminance
        trend divided out (:func:`luminance_gain`: each pixel's hue kept; then, with ``photo``, its casts), the
        specular and roughness their trend subtracted (clipped). Diffuse, specular and roughness are float32.

    Raises:
        ValueError: ``photo`` is not (H, W, 3).
    """
    h, w = maps.shape
    k = max(1, math.ceil(max(h, w) / FIT_MAX_SIDE))
    if photo is not None:
        photo = np.asarray(photo, dtype=np.float32)
        if photo.shape != (h, w, 3):
            raise ValueError(f"photo {photo.shape} does not match maps of {h}x{w}")
    if centre is None:
        if photo is not None:
            centre = highlight_centre(block_mean(photo, k))
            centre = (centre[0] * k, centre[1] * k)
        else:
            centre = (h / 2.0, w / 2.0)
    cy, cx = float(centre[0]), float(centre[1])
    names = [n for n in TREND_MAPS if getattr(maps, n) is not None]
    if not names or min(h, w) // k < 4:
        return maps
    # The block mean drops a partial last block; its grid still starts at the image's top-left corner. The base
    # colour is fitted by its luminance (one field), the other maps as they are.
    fields = [block_mean(getattr(maps, n), k) for n in names]
    fields = [f.mean(axis=-1, keepdims=True) if n == "diffuse" else f for n, f in zip(names, fields)]
    small = np.concatenate(fields, axis=-1)
    coef = fit_flash_trend(small, (cy / k, cx / k), widths)  # (K, C) in map units
    trend = _full_trend(coef, (h, w), (cy, cx), widths)  # (H, W, C)
    out: Dict[str, np.ndarray] = dict(maps.items())
    removed: Dict[str, float] = {}
    for j, n in enumerate(names):
        a = np.asarray(getattr(maps, n), dtype=np.float32)
        if n == "diffuse":
            level = float(small[..., j].mean(dtype=np.float64))
            out[n] = luminance_gain(a, trend[..., j], level) if level > 0 else a
            if photo is not None:
                from .photo_colour import local_colour  # it imports this module

                out[n] = local_colour(out[n], photo)
        else:
            lo, hi = MAP_RANGES[n]
            out[n] = np.clip(a - trend[..., j:j + 1], lo, hi)
        change = out[n][::k, ::k] - a[::k, ::k]
        removed[n] = float(np.sqrt(np.mean(np.square(change, dtype=np.float64))))
    result = maps._with(out)
    result.meta["flash_trend"] = {"centre": [cy, cx], "widths": list(widths), "removed": removed}
    return result


def _interp_matrix(n: int, m: int, k: int) -> np.ndarray:
    """(n, m) linear interpolation of m samples at block centres (blocks of k pixels) onto n pixel centres; ends
    held."""
    x = np.clip((np.arange(n) + 0.5) / k - 0.5, 0, m - 1)
    i0 = np.minimum(np.floor(x).astype(int), max(m - 2, 0))
    f = x - i0 if m > 1 else np.zeros(n)
    a = np.zeros((n, m))
    a[np.arange(n), i0] += 1 - f
    a[np.arange(n), np.minimum(i0 + 1, m - 1)] += f
    return a


def lighting_field(photo: np.ndarray, sigma: float) -> np.ndarray:
    """The photo's smooth lighting: the geometric-mean luminance around each pixel.

    ``exp`` of the log luminance (mean of the linear channels, floored at 1e-4) low-passed by a Gaussian of
    ``sigma`` x the width (three box blurs) on a block-mean copy no longer than :data:`LIGHTING_MAX_SIDE`,
    interpolated bilinearly to full size. Borders are extended (edge pixels repeated).

    Args:
        photo: (H, W, 3) linear photo.
        sigma: the low pass's standard deviation as a fraction of the width, > 0.

    Returns:
        (H, W) float32, > 0, in the photo's units.
    """
    h, w = photo.shape[:2]
    k = max(1, math.ceil(max(h, w) / LIGHTING_MAX_SIDE))
    lum = block_mean(np.asarray(photo, np.float32).mean(axis=-1, keepdims=True), k, partial=True)
    g = np.log(np.maximum(lum, 1e-4)).astype(np.float64)
    s = sigma * w / k  # in blocks; three boxes of radius r have the variance r (r + 1)
    r = max(1, int(round((math.sqrt(1 + 4 * s * s) - 1) / 2)))
    for _ in range(3):
        g = box_mean(g, r)
    f32 = lambda a: a.astype(np.float32)  # noqa: E731  (float32 at full size: 4x less time than float64 at 2048 px)
    field = f32(_interp_matrix(h, g.shape[0], k)) @ f32(g[..., 0]) @ f32(_interp_matrix(w, g.shape[1], k)).T
    return np.exp(field, out=field)


def even_lighting(photo: np.ndarray, sigma: float) -> np.ndarray:
    """The photo evenly lit: divided by its :func:`lighting_field`, scaled so that its median luminance is the
    photo's (medians of a strided copy at most about 256 px long). Every channel is divided by the same field, so
    colours and the detail finer than ``sigma`` are kept; a clipped highlight stays flat.

    Args:
        photo: (H, W, 3) linear photo.
        sigma: see :func:`lighting_field`.

    Returns:
        (H, W, 3) float32 linear, >= 0.
    """
    photo = np.asarray(photo, np.float32)
    field = lighting_field(photo, sigma)
    # The medians on a strided subsample (at most about 256 px long): the full-size medians cost more than the rest.
    step = max(1, math.ceil(max(photo.shape[:2]) / 256))
    lum = photo[::step, ::step].mean(axis=-1)
    scale = float(np.median(lum)) / max(float(np.median(lum / field[::step, ::step])), 1e-12)
    return photo * (np.float32(scale) / field)[..., None]


def uniform_specular(maps: Maps) -> Maps:
    """The maps with the specular albedo replaced by its median: one level per photo.

    The predicted specular's spatial variation is noise; the level (dielectric or metal) is what the photo tells.
    The median rather than the mean: a network unsure between a dielectric and a metal calls some pixels metal.
    Decision: docs/decisions/005-uniform-specular.md.

    Args:
        maps: a texture set; without a specular map it is returned as it is.

    Returns:
        A new :class:`Maps` whose specular (H, W, 1) float32 is constant, its median, with
        ``meta["uniform_specular"] = {"level", "std_removed"}`` (``std_removed``: the map's standard deviation).
    """
    if maps.specular is None:
        return maps
    spec = np.asarray(maps.specular, dtype=np.float32)
    level = float(np.median(spec))
    out = maps._with({**dict(maps.items()), "specular": np.full_like(spec, level)})
    out.meta["uniform_specular"] = {"level": level, "std_removed": float(spec.std(dtype=np.float64))}
    return out


def postprocess(maps: Maps, photo: np.ndarray, *, flash_trend: bool = True, specular_level: bool = True,
                highlight_fill: bool = False, patches: bool = True) -> Maps:
    """What the runtime does to a network's maps before returning them (the preview's
    :func:`svbrdf.runtime.inference.pipeline.estimate` and the refine's :meth:`svbrdf.trainer.train.Trainer.predict_maps`),
    each step when asked, in this order: :func:`svbrdf.runtime.post.highlight_fill.fill_highlight` (the region of a
    clipped highlight copied from the material elsewhere; first, so the trend fit does not compensate a hole that
    is then filled), :func:`remove_flash_trend` around the photo's highlight (with the photo: the base colour's
    casts too) and :func:`uniform_specular`.

    Args:
        maps: the network's texture set (H, W).
        photo: (H, W, 3) linear photo the maps were estimated from.
        flash_trend, specular_level, highlight_fill: run :func:`remove_flash_trend`, :func:`uniform_specular`,
            :func:`~svbrdf.runtime.post.highlight_fill.fill_highlight`.
        patches: let the fill copy a large region patch by patch (``fill_highlight(..., patches=)``).

    Returns:
        The maps with ``meta["burn_in_model"]``: the label-free burn-in of the network's maps
        (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in`), and ``meta["burn_in"]``: that of the maps returned
        (and ``meta["highlight_fill"]`` with ``highlight_fill``).
    """
    model_burn_in = photo_burn_in(maps, photo)
    out = maps._with(dict(maps.items()))  # a new meta dict, the arrays shared
    centre = model_burn_in["centre"]
    if highlight_fill:
        out = fill_highlight(out, photo, centre=None if centre is None else tuple(centre), patches=patches)
    if flash_trend:
        out = remove_flash_trend(out, centre=centre, photo=photo)
    if specular_level:
        out = uniform_specular(out)
    changed = flash_trend or specular_level or highlight_fill
    out.meta["burn_in"] = photo_burn_in(out, photo) if changed else model_burn_in
    out.meta["burn_in_model"] = model_burn_in
    return out


__all__ = ["postprocess", "remove_flash_trend", "uniform_specular", "even_lighting", "lighting_field", "EVEN_LIGHTING_WIDTH", "fit_flash_trend", "radial_basis", "TREND_WIDTHS", "TREND_MAPS",
           "FIT_MAX_SIDE", "luminance_gain", "GAIN_MAX"]
