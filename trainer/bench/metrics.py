"""Every benchmark metric, defined once (numpy only, no torch).

Conventions shared by all metrics:

* maps are :class:`svbrdf.runtime.maps.Maps` (linear, channel-last float32, OpenGL normals);
* "sRGB" means: clip to [0, 1], then encode with the exact sRGB curve (:func:`svbrdf.runtime.colour.linear_to_srgb` with ``clip=True``);
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

Re-rendering errors (:func:`svbrdf.runtime.render.rerender_rmse`, beside the renderer so that the runtime's
``--quality auto`` rule computes the same number): both texture sets are rendered with the project renderer
(:func:`svbrdf.runtime.render.render`, the benchmark's :class:`~svbrdf.runtime.render.RenderConfig`) under each
light, every render is converted to sRGB (clipped to [0, 1] first, as a display or a camera would), and the
RMSE is pooled over all lights, pixels and channels:

* ``rerender_rmse``: the 9 lights of :func:`svbrdf.runtime.render.novel_lights` plus the input flash (10 renders);
* ``input_rmse``: the input flash only. For a real photo (no ground truth) the reference is the photo itself
  (clipped to [0, 1], sRGB-encoded), so this is the only re-rendering metric there; it is given twice:
  ``input_rmse`` with the benchmark's configuration (ZHAO: no light fall-off, which favours maps that carry the
  photo's fall-off as burn-in) and ``input_rmse_falloff`` with inverse-square fall-off, as a real flash has.

Highlight burn-in: the label-free score of :mod:`svbrdf.runtime.burn_in` (``burn_*`` per map, ``burn_in`` the
mean of their absolute values), imported from there so the runtime reports the same number.
"""

from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from svbrdf.runtime.burn_in import BURN_METRICS, burn_in_scores
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.maps import Maps, encode_normal, normalize_normals
from svbrdf.runtime.render import ZHAO, RenderConfig, novel_lights, rerender_rmse

#: Keys returned by :func:`map_errors`.
MAP_METRICS = ("diffuse_rmse", "diffuse_rmse_srgb", "specular_rmse", "specular_rmse_srgb", "roughness_rmse",
               "normal_rmse", "normal_angle_deg")


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
        out["input_rmse_falloff"] = rerender_rmse(pred, photo, [None], config.replace(falloff=True))
    out.update(burn_in_scores(pred, centre))
    return out


__all__ = ["rmse", "angular_error_deg", "map_errors", "evaluation_lights", "evaluate", "MAP_METRICS"]
