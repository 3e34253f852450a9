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
recorded as ``gt_burn_*``).

Rings: a map can carry the flash as concentric rings (a roughness ring at the edge of the highlight, a base colour
that oscillates with the distance) whose disc and ring means are equal, so ``b`` misses them. The ring score of
one map is the share of its variance explained by its radial profile around the highlight,

.. math::

    q = \\max_{c} \\frac{\\sum_k n_k (\\bar g_k - \\bar g)^2}{\\sum_i (g_i - \\bar g)^2}
        \\cdot \\frac{\\operatorname{std}(g)^2}{\\operatorname{std}(g)^2 + \\epsilon^2}

over the pixels within ``RING_RADIUS`` (0.5 W) of a centre ``c``, binned by distance in annuli of
``1 / RING_BINS`` W (``n_k`` pixels and mean ``g_k`` in annulus k). A network's rings are rarely centred exactly
on the photo's brightest window, so ``c`` is searched on a grid of step ``1 / RING_BINS`` W within
``RING_SEARCH`` (0.05 W) of the highlight centre in each axis (the maximum over the grid). The last factor, with
the burn-in's ``epsilon``, keeps a near-constant map (a flat normal map's ``n_z``) from scoring its rounding
noise. ``q`` is in [0, 1]: 0 for a constant map; for a stationary texture the chance level (a ground-truth map's
score, recorded as ``gt_ring_*``) is a few hundredths; concentric rings or a blob score tenths. It is computed
on a block-averaged copy no longer than ``RING_MAX_SIDE`` (128 px).

``burn_in`` (the headline number) is the largest over the four maps of ``max(|b|, RING_WEIGHT q)``: a map counts
as burnt in when its highlight disc differs from its surroundings or when its variance follows the distance to the
flash, and a texture set is as burnt in as its worst map (a mean over the maps, the score before rings were added,
let a constant specular or a flat normal map, which score 0, hide the rings of the others). ``RING_WEIGHT`` (3.5) puts the two scores on one scale: it is the ratio of their mean chance levels,
``mean |b|`` 0.084 and ``mean q`` 0.023 over the four maps of 32 procedural materials (the held-out procedural set
of the benchmarks, seed 987654; no shared data was used to set it).
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

from ..core.maps import MAP_NAMES, Maps, normalize_normals
from ..core.filters import block_mean

#: Burn-in geometry, as fractions of the image width.
DISC_RADIUS = 0.15
RING_RADII = (0.35, 0.5)
BURN_EPS = 0.01
#: Ring score geometry: annuli per image width, search half-width and radius (fractions of W), scored side.
RING_BINS = 64
RING_SEARCH = 0.05
RING_RADIUS = 0.5
RING_MAX_SIDE = 128
#: Scale of the ring score in the headline ``burn_in`` (ratio of the chance levels, see the module docstring).
RING_WEIGHT = 3.5
#: Keys returned by :func:`burn_in_scores` (plus ``burn_in``): signed disc scores and ring scores per map.
BURN_METRICS = tuple(f"burn_{n}" for n in MAP_NAMES)
RING_METRICS = tuple(f"ring_{n}" for n in MAP_NAMES)
#: :func:`photo_burn_in` scores a block-averaged copy no longer than this (the score is low-frequency).
SCORE_MAX_SIDE = 256


def highlight_centre(photo: np.ndarray, window: float = 0.25) -> Tuple[float, float]:
    """Where the flash highlight of a photo is: the centre of the brightest ``window * W`` square.

    The luminance (channel mean) is box-filtered with a square of side ``window`` times the width (large, so
    the texture averages out and the smooth flash fall-off dominates) and the arg-max is returned. Decision:
    docs/decisions/016-highlight-centre.md.

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


def _annuli(shape: Tuple[int, int], centre: Tuple[float, float], bins: int,
            radius: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The geometry of :func:`radial_share` on an (H, W) grid: the flat indices of the pixels within ``radius`` W of
    ``centre`` (C order, int64), their annulus numbers (int64) and the pixel count of each annulus."""
    h, w = shape
    r = np.hypot(np.arange(h)[:, None] + 0.5 - centre[0], np.arange(w)[None, :] + 0.5 - centre[1]) / w
    inside = r <= radius
    k = (r[inside] * bins).astype(np.int64)
    return np.flatnonzero(inside), k, np.bincount(k)


def _share(s: np.ndarray, n: np.ndarray, total: float) -> float:
    used = n > 0
    return float(np.sum(s[used] ** 2 / n[used]) / total)


def radial_share(field: np.ndarray, centre: Tuple[float, float], bins: int = RING_BINS,
                 radius: float = RING_RADIUS) -> float:
    """Share of the variance of ``field`` (H, W) within ``radius`` W of ``centre`` that its radial profile explains.

    Pixels are binned by their distance to ``centre`` (row, column; pixel centres at integer + 0.5) in annuli of
    ``1 / bins`` W; the result is the between-annuli sum of squares over the total, in [0, 1] (0 when the field
    is constant there).
    """
    g = np.asarray(field, dtype=np.float64)
    idx, k, n = _annuli(g.shape, (float(centre[0]), float(centre[1])), int(bins), float(radius))
    v = g.reshape(-1)[idx]
    if v.size < 2:
        return 0.0
    v = v - v.mean()
    total = float(np.dot(v, v))
    if total <= 0.0:
        return 0.0
    return _share(np.bincount(k, weights=v), n, total)


class _RingGrid:
    """The annuli of every centre the ring score searches (:func:`ring_score`) on one (h, w) grid, laid end to end:
    ``idx`` the pixels of centre 0, then of centre 1, ... (flat indices), ``labels`` = centre * ``bins_max`` +
    annulus, ``bounds`` each centre's slice, ``counts`` (centres, bins_max) pixels per annulus."""

    def __init__(self, shape: Tuple[int, int], centres: Tuple[Tuple[float, float], ...]) -> None:
        parts = [_annuli(shape, c, RING_BINS, RING_RADIUS) for c in centres]
        self.bins = max(len(n) for _, _, n in parts)
        self.idx = np.concatenate([i for i, _, _ in parts])
        self.labels = np.concatenate([j * self.bins + k for j, (_, k, _) in enumerate(parts)])
        ends = np.cumsum([len(i) for i, _, _ in parts])
        self.bounds = list(zip([0, *ends[:-1].tolist()], ends.tolist()))
        self.counts = np.zeros((len(parts), self.bins), np.int64)
        for j, (_, _, n) in enumerate(parts):
            self.counts[j, :len(n)] = n


@lru_cache(maxsize=2)
def _ring_grid(shape: Tuple[int, int], centres: Tuple[Tuple[float, float], ...]) -> _RingGrid:
    """Cached: the four maps of a texture set, before and after the post-processing, share one grid and centre."""
    return _RingGrid(shape, centres)


def ring_score(field: np.ndarray, centre: Optional[Tuple[float, float]] = None, eps: float = BURN_EPS) -> float:
    """Ring score ``q`` of one scalar field (H, W) around ``centre`` (default the image centre): see the module
    docstring. The field is block-averaged to at most :data:`RING_MAX_SIDE` px first.

    The :func:`radial_share` of every centre of the search, with the same sums in the same order (the same
    result to the last bit), from one gather and one ``bincount`` over all the centres' annuli (cached per grid
    and centre)."""
    g = np.asarray(field, dtype=np.float64)
    if g.ndim != 2:
        raise ValueError(f"ring_score expects an (H, W) field, got {g.shape}")
    if np.ptp(g) == 0:
        return 0.0
    h, w = g.shape
    cy, cx = (h / 2.0, w / 2.0) if centre is None else (float(centre[0]), float(centre[1]))
    k = max(1, math.ceil(max(h, w) / RING_MAX_SIDE))
    if k > 1:
        g, cy, cx = block_mean(g[..., None], k)[..., 0], cy / k, cx / k
        w = g.shape[1]
    sd = float(g.std())  # (of the float32 block means when k > 1)
    weight = sd * sd / (sd * sd + eps * eps)
    g = np.asarray(g, dtype=np.float64)
    steps = np.arange(-round(RING_SEARCH * RING_BINS), round(RING_SEARCH * RING_BINS) + 1) * (w / RING_BINS)
    centres = tuple((float(cy + dy), float(cx + dx)) for dy in steps for dx in steps)
    grid = _ring_grid(g.shape, centres)
    v_all = g.reshape(-1)[grid.idx]
    totals = []
    for a, b in grid.bounds:  # each centre's values less their own mean (pairwise sums, as radial_share)
        if b - a < 2:
            totals.append(0.0)
            continue
        v = v_all[a:b] - v_all[a:b].mean()  # a fresh array, as in radial_share (the dot's rounding follows it)
        v_all[a:b] = v
        totals.append(float(np.dot(v, v)))
    s = np.bincount(grid.labels, weights=v_all, minlength=len(centres) * grid.bins).reshape(len(centres), grid.bins)
    shares = [_share(s[j], grid.counts[j], t) if t > 0.0 else 0.0 for j, t in enumerate(totals)]
    return float(max(shares) * weight)


def burn_in_scores(maps: Maps, centre: Optional[Tuple[float, float]] = None) -> Dict[str, float]:
    """Burn-in scores of a texture set around ``centre`` (default the image centre; see the module docstring).

    Returns:
        ``burn_diffuse`` ... ``burn_normal`` (signed disc scores ``b``), ``ring_diffuse`` ... ``ring_normal``
        (ring scores ``q``) and ``burn_in`` = the largest over the maps of ``max(|b|, RING_WEIGHT q)``.
    """
    maps = maps.clipped()
    out: Dict[str, float] = {}
    per_map = []
    for n, a in maps.items():
        field = _burn_field(n, a)
        b, q = burn_in(field, centre), ring_score(field, centre)
        out[f"burn_{n}"], out[f"ring_{n}"] = b, q
        per_map.append(max(abs(b), RING_WEIGHT * q))
    out["burn_in"] = float(max(per_map, default=0.0))
    return out


def photo_burn_in(maps: Maps, photo: np.ndarray) -> Dict[str, float]:
    """Label-free burn-in scores of the maps estimated from ``photo``, centred on the photo's highlight.

    Args:
        maps: the estimated texture set (H, W), all four maps.
        photo: (H, W, 3) linear photo the maps were estimated from.

    Returns:
        ``burn_*`` (signed), ``ring_*`` and ``burn_in`` of :func:`burn_in_scores`, plus
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


__all__ = ["highlight_centre", "burn_in", "radial_share", "ring_score", "burn_in_scores", "photo_burn_in",
           "BURN_METRICS", "RING_METRICS", "DISC_RADIUS", "RING_RADII", "BURN_EPS", "SCORE_MAX_SIDE", "RING_BINS",
           "RING_SEARCH", "RING_RADIUS", "RING_MAX_SIDE", "RING_WEIGHT"]
