"""The one flash renderer of the project: Cook-Torrance (GGX) under a point light, for numpy and torch.

The BRDF formula is written once, in :func:`shade`, on per-pixel scalar fields using only arithmetic,
``** 0.5`` and a clamp. The same code runs on numpy arrays (runtime previews, benchmark) and on torch
tensors (training, differentiable); ``svbrdf.trainer.render`` only adds the torch layout around it.

Scene (all lengths in units of half the photo width):

* the material is the plane z = 0; pixel (row i, column j) of an H x W photo has its centre at
  ``x = 2 (j + 0.5) / W - 1`` and ``y = (H / W) (1 - 2 (i + 0.5) / H)`` (+y up the image, OpenGL frame,
  see :mod:`svbrdf.runtime.core.maps`);
* the camera sits above the centre at ``(0, 0, d)``, ``d = 1 / tan(fov / 2)``, fov is the horizontal field of
  view across the photo width, unless a camera position is given (a rectified view of the same plane region from
  elsewhere, as in a multi-view capture); the flash (point light) is co-located with the camera unless a light
  position is given.

BRDF, with n, v, l, h the normal, view, light and half vectors, alpha = r**2:

.. math::

    f = \\frac{F\\,D\\,G}{4\\,(n.l)(n.v)} + w_d\\,\\frac{\\rho_d}{\\pi}, \\qquad
    L = I\\,f\\,(n.l)\\,[1 / |p_l - p|^2 \\text{ if fall-off}]

* D: GGX, ``alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)``;
* G: Smith-Schlick with ``k = alpha / 2`` (default, as Zhao et al. 2020) or the exact separable Smith GGX
  masking ``G1(x) = 2x / (x + sqrt(alpha^2 + (1 - alpha^2) x^2))`` (``geometry="smith"``);
* F: Schlick with the spherical-Gaussian exponent (UE4), ``F0 + (1 - F0) 2^((-5.55473 v.h - 6.98316) v.h)``
  (default), or ``F = F0`` (``fresnel="none"``, a perfect-mirror Fresnel scaled by F0, as Mitsuba's
  ``roughconductor`` with ``material="none"``);
* ``w_d = 1`` (Zhao et al. 2020) or ``1 - rho_s`` (Deschaintre et al. 2018, ``diffuse_conservation=True``).

Numerical guards (float32-safe values and gradients at roughness 0, grazing angles and black maps):
alpha >= ``ALPHA_MIN`` (1e-3, i.e. r ~ 0.032), cosines clamped to >= ``COS_EPS`` (1e-4), vector norms with an
epsilon under the square root.
"""

from __future__ import annotations

import math
from typing import Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from .maps import Maps, _sum_squares
from .render_config import DESCHAINTRE, ZHAO, RenderConfig, physical_config

ALPHA_MIN = 1e-3
COS_EPS = 1e-4
NORM_EPS = 1e-12


def _clamp_min(x: Any, lo: float) -> Any:
    if isinstance(x, np.ndarray) or np.isscalar(x):
        return np.maximum(x, lo)
    return x.clamp_min(lo)  # torch.Tensor


def _normalize3(x: Any, y: Any, z: Any) -> Tuple[Any, Any, Any]:
    inv = (x * x + y * y + z * z + NORM_EPS) ** -0.5
    return x * inv, y * inv, z * inv


def shade(
    n: Sequence[Any],
    v: Sequence[Any],
    l: Sequence[Any],
    specular: Any,
    roughness: Any,
    config: RenderConfig = ZHAO,
    light_dist2: Optional[Any] = None,
) -> Tuple[Any, Any]:
    """Per-pixel shading weights: the one BRDF formula of the project (numpy or torch).

    Args:
        n: normal components (nx, ny, nz), each of the same shape S (any shape); need not be unit length.
        v: unit vector from the surface point to the camera, components broadcastable to S.
        l: unit vector from the surface point to the light, components broadcastable to S.
        specular: rho_s, shape S, linear in [0, 1].
        roughness: r, shape S, in [0, 1].
        config: renderer settings.
        light_dist2: squared light distance (broadcastable to S), used only if ``config.falloff``.

    Returns:
        ``(diffuse_weight, specular_radiance)``, both of shape S: the linear radiance is
        ``diffuse_weight * rho_d + specular_radiance`` for each RGB channel of rho_d.
    """
    nx, ny, nz = _normalize3(*n)
    vx, vy, vz = v
    lx, ly, lz = l
    hx, hy, hz = _normalize3(vx + lx, vy + ly, vz + lz)
    n_l = _clamp_min(nx * lx + ny * ly + nz * lz, COS_EPS)
    n_v = _clamp_min(nx * vx + ny * vy + nz * vz, COS_EPS)
    n_h = _clamp_min(nx * hx + ny * hy + nz * hz, COS_EPS)
    v_h = _clamp_min(vx * hx + vy * hy + vz * hz, COS_EPS)

    alpha = _clamp_min(roughness * roughness, ALPHA_MIN)
    a2 = alpha * alpha
    denom = n_h * n_h * (a2 - 1.0) + 1.0
    d_term = a2 / (math.pi * denom * denom)

    if config.geometry == "schlick":
        k = alpha * 0.5
        vis = 1.0 / ((n_l * (1.0 - k) + k) * (n_v * (1.0 - k) + k))  # G / (n.l n.v)
    else:
        g1_l = 2.0 / (1.0 + (a2 + (1.0 - a2) * n_l * n_l) ** 0.5 / n_l)  # 2x / (x + sqrt(..)) rewritten
        g1_v = 2.0 / (1.0 + (a2 + (1.0 - a2) * n_v * n_v) ** 0.5 / n_v)
        vis = g1_l * g1_v / (n_l * n_v)

    if config.fresnel == "schlick":
        fres = specular + (1.0 - specular) * 2.0 ** ((-5.55473 * v_h - 6.98316) * v_h)
    else:
        fres = specular

    light = config.intensity * n_l
    if config.falloff:
        if light_dist2 is None:
            raise ValueError("falloff needs light_dist2")
        light = light * (config.camera_distance ** 2) / light_dist2
    spec_radiance = light * fres * vis * d_term * 0.25
    diff_weight = light / math.pi
    if config.diffuse_conservation:
        diff_weight = diff_weight * (1.0 - specular)
    return diff_weight, spec_radiance


def plane_positions(height: int, width: int) -> np.ndarray:
    """World positions (H, W, 3) float32 of pixel centres on the plane z = 0 (see module docstring)."""
    if height < 1 or width < 1:
        raise ValueError(f"image size must be positive, got {height}x{width}")
    xs = (2.0 * (np.arange(width, dtype=np.float64) + 0.5) / width - 1.0)
    ys = (height / width) * (1.0 - 2.0 * (np.arange(height, dtype=np.float64) + 0.5) / height)
    pos = np.zeros((height, width, 3), dtype=np.float64)
    pos[..., 0] = xs[None, :]
    pos[..., 1] = ys[:, None]
    return pos.astype(np.float32)


def camera_position(config: RenderConfig = ZHAO) -> np.ndarray:
    """Camera (= flash) position (3,) above the photo centre."""
    return np.array([0.0, 0.0, config.camera_distance], dtype=np.float32)


def light_vectors(
    height: int, width: int, light_pos: Optional[Sequence[float]] = None, config: RenderConfig = ZHAO,
    camera_pos: Optional[Sequence[float]] = None,
) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit view and light directions for every pixel of a whole photo, and the squared light distance.

    Compute them once for the whole photo and crop them with a tile, so that a corner tile is lit and
    seen obliquely as in the photo.

    Args:
        height, width: photo size in pixels.
        light_pos: light position (3,) in scene units; ``None`` = co-located with the camera (flash).
        config: renderer settings (field of view).
        camera_pos: camera position (3,) in scene units; ``None`` = :func:`camera_position` (above the centre).

    Returns:
        ``(view, light, light_dist2)``: (H, W, 3), (H, W, 3) float32 unit vectors and (H, W, 1) float32.
    """
    pos = plane_positions(height, width).astype(np.float64)
    cam = camera_position(config).astype(np.float64) if camera_pos is None else \
        np.asarray(camera_pos, dtype=np.float64).reshape(3)
    lp = cam if light_pos is None else np.asarray(light_pos, dtype=np.float64).reshape(3)
    v = cam - pos
    v /= np.sqrt(_sum_squares(v))
    l = lp - pos
    d2 = _sum_squares(l)
    l /= np.sqrt(d2)
    return v.astype(np.float32), l.astype(np.float32), d2.astype(np.float32)


def render(
    maps: Maps,
    light_pos: Optional[Sequence[float]] = None,
    config: RenderConfig = ZHAO,
    full_size: Optional[Tuple[int, int]] = None,
    offset: Tuple[int, int] = (0, 0),
    camera_pos: Optional[Sequence[float]] = None,
) -> np.ndarray:
    """Render a texture set under a point light (numpy, no torch).

    Args:
        maps: the texture set (see :class:`svbrdf.runtime.core.maps.Maps`).
        light_pos: light position (3,), scene units; ``None`` = the camera flash.
        config: renderer settings.
        camera_pos: camera position (3,), scene units; ``None`` = above the centre at the ``config`` distance.
            The image stays the rectified view of the plane region ``x in [-1, 1]`` (only the view direction
            of each pixel changes).
        full_size: (H, W) of the whole photo when ``maps`` is a tile of it; default: the maps' size.
        offset: (row, column) of the tile's top-left pixel in the whole photo.

    Returns:
        (H, W, 3) float32 linear radiance (not clamped; may exceed 1).

    Raises:
        ValueError: ``maps`` lacks one of the four maps (a ``--maps`` subset).
    """
    maps.require(what="rendering")
    h, w = maps.shape
    fh, fw = full_size if full_size is not None else (h, w)
    v, l, d2 = light_vectors(fh, fw, light_pos, config, camera_pos)
    y0, x0 = offset
    v, l, d2 = (a[y0:y0 + h, x0:x0 + w] for a in (v, l, d2))
    n = maps.normal
    dw, sr = shade(
        (n[..., 0], n[..., 1], n[..., 2]),
        (v[..., 0], v[..., 1], v[..., 2]),
        (l[..., 0], l[..., 1], l[..., 2]),
        maps.specular[..., 0],
        maps.roughness[..., 0],
        config,
        d2[..., 0],
    )
    return (dw[..., None] * maps.diffuse + sr[..., None]).astype(np.float32)


def novel_lights(config: RenderConfig = ZHAO, grid: int = 3, spread: float = 0.6) -> np.ndarray:
    """A fixed ``grid x grid`` set of light positions (N, 3) at the camera height, for relighting metrics.

    Lights sit on a square grid of half-width ``spread`` (scene units) at height ``d``; the centre one
    coincides with the flash.
    """
    d = config.camera_distance
    ticks = np.linspace(-spread, spread, grid)
    return np.array([[x, y, d] for y in ticks[::-1] for x in ticks], dtype=np.float32)


def grazing_lights(config: RenderConfig = ZHAO, angles_deg: Sequence[float] = (60.0, 75.0),
                   azimuths: int = 4) -> np.ndarray:
    """Light positions (N, 3) that graze the material: ``angles_deg`` from the normal, ``azimuths`` directions each.

    Seen from the photo centre, each light sits at the camera distance ``d`` (scene units) in the direction at
    ``theta`` from +z and azimuth ``phi = 2 pi k / azimuths + theta`` (the second ring turned against the
    first so that their azimuths differ). Under such light the normals and the roughness decide what a person
    sees: bumps cast long shading, and the specular lobe rises at grazing angles.
    """
    d = config.camera_distance
    out = []
    for theta in np.radians(np.asarray(angles_deg, dtype=np.float64)):
        for k in range(int(azimuths)):
            phi = 2.0 * math.pi * k / azimuths + theta
            out.append([d * math.sin(theta) * math.cos(phi), d * math.sin(theta) * math.sin(phi),
                        d * math.cos(theta)])
    return np.array(out, dtype=np.float32)


def rerender_rmse(
    pred: Maps,
    reference: Union[Maps, np.ndarray],
    lights: Iterable[Optional[Sequence[float]]],
    config: RenderConfig = ZHAO,
) -> float:
    """sRGB RMSE between renders of ``pred`` and of ``reference``, pooled over ``lights``.

    Every render is clipped to [0, 1] (as a display or a camera would) and sRGB-encoded
    (:func:`svbrdf.runtime.core.colour.linear_to_srgb` with ``clip=True``).

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
    from .colour import linear_to_srgb  # OpenImageIO: only when a metric is computed

    def to_srgb(linear):
        return linear_to_srgb(linear, clip=True)

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


__all__ = [
    "RenderConfig", "ZHAO", "DESCHAINTRE", "physical_config", "shade", "render", "light_vectors", "plane_positions",
    "camera_position", "novel_lights", "grazing_lights", "rerender_rmse", "ALPHA_MIN", "COS_EPS",
]
