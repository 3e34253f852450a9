"""Every benchmark metric, defined once (numpy only, no torch).

Conventions shared by all metrics:

* maps are :class:`svbrdf.runtime.maps.Maps` (linear, channel-last float32, OpenGL normals);
* "sRGB" means: clip to [0, 1], then encode with the exact sRGB curve (:func:`svbrdf.runtime.colour.linear_to_srgb`);
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

Re-rendering errors (:func:`rerender_rmse`): both texture sets are rendered with the project renderer
(:func:`svbrdf.runtime.render.render`, the benchmark's :class:`~svbrdf.runtime.render.RenderConfig`) under each
light, every render is converted to sRGB (clipped to [0, 1] first, as a display or a camera would), and the
RMSE is pooled over all lights, pixels and channels:

* ``rerender_rmse``: the 9 lights of :func:`svbrdf.runtime.render.novel_lights` plus the input flash (10 renders);
* ``input_rmse``: the input flash only. For a real photo (no ground truth) the reference is the photo itself
  (clipped to [0, 1], sRGB-encoded), so this is the only re-rendering metric there.

Highlight burn-in (:func:`burn_in`): a flash photo of a stationary material is brightest where the light
is closest (the centre, for a co-located flash); a method that bakes this highlight into its maps leaves a
radial trend centred there. The score of one map is

.. math::

    b = \\frac{\\bar g_{disc} - \\bar g_{ring}}{\\operatorname{std}(g) + \\epsilon}

where ``g`` is a scalar field of the map (mean over the RGB channels for diffuse; the map itself for specular
and roughness; ``n_z`` for normals, which drops where normals tilt), ``disc`` is the set of pixels within
``0.15 W`` of the highlight centre, ``ring`` the pixels between ``0.35 W`` and ``0.5 W`` of it (``W`` = image
width), ``std`` the standard deviation of ``g`` over the whole map and ``epsilon = 0.01`` (so near-constant
maps are not amplified). It is signed: > 0 means the map is larger at the highlight (a burnt-in diffuse or
specular highlight), < 0 smaller (e.g. roughness lowered under the highlight). A constant map scores exactly
0, a stationary texture about 0 (a ground-truth map's score shows the level reached by chance; it is
recorded as ``gt_burn_*``). ``burn_in`` (the headline number) is the mean of ``|b|`` over the four maps.
For synthetic cases the centre is the image centre (the flash is above it); for real photos it is
:func:`highlight_centre` of the photo.
"""

from __future__ import annotations

from typing import Dict, Iterable, Optional, Sequence, Tuple

import numpy as np

from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.maps import MAP_NAMES, Maps, encode_normal, normalize_normals
from svbrdf.runtime.render import ZHAO, RenderConfig, novel_lights, render

#: Burn-in geometry, as fractions of the image width.
DISC_RADIUS = 0.15
RING_RADII = (0.35, 0.5)
BURN_EPS = 0.01

#: Keys returned by :func:`map_errors`.
MAP_METRICS = ("diffuse_rmse", "diffuse_rmse_srgb", "specular_rmse", "specular_rmse_srgb", "roughness_rmse",
               "normal_rmse", "normal_angle_deg")
#: Keys returned by :func:`burn_in_scores` (plus ``burn_in``).
BURN_METRICS = tuple(f"burn_{n}" for n in MAP_NAMES)


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square error ``sqrt(mean((a - b)^2))`` over all elements (arrays of the same shape)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"shape mismatch: {a.shape} vs {b.shape}")
    return float(np.sqrt(np.mean((a - b) ** 2)))


def to_srgb(linear: np.ndarray) -> np.ndarray:
    """Linear values -> clipped to [0, 1] -> sRGB-encoded (exact curve), float32, same shape."""
    return linear_to_srgb(np.clip(np.asarray(linear, dtype=np.float32), 0.0, 1.0))


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
        "diffuse_rmse_srgb": rmse(to_srgb(p.diffuse), to_srgb(g.diffuse)),
        "specular_rmse": rmse(p.specular, g.specular),
        "specular_rmse_srgb": rmse(to_srgb(p.specular), to_srgb(g.specular)),
        "roughness_rmse": rmse(p.roughness, g.roughness),
        "normal_rmse": rmse(encode_normal(p.normal), encode_normal(g.normal)),
        "normal_angle_deg": angular_error_deg(p.normal, g.normal),
    }


def rerender_rmse(
    pred: Maps,
    reference: Maps | np.ndarray,
    lights: Iterable[Optional[Sequence[float]]],
    config: RenderConfig = ZHAO,
) -> float:
    """sRGB RMSE between renders of ``pred`` and of ``reference``, pooled over ``lights``.

    Args:
        pred: predicted texture set (H, W).
        reference: ground-truth texture set (rendered the same way), or a linear photo (H, W, 3) that is
            compared with every render (only meaningful for its own light).
        lights: light positions (3,) in scene units; ``None`` = the co-located flash.
        config: renderer settings (the same for both sides).

    Returns:
        ``sqrt(mean over lights, pixels, channels of (srgb(render_pred) - srgb(render_ref))^2)``.
    """
    pred = pred.clipped()
    ref_maps = reference.clipped() if isinstance(reference, Maps) else None
    ref_img = None if ref_maps is not None else to_srgb(reference)
    total, count = 0.0, 0
    for light in lights:
        a = to_srgb(render(pred, light, config)).astype(np.float64)
        b = ref_img if ref_maps is None else to_srgb(render(ref_maps, light, config))
        if a.shape != b.shape:
            raise ValueError(f"size mismatch: prediction {a.shape} vs reference {b.shape}")
        total += float(np.sum((a - b) ** 2))
        count += a.size
    if count == 0:
        raise ValueError("no lights given")
    return float(np.sqrt(total / count))


def evaluation_lights(config: RenderConfig = ZHAO) -> list:
    """The fixed re-rendering lights: the 3 x 3 grid of :func:`novel_lights` plus the input flash (``None``)."""
    return [tuple(float(c) for c in p) for p in novel_lights(config)] + [None]


def highlight_centre(photo: np.ndarray, window: float = 0.25) -> Tuple[float, float]:
    """Where the flash highlight of a photo is: the centre of the brightest ``window * W`` square.

    The luminance (channel mean) is box-filtered with a square of side ``window`` times the width (large, so
    the texture averages out and the smooth flash fall-off dominates) and the arg-max is returned.

    Args:
        photo: (H, W, 3) linear photo.

    Returns:
        (row, column) in pixel units (pixel centres at integer + 0.5).
    """
    lum = np.asarray(photo, dtype=np.float64).mean(axis=-1)
    h, w = lum.shape
    k = max(1, min(h, w, int(round(window * w))))
    c = np.pad(np.cumsum(np.cumsum(lum, 0), 1), ((1, 0), (1, 0)))
    box = c[k:, k:] - c[:-k, k:] - c[k:, :-k] + c[:-k, :-k]  # sums over every k x k window
    i, j = np.unravel_index(int(np.argmax(box)), box.shape)
    return i + k / 2.0, j + k / 2.0


def _burn_field(name: str, arr: np.ndarray) -> np.ndarray:
    if name == "normal":
        return normalize_normals(arr)[..., 2]
    return np.asarray(arr, dtype=np.float64).mean(axis=-1)


def burn_in(field: np.ndarray, centre: Optional[Tuple[float, float]] = None, eps: float = BURN_EPS) -> float:
    """Signed highlight burn-in score of one scalar field (H, W) (see the module docstring).

    Args:
        field: (H, W) values (e.g. a map's channel mean).
        centre: (row, column) of the highlight in pixels; default the image centre.
        eps: added to the field's standard deviation.

    Returns:
        ``(mean in the disc - mean in the ring) / (std + eps)``; 0 for a constant field or if the ring or the
        disc is empty.
    """
    g = np.asarray(field, dtype=np.float64)
    if g.ndim != 2:
        raise ValueError(f"burn_in expects an (H, W) field, got {g.shape}")
    h, w = g.shape
    cy, cx = (h / 2.0, w / 2.0) if centre is None else centre
    yy, xx = np.mgrid[0:h, 0:w]
    r = np.hypot(yy + 0.5 - cy, xx + 0.5 - cx) / w
    disc = r <= DISC_RADIUS
    ring = (r >= RING_RADII[0]) & (r <= RING_RADII[1])
    if not disc.any() or not ring.any() or np.ptp(g) == 0:  # (a constant field: exactly 0, not rounding noise)
        return 0.0
    return float((g[disc].mean() - g[ring].mean()) / (g.std() + eps))


def burn_in_scores(maps: Maps, centre: Optional[Tuple[float, float]] = None) -> Dict[str, float]:
    """Burn-in score of each map (``burn_diffuse`` ... ``burn_normal``) and ``burn_in`` = mean of ``|score|``."""
    maps = maps.clipped()
    out = {f"burn_{n}": burn_in(_burn_field(n, a), centre) for n, a in maps.items()}
    out["burn_in"] = float(np.mean([abs(v) for v in out.values()]))
    return out


def evaluate(
    pred: Maps,
    *,
    gt: Optional[Maps] = None,
    photo: Optional[np.ndarray] = None,
    config: RenderConfig = ZHAO,
    centre: Optional[Tuple[float, float]] = None,
) -> Dict[str, float]:
    """All metrics of one prediction.

    Args:
        pred: predicted texture set.
        gt: ground truth (synthetic case): per-map errors, ``rerender_rmse`` (10 lights) and ``input_rmse``
            against renders of ``gt``.
        photo: linear input photo (H, W, 3), used when there is no ground truth: ``input_rmse`` against it.
        config: renderer settings.
        centre: highlight centre for the burn-in scores (default the image centre).

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
    out.update(burn_in_scores(pred, centre))
    return out


__all__ = [
    "rmse", "to_srgb", "angular_error_deg", "map_errors", "rerender_rmse", "evaluation_lights", "highlight_centre",
    "burn_in", "burn_in_scores", "evaluate", "MAP_METRICS", "BURN_METRICS", "DISC_RADIUS", "RING_RADII",
    "BURN_EPS",
]
