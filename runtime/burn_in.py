"""Highlight burn-in: how much of the flash highlight a texture set carries (numpy, label-free).

A flash photo of a stationary material is brightest where the light
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

Label-free: the score needs the maps and, for a real photo, the photo (to find the highlight), never a ground
truth, so the runtime reports it with every estimate (:func:`photo_burn_in`) and the benchmark scores every
method with the same function (:mod:`svbrdf.trainer.bench.metrics`).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Dict, Optional, Tuple

import numpy as np

from .maps import MAP_NAMES, Maps, normalize_normals
from .tiling import block_mean

#: Burn-in geometry, as fractions of the image width.
DISC_RADIUS = 0.15
RING_RADII = (0.35, 0.5)
BURN_EPS = 0.01
#: Keys returned by :func:`burn_in_scores` (plus ``burn_in``).
BURN_METRICS = tuple(f"burn_{n}" for n in MAP_NAMES)
#: :func:`photo_burn_in` scores a block-averaged copy no longer than this (the score is low-frequency).
SCORE_MAX_SIDE = 256


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


@lru_cache(maxsize=8)
def _regions(shape: Tuple[int, int], centre: Optional[Tuple[float, float]]) -> Tuple[np.ndarray, np.ndarray]:
    """The disc and ring masks (H, W) of the score around ``centre`` (default the image centre); cached, since the
    four maps of one texture set share them."""
    h, w = shape
    cy, cx = (h / 2.0, w / 2.0) if centre is None else centre
    r = np.hypot(np.arange(h)[:, None] + 0.5 - cy, np.arange(w)[None, :] + 0.5 - cx) / w
    return r <= DISC_RADIUS, (r >= RING_RADII[0]) & (r <= RING_RADII[1])


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
    disc, ring = _regions(g.shape, None if centre is None else (float(centre[0]), float(centre[1])))
    if not disc.any() or not ring.any() or np.ptp(g) == 0:  # (a constant field: exactly 0, not rounding noise)
        return 0.0
    return float((g[disc].mean() - g[ring].mean()) / (g.std() + eps))


def burn_in_scores(maps: Maps, centre: Optional[Tuple[float, float]] = None) -> Dict[str, float]:
    """Burn-in score of each map (``burn_diffuse`` ... ``burn_normal``) and ``burn_in`` = mean of ``|score|``."""
    maps = maps.clipped()
    out = {f"burn_{n}": burn_in(_burn_field(n, a), centre) for n, a in maps.items()}
    out["burn_in"] = float(np.mean([abs(v) for v in out.values()]))
    return out


def photo_burn_in(maps: Maps, photo: np.ndarray) -> Dict[str, float]:
    """Label-free burn-in scores of the maps estimated from ``photo``, centred on the photo's highlight.

    Args:
        maps: the estimated texture set (H, W), all four maps.
        photo: (H, W, 3) linear photo the maps were estimated from.

    Returns:
        ``burn_diffuse`` ... ``burn_normal`` (signed) and ``burn_in`` (mean of their absolute values), plus
        ``centre`` = [row, column] of the highlight in the maps' pixels. Maps longer than
        :data:`SCORE_MAX_SIDE` are scored on a block-averaged copy.
    """
    photo = np.asarray(photo, dtype=np.float32)
    if photo.shape[:2] != maps.shape:
        raise ValueError(f"photo {photo.shape[:2]} and maps {maps.shape} differ in size")
    k = max(1, math.ceil(max(maps.shape) / SCORE_MAX_SIDE))
    small = maps if k == 1 else Maps(**{n: block_mean(a, k) for n, a in maps.items()}, meta=dict(maps.meta))
    cy, cx = highlight_centre(photo if k == 1 else block_mean(photo, k))
    cy, cx = float(cy), float(cx)
    out: Dict[str, float] = dict(burn_in_scores(small, (cy, cx)))
    out["centre"] = [cy * k, cx * k]
    return out


__all__ = ["highlight_centre", "burn_in", "burn_in_scores", "photo_burn_in", "BURN_METRICS", "DISC_RADIUS",
           "RING_RADII", "BURN_EPS", "SCORE_MAX_SIDE"]
