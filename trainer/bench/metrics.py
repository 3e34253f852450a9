"""Every benchmark metric, defined once (numpy only, no torch).

Conventions shared by all metrics:

* maps are :class:`svbrdf.runtime.core.maps.Maps` (linear, channel-last float32, OpenGL normals);
* "sRGB" means: clip to [0, 1], then encode with the exact sRGB curve (:func:`svbrdf.runtime.core.colour.linear_to_srgb` with ``clip=True``);
* RMSE is ``sqrt(mean((a - b)^2))`` over every pixel and channel of the compared arrays (pooled, not a mean of
  per-channel RMSEs); lower is better, 0 = identical.

Per-map errors (:func:`map_errors`, synthetic cases with ground truth):

===================  =====================================================================================
key                  definition
===================  =====================================================================================
diffuse_rmse         RMSE of the linear diffuse albedo (3 channels)
diffuse_rmse_srgb    RMSE of the sRGB-encoded diffuse albedo
specular_rmse        RMSE of the linear specular albedo
specular_rmse_srgb   RMSE of the sRGB-encoded specular albedo
roughness_rmse       RMSE of the roughness r (as stored, not alpha)
normal_rmse          RMSE of the encoded normals (n + 1) / 2 (3 channels)
normal_angle_deg     mean over pixels of the angle between unit normals, degrees
===================  =====================================================================================

Re-rendering errors (:func:`svbrdf.runtime.core.render.rerender_rmse`, beside the renderer so that the runtime's
``--quality auto`` rule computes the same number): both texture sets are rendered with the project renderer
(:func:`svbrdf.runtime.core.render.render`, the benchmark's :class:`~svbrdf.runtime.core.render.RenderConfig`) under each
light, every render is converted to sRGB (clipped to [0, 1] first, as a display or a camera would), and the
RMSE is pooled over all lights, pixels and channels:

* ``rerender_rmse``: the 9 lights of :func:`svbrdf.runtime.core.render.novel_lights` plus the input flash (10 renders);
* ``input_rmse``: the input flash only. For a real photo (no ground truth) the reference is the photo itself
  (clipped to [0, 1], sRGB-encoded), so this is the only re-rendering metric there; it is given twice:
  ``input_rmse`` with the benchmark's configuration (ZHAO: no light fall-off, which favours maps that carry the
  photo's fall-off as burn-in) and ``input_rmse_falloff`` with inverse-square fall-off, as a real flash has.

Highlight burn-in: the label-free score of :mod:`svbrdf.runtime.quality.burn_in` (``burn_*`` signed disc scores and
``ring_*`` ring scores per map, ``burn_in`` the worst map's), imported from there so the runtime reports the same
number.

Foreign colour (:func:`svbrdf.runtime.quality.colour_check.foreign_colour`, every case): the CIELAB a*b* distance,
at equal lightness, between the predicted base colour and the photo, block by block (16 blocks on the long side;
blocks where the photo is clipped or too dark are left out). The photo is the input photo when given, else (a
synthetic case) the ground truth rendered under the input flash, clipped to [0, 1]: what is seen.

=====================  ================================================================================
key                    definition
=====================  ================================================================================
foreign_colour         mean distance over the kept blocks (0: the photo's colours; about 10 and above:
                       a hue the photo does not show there)
foreign_colour_p99     99th percentile of the distances (the worst patch)
foreign_colour_area    share of the kept blocks above 15 (a visible foreign colour), in [0, 1]
=====================  ================================================================================

Relief (:func:`relief_metrics`, every case with a normal map): the height of the written ``_height.png``
(:func:`svbrdf.runtime.core.relief.relief_maps` of the predicted normals).

=====================  ================================================================================
key                    definition
=====================  ================================================================================
relief_radial_corr     Pearson correlation of the height and the distance to the highlight centre, in
                       [-1, 1] (< 0: a dome under the flash; :mod:`svbrdf.runtime.quality.relief_check`)
relief_radial_share    share of the height's variance its radial profile about that centre explains,
                       in [0, 1] (a few hundredths by chance)
height_lowband_err     synthetic cases, :func:`height_lowband_error`: the height against the truth's
                       (its normals integrated plainly, ``low_cut=0``), each less its least-squares plane
                       and divided by its RMS; the energy of the difference in the orthonormal DCT terms
                       of at most :data:`LOWBAND_CYCLES` cycles across the map, over the pixel count
                       (0: the same broad shape; a height that is all dome: about 1 plus the truth's
                       own broad share; at most 4)
=====================  ================================================================================

What an artist sees (:func:`artist_metrics`; the columns of the first table of ``svbrdf-bench``'s ``results.md``):

=====================  ================================================================================
key                    definition
=====================  ================================================================================
std_<map>              spatial standard deviation of the predicted map (:func:`map_std`); every case
detail_<map>           ``std_<map>`` of the prediction / that of the ground truth: 0 for a constant or
                       flat map, ~1 for a faithful one (synthetic cases; absent where the truth itself
                       is visually constant, std below :data:`DETAIL_MIN_STD`)
normal_slope_corr      Pearson correlation of the predicted and true surface slopes ``(-n_x/n_z,
                       -n_y/n_z)`` (the height field's gradient), both components pooled; 0 for a flat
                       map (synthetic cases)
grazing_rmse           ``rerender_rmse`` under :func:`~svbrdf.runtime.core.render.grazing_lights` (60 and 75
                       degrees from the normal, 4 azimuths each), where normals and roughness show
grazing_hp_corr        mean over those lights of the correlation of the relit images' high-pass (sRGB
                       luminance minus its Gaussian blur of sigma W / 128), prediction against truth
capture_rmse           real multi-view captures (:func:`capture_errors`): the maps relit at every other
                       view's camera and flash, one exposure fitted per view, sRGB RMSE against the
                       real photos over their unclipped pixels
capture_ssim           the mean SSIM of the same relit views and photos (sRGB luminance, Gaussian
                       window sigma 1.5 px), over the same pixels: 1 = the same local contrast
=====================  ================================================================================
"""

from __future__ import annotations

import math
from typing import Dict, Optional, Tuple

import numpy as np

from svbrdf.runtime.quality.burn_in import BURN_METRICS, burn_in_scores
from svbrdf.runtime.quality.relief_check import RELIEF_METRICS as _RADIAL_METRICS, relief_radial
from svbrdf.runtime.core.relief import clamped_slopes, height_from_normals, relief_maps
from svbrdf.runtime.quality.colour_check import COLOUR_METRICS, foreign_colour
from svbrdf.runtime.core.colour import linear_to_srgb
from svbrdf.runtime.core.maps import MAP_NAMES, Maps, encode_normal, normalize_normals
from svbrdf.runtime.core.stats import pearson
from svbrdf.runtime.core.render import ZHAO, RenderConfig, grazing_lights, novel_lights, render, rerender_rmse

#: Keys returned by :func:`map_errors`.
MAP_METRICS = ("diffuse_rmse", "diffuse_rmse_srgb", "specular_rmse", "specular_rmse_srgb", "roughness_rmse",
               "normal_rmse", "normal_angle_deg")
#: Keys of :func:`relief_metrics` (``height_lowband_err`` with a ground truth only).
RELIEF_METRICS = _RADIAL_METRICS + ("height_lowband_err",)
#: :func:`height_lowband_error` compares the DCT terms of at most this many cycles across the map.
LOWBAND_CYCLES = 2.0


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square error ``sqrt(mean((a - b)^2))`` over all elements (arrays of the same shape)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"shape mismatch: {a.shape} vs {b.shape}")
    return float(np.sqrt(np.mean((a - b) ** 2)))


def angular_error_deg(pred: np.ndarray, gt: np.ndarray) -> float:
    """Mean angle in degrees between two normal fields (H, W, 3) (normalised first; z clamped to >= 0)."""
    p = normalize_normals(pred).astype(np.float64)
    g = normalize_normals(gt).astype(np.float64)
    # atan2(|p x g|, p.g) stays accurate near 0 degrees, where arccos of a rounded dot product does not.
    sin = np.linalg.norm(np.cross(p, g), axis=-1)
    return float(np.degrees(np.mean(np.arctan2(sin, np.sum(p * g, axis=-1)))))


def map_errors(pred: Maps, gt: Maps) -> Dict[str, float]:
    """Per-map errors of a predicted texture set against the ground truth (keys: :data:`MAP_METRICS`).

    Args:
        pred, gt: texture sets of the same size; values are clipped to their valid ranges first.

    Returns:
        dict of floats, see the module docstring for each definition.
    """
    if pred.shape != gt.shape:
        raise ValueError(f"map size mismatch: prediction {pred.shape} vs ground truth {gt.shape}")
    p, g = pred.clipped(), gt.clipped()
    return {
        "diffuse_rmse": rmse(p.diffuse, g.diffuse),
        "diffuse_rmse_srgb": rmse(linear_to_srgb(p.diffuse, clip=True), linear_to_srgb(g.diffuse, clip=True)),
        "specular_rmse": rmse(p.specular, g.specular),
        "specular_rmse_srgb": rmse(linear_to_srgb(p.specular, clip=True), linear_to_srgb(g.specular, clip=True)),
        "roughness_rmse": rmse(p.roughness, g.roughness),
        "normal_rmse": rmse(encode_normal(p.normal), encode_normal(g.normal)),
        "normal_angle_deg": angular_error_deg(p.normal, g.normal),
    }


#: Keys of :func:`artist_metrics` (those that need a ground truth or a capture are absent without one).
#: A truth whose spatial std (:func:`map_std`) is below this is visually constant (2.5 of 255 codes; for
#: normals about 0.6 degrees of tilt): no detail ratio is reported against it, the ratio would be unbounded.
DETAIL_MIN_STD = 0.01

ARTIST_METRICS = (tuple(f"std_{n}" for n in MAP_NAMES) + tuple(f"detail_{n}" for n in MAP_NAMES)
                  + ("normal_slope_corr", "grazing_rmse", "grazing_hp_corr", "capture_rmse", "capture_ssim"))
#: Pixels of a capture photo at or above this sRGB value in any channel are clipped and left out.
CAPTURE_CLIP_SRGB = 0.98
#: SSIM constants for values in [0, 1] and its Gaussian window (pixels).
SSIM_C1, SSIM_C2, SSIM_SIGMA = 0.01 ** 2, 0.03 ** 2, 1.5


def map_std(name: str, arr: np.ndarray) -> float:
    """Spatial standard deviation of one map (H, W, C): the root of the channels' mean variance over the pixels;
    for normals, ``sqrt(var(n_x) + var(n_y))`` of the unit normals (0 for a flat map)."""
    a = np.asarray(arr, dtype=np.float64)
    if name == "normal":
        n = normalize_normals(a).astype(np.float64)
        return float(np.sqrt(n[..., 0].var() + n[..., 1].var()))
    return float(np.sqrt(a.reshape(-1, a.shape[-1]).var(axis=0).mean()))


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation of two arrays (:func:`~svbrdf.runtime.core.stats.pearson`); 0 when either is constant."""
    r = pearson(a, b)
    return 0.0 if r is None else r


def _slopes(normal: np.ndarray) -> np.ndarray:
    """Surface slopes (:func:`~svbrdf.runtime.core.relief.clamped_slopes`) (H, W, 2) of a normal map, unit first,
    float64, each component mean-removed."""
    s = clamped_slopes(normalize_normals(normal).astype(np.float64))
    return s - s.reshape(-1, 2).mean(axis=0)


def gaussian_blur(img: np.ndarray, sigma: float) -> np.ndarray:
    """Separable Gaussian blur of an (H, W) array (reflected borders, kernel radius 3 sigma), float64."""
    r = max(1, int(math.ceil(3.0 * sigma)))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    out = np.asarray(img, np.float64)
    for axis in (0, 1):
        pad = [(0, 0), (0, 0)]
        pad[axis] = (r, r)
        p = np.pad(out, pad, mode="reflect")
        n = out.shape[axis]
        out = sum(w * np.take(p, np.arange(i, i + n), axis=axis) for i, w in enumerate(k))
    return out


def ssim_map(a: np.ndarray, b: np.ndarray, sigma: float = SSIM_SIGMA) -> np.ndarray:
    """Per-pixel SSIM (H, W) of two (H, W) images with values in [0, 1] (Gaussian window of ``sigma`` px)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    mu_a, mu_b = gaussian_blur(a, sigma), gaussian_blur(b, sigma)
    var_a = gaussian_blur(a * a, sigma) - mu_a ** 2
    var_b = gaussian_blur(b * b, sigma) - mu_b ** 2
    cov = gaussian_blur(a * b, sigma) - mu_a * mu_b
    return ((2 * mu_a * mu_b + SSIM_C1) * (2 * cov + SSIM_C2)) / \
        ((mu_a ** 2 + mu_b ** 2 + SSIM_C1) * (var_a + var_b + SSIM_C2))


def _luma_srgb(linear: np.ndarray) -> np.ndarray:
    """sRGB-encoded (clipped) channel mean of a linear (H, W, 3) image, float64."""
    return linear_to_srgb(np.asarray(linear, np.float32), clip=True).astype(np.float64).mean(axis=-1)


def grazing_errors(pred: Maps, gt: Maps, config: RenderConfig = ZHAO) -> Dict[str, float]:
    """``grazing_rmse`` and ``grazing_hp_corr`` of a prediction against the ground truth (module docstring)."""
    lights = [tuple(float(c) for c in p) for p in grazing_lights(config)]
    p, g = pred.clipped(), gt.clipped()
    sigma = max(1.0, p.shape[1] / 128.0)
    corrs = []
    for light in lights:
        a, b = _luma_srgb(render(p, light, config)), _luma_srgb(render(g, light, config))
        corrs.append(_corr(a - gaussian_blur(a, sigma), b - gaussian_blur(b, sigma)))
    return {"grazing_rmse": rerender_rmse(p, g, lights, config), "grazing_hp_corr": float(np.mean(corrs))}


def relight_view(pred: Maps, capture, view: int, config: RenderConfig = ZHAO
                 ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The maps relit at one view of a real multi-view capture, exposed like its photo (see :func:`capture_errors`).

    Returns:
        ``(relit, photo, unclipped)``: the relit image and the real photo, (H, W, 3) float64 sRGB in [0, 1], and
        the (H, W) mask of the photo's unclipped pixels (every channel below :data:`CAPTURE_CLIP_SRGB`).
    """
    photo = np.asarray(capture.photos[view], np.float64)
    cam, light = capture.calibration.scene_units(view)
    r = render(pred.clipped(), light, config.replace(falloff=True), camera_pos=cam).astype(np.float64)
    ref = linear_to_srgb(photo.astype(np.float32), clip=True).astype(np.float64)
    ok = np.all(ref < CAPTURE_CLIP_SRGB, axis=-1)
    den = float(np.sum(r[ok] ** 2))
    k = float(np.sum(r[ok] * photo[ok])) / den if den > 0 else 0.0
    relit = linear_to_srgb(np.clip(k * r, 0, 1).astype(np.float32), clip=True).astype(np.float64)
    return relit, ref, ok


def capture_errors(pred: Maps, capture, config: RenderConfig = ZHAO) -> Dict[str, float]:
    """Relighting error of maps estimated from one view of a real multi-view capture, at its other views.

    For every other view j: the maps are rendered (:func:`svbrdf.runtime.core.render.render` with ``config`` and
    inverse-square fall-off, the physics of a real flash) with view j's camera and flash positions; one
    exposure ``k = sum(r p) / sum(r r)`` (linear light, all channels of the unclipped pixels) scales the render
    ``r`` to the photo ``p``, as a camera's exposure would; the scaled render is clipped and sRGB-encoded and
    compared with the photo over its unclipped pixels (every channel below :data:`CAPTURE_CLIP_SRGB`). The same
    rule for every method (:func:`relight_view`).

    Args:
        pred: maps estimated from view ``capture.index`` (same size as the capture's photos).
        capture: :class:`svbrdf.trainer.bench.cases.CaptureViews`.
        config: renderer settings (fall-off is switched on).

    Returns:
        ``capture_rmse`` (sRGB RMSE pooled over the pixels of all other views), ``capture_ssim`` (mean over
        the views of the mean SSIM of the sRGB luminance over the unclipped pixels) and ``capture_views``.
    """
    sq, n, ssims = 0.0, 0, []
    for j in capture.others():
        relit, ref, ok = relight_view(pred, capture, j, config)
        if not ok.any():
            continue
        sq += float(np.sum((relit[ok] - ref[ok]) ** 2))
        n += int(ok.sum()) * 3
        ssims.append(float(ssim_map(relit.mean(-1), ref.mean(-1))[ok].mean()))
    if n == 0:
        return {}
    return {"capture_rmse": math.sqrt(sq / n), "capture_ssim": float(np.mean(ssims)),
            "capture_views": len(ssims)}


def artist_metrics(pred: Maps, gt: Optional[Maps] = None, capture=None,
                   config: RenderConfig = ZHAO) -> Dict[str, float]:
    """The measures of what an artist sees (keys :data:`ARTIST_METRICS`, see the module docstring)."""
    out: Dict[str, float] = {}
    p = pred.clipped()
    stds = {n: map_std(n, a) for n, a in p.items()}
    out.update({f"std_{n}": v for n, v in stds.items()})
    if gt is not None:
        g = gt.clipped()
        for n, a in g.items():
            ref = map_std(n, a)
            if n in stds and ref >= DETAIL_MIN_STD:
                out[f"detail_{n}"] = stds[n] / ref
        out["normal_slope_corr"] = _corr(_slopes(p.normal), _slopes(g.normal))
        out.update(grazing_errors(p, g, config))
    if capture is not None:
        out.update(capture_errors(p, capture, config))
    return out


def evaluation_lights(config: RenderConfig = ZHAO) -> list:
    """The fixed re-rendering lights: the 3 x 3 grid of :func:`novel_lights` plus the input flash (``None``)."""
    return [tuple(float(c) for c in p) for p in novel_lights(config)] + [None]


def evaluate(
    pred: Maps,
    *,
    gt: Optional[Maps] = None,
    photo: Optional[np.ndarray] = None,
    config: RenderConfig = ZHAO,
    centre: Optional[Tuple[float, float]] = None,
    capture=None,
) -> Dict[str, float]:
    """All metrics of one prediction.

    Args:
        pred: predicted texture set.
        gt: ground truth (synthetic case): per-map errors, ``rerender_rmse`` (10 lights) and ``input_rmse``
            against renders of ``gt``.
        photo: linear input photo (H, W, 3): ``input_rmse`` against it when there is no ground truth; the
            foreign colour against it always (without it, against ``gt`` rendered under the input flash).
        config: renderer settings.
        centre: highlight centre for the burn-in scores (default the image centre).
        capture: the capture's views (:class:`svbrdf.trainer.bench.cases.CaptureViews`) when the photo is one
            view of a real multi-view capture: ``capture_*`` relighting errors.

    Returns:
        flat dict of floats (missing metrics are simply absent).
    """
    out: Dict[str, float] = {}
    if gt is not None:
        out.update(map_errors(pred, gt))
        out["rerender_rmse"] = rerender_rmse(pred, gt, evaluation_lights(config), config)
        out["input_rmse"] = rerender_rmse(pred, gt, [None], config)
    elif photo is not None:
        out["input_rmse"] = rerender_rmse(pred, photo, [None], config)
        out["input_rmse_falloff"] = rerender_rmse(pred, photo, [None], config.replace(falloff=True))
    out.update(burn_in_scores(pred, centre))
    out.update(colour_metrics(pred, gt=gt, photo=photo, config=config))
    out.update(relief_metrics(pred, gt, centre))
    out.update(artist_metrics(pred, gt, capture, config))
    return out


def colour_metrics(pred: Maps, *, gt: Optional[Maps] = None, photo: Optional[np.ndarray] = None,
                   config: RenderConfig = ZHAO) -> Dict[str, float]:
    """``foreign_colour*`` (:data:`COLOUR_METRICS`) of the predicted base colour against ``photo``, else against
    ``gt`` rendered under the input flash (clipped to [0, 1]); empty without a base colour or a reference."""
    if pred.diffuse is None or (photo is None and gt is None):
        return {}
    from svbrdf.runtime.post.highlight_fill import highlight_mask

    seen = np.clip(photo if photo is not None else render(gt.clipped(), None, config), 0, 1)
    return foreign_colour(np.clip(pred.diffuse, 0, 1), seen, unknown=highlight_mask(seen))


def _unplane(h: np.ndarray) -> np.ndarray:
    """(H, W) float64 ``h`` less its least-squares plane ``a + b row + c column`` (the centred coordinates are
    orthogonal on the full grid, so each coefficient is one projection)."""
    h = np.asarray(h, np.float64)
    h = h - h.mean()
    rows, cols = h.shape
    y = np.arange(rows) - (rows - 1) / 2.0
    x = np.arange(cols) - (cols - 1) / 2.0
    if rows > 1:
        h = h - (float(y @ h.sum(axis=1)) / (cols * float(y @ y))) * y[:, None]
    if cols > 1:
        h = h - (float(h.sum(axis=0) @ x) / (rows * float(x @ x))) * x[None, :]
    return h


def _dct_rows(n: int, k: int) -> np.ndarray:
    """The first ``k`` rows of the orthonormal DCT-II matrix of size ``n`` ((k, n) float64)."""
    m = np.cos(np.pi * np.arange(k)[:, None] * (np.arange(n)[None, :] + 0.5) / n) * math.sqrt(2.0 / n)
    m[0] /= math.sqrt(2.0)
    return m


def height_lowband_error(pred: np.ndarray, truth: np.ndarray, cycles: float = LOWBAND_CYCLES) -> float:
    """How differently two heights are shaped at the broadest scales (the ``height_lowband_err`` of the docstring).

    Args:
        pred, truth: (H, W) heights (any units, offsets and scales: each is taken less its least-squares plane and
            divided by its RMS; a flat one stays 0).
        cycles: the largest ``sqrt(cy^2 + cx^2)`` compared, cy and cx the cycles across the map's height and width
            of an orthonormal DCT-II term (index k: k / 2 cycles).

    Returns:
        ``sum over those terms of d_k^2 / (H W)``, ``d = pred' - truth'``: in [0, 4]; 0 when the broad shapes agree.
    """
    a, b = _unplane(pred), _unplane(truth)
    if a.shape != b.shape:
        raise ValueError(f"height size mismatch: prediction {a.shape} vs truth {b.shape}")
    for arr in (a, b):
        sd = float(arr.std())
        if sd > 0:
            arr /= sd
    d = a - b
    rows, cols = d.shape
    ky, kx = min(rows, int(2 * cycles) + 1), min(cols, int(2 * cycles) + 1)
    coef = _dct_rows(rows, ky) @ d @ _dct_rows(cols, kx).T
    rho = np.hypot(np.arange(ky)[:, None] / 2.0, np.arange(kx)[None, :] / 2.0)
    return float(np.sum(coef[rho <= cycles] ** 2) / d.size)


def relief_metrics(pred: Maps, gt: Optional[Maps] = None,
                   centre: Optional[Tuple[float, float]] = None) -> Dict[str, float]:
    """:data:`RELIEF_METRICS` of the predicted normal map's written height (:func:`relief_maps`): its radial scores
    about ``centre`` (default the image centre; :func:`~svbrdf.runtime.quality.relief_check.relief_radial`) and,
    with ``gt``, :func:`height_lowband_error` against the truth's plainly integrated normals; empty without a
    normal map."""
    if pred.normal is None:
        return {}
    height = relief_maps(pred.normal, maps="height", zero="unit").height
    out = dict(relief_radial(height, centre))
    if gt is not None and gt.normal is not None:
        truth, _ = height_from_normals(gt.normal, zero="unit", low_cut=0)
        out["height_lowband_err"] = height_lowband_error(height, truth)
    return out


__all__ = ["rmse", "angular_error_deg", "map_errors", "evaluation_lights", "evaluate", "MAP_METRICS",
           "relief_metrics", "height_lowband_error", "RELIEF_METRICS", "LOWBAND_CYCLES", "colour_metrics",
           "COLOUR_METRICS",
           "ARTIST_METRICS", "map_std", "gaussian_blur", "ssim_map", "grazing_errors", "relight_view", "capture_errors",
           "artist_metrics", "CAPTURE_CLIP_SRGB"]
