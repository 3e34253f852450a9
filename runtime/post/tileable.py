"""Tileable texture sets: maps that repeat without a visible seam, at the same size and scale (pure numpy).

:func:`make_tileable` takes a texture set (:class:`~svbrdf.runtime.core.maps.Maps`, any subset of the four maps) and
returns one of the same size whose opposite borders join: column ``W - 1`` continues into column 0 and row
``H - 1`` into row 0. Every map is cut the same way, so the maps stay registered with each other.

Methods (decision: docs/decisions/009-tileable-cut.md):

``"cut"`` (default): a strip of the material itself is laid over the wrap, joined by minimal-error cuts, and the
    steps left across the cuts are repaired.
    For the horizontal wrap, a vertical strip ``4 o`` pixels wide is copied from where it best fits
    (``o`` = :func:`default_overlap`) and placed across the wrap: its left half ends at column ``W - 1``, its
    right half starts at column 0, so the wrap falls *inside* the copied strip, between two pixels that were
    neighbours in the photo. On each side, the ``o`` columns where the strip and the maps overlap are joined
    along the path of least difference (a dynamic-programming cut, top to bottom, one column per row at most).
    Then the same for the vertical wrap with a horizontal strip of the result; that cut runs across the whole
    width and is constrained to close on itself across the horizontal wrap. The difference that decides the
    cuts is summed over every map present, each normalised by its own variance. A cut still leaves a step
    where the two sides differ in level (a smooth map such as roughness), so the repair solves a periodic screened
    Poisson problem (:func:`_repair`, by FFT): every gradient of the result is kept except across a join,
    where the input's own gradient at the source is asked for, and the step is spread smoothly over about
    ``o`` pixels. Every detail is a pixel of the input; only a smooth correction of small amplitude is added,
    so the scale and the value statistics are kept; the cost is that a strip of ``4 o`` pixels repeats
    content from elsewhere in the set.
``"blend"``: the variance-preserving cross-fade of the set with itself shifted by half its size (first along
    x, then along y): ``mu + (w (a - mu) + (1 - w) (b - mu)) / sqrt(w^2 + (1 - w)^2)`` per channel, ``w`` a
    raised cosine that is 0 at the borders and 1 in the middle; normals renormalised. Kept for comparison: it
    doubles every feature in the cross-faded zones (a ghosted cross).

Neither method makes a non-stationary set stationary: a large-scale pattern (a ring left around the flash, a
gradient across the photo) repeats with the tile.

Scores (:func:`seam_scores`, :func:`histogram_distance`) are what the benchmark reports and what
:func:`make_tileable` records in ``meta["tileable"]``.
"""

from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from ..errors import SvbrdfError
from ..core.maps import MAP_NAMES, Maps

#: Methods of :func:`make_tileable`; the first is the default.
METHODS = ("cut", "blend")
#: Smallest side :func:`make_tileable` accepts, in pixels.
MIN_SIZE = 16
#: The repair spreads a join's step over about this many overlaps (the screened Poisson weight is 1 / (s o)^2).
REPAIR_SPREAD = 1.0
#: Border pixels of the input whose steps the repair does not ask of a join (see :func:`_guidance`).
GUIDE_MARGIN = 2

__all__ = ["METHODS", "MIN_SIZE", "make_tileable", "default_overlap", "seam_scores", "histogram_distance",
           "cut_scores", "tile_grid", "screened_poisson", "map_weights"]


def default_overlap(height: int, width: int) -> int:
    """Overlap ``o`` of the ``"cut"`` method: 1/16 of the short side, at least 2 px (16 px at 256 px).

    The copied strip is ``4 o`` wide, a quarter of the short side."""
    return max(2, min(height, width) // 16)


# ---------------------------------------------------------------------------------------------------- scores

def _pair_energy(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared difference summed over channels, per pixel pair: (..., C) x2 -> (...)."""
    d = np.subtract(a, b, dtype=np.float32)
    return np.einsum("...c,...c->...", d, d)


def seam_scores(arr: np.ndarray) -> Dict[str, Optional[float]]:
    """Gradient energy across the wrap against the interior, of one map.

    Args:
        arr: (H, W, C) map (any range; the energy is in its units squared).

    Returns:
        ``{"x": ratio, "y": ratio, "max": the larger}``: ``x`` = mean over rows of
        ``|arr[:, 0] - arr[:, W - 1]|^2`` (summed over channels) divided by the mean over every interior
        horizontal neighbour pair of the same quantity; ``y`` the same for rows. 1 means the wrap looks like any
        column boundary of the map; a visible seam is well above 1. ``None`` where the map is constant along
        that axis (no interior energy: no seam either).
    """
    arr = np.asarray(arr)
    if arr.ndim == 2:
        arr = arr[..., None]
    out: Dict[str, Optional[float]] = {}
    for axis, key in ((1, "x"), (0, "y")):
        a = np.moveaxis(arr, axis, 1)  # the wrap is along axis 1 of `a`
        interior = float(np.mean(_pair_energy(a[:, 1:], a[:, :-1]), dtype=np.float64))
        wrap = float(np.mean(_pair_energy(a[:, 0], a[:, -1]), dtype=np.float64))
        out[key] = None if interior <= 1e-20 else wrap / interior
    vals = [v for v in (out["x"], out["y"]) if v is not None]
    out["max"] = max(vals) if vals else None
    return out


#: Pixels of a map :func:`histogram_distance` reads at most (every k-th beyond: quantiles within ~1e-4).
HISTOGRAM_SAMPLES = 1 << 18


def _sample(rows: np.ndarray) -> np.ndarray:
    step = max(1, -(-rows.shape[0] // HISTOGRAM_SAMPLES))
    return rows[::step].astype(np.float64)


def histogram_distance(before: np.ndarray, after: np.ndarray) -> float:
    """Wasserstein-1 distance between the value distributions of two maps, mean over channels, in map units.

    The mean absolute difference of the two quantile functions (1024 quantiles; of every k-th pixel where a map has
    more than :data:`HISTOGRAM_SAMPLES`): 0 when the values are the same multiset; a contrast loss of a factor ``s`` on a map of standard deviation ``sigma`` gives about
    ``(1 - s) sigma sqrt(2 / pi)``.

    Args:
        before, after: (H, W, C) maps with the same C (sizes may differ).
    """
    a = _sample(np.asarray(before).reshape(-1, np.shape(before)[-1]))
    b = _sample(np.asarray(after).reshape(-1, np.shape(after)[-1]))
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"channel counts differ: {a.shape[1]} vs {b.shape[1]}")
    q = (np.arange(1024) + 0.5) / 1024
    return float(np.mean([np.mean(np.abs(np.quantile(a[:, c], q) - np.quantile(b[:, c], q)))
                          for c in range(a.shape[1])]))


def cut_scores(arr: np.ndarray, source: np.ndarray) -> Dict[str, Optional[float]]:
    """Gradient energy across the joins of a tiled map against its natural neighbour pairs (the join score).

    A join is a pair of neighbouring pixels (the wrap's pairs included) whose sources were not neighbours in the
    input: the cuts of a ``"cut"`` result, or with the identity ``source`` the wrap of the untiled map. This is
    where a seam can be; 1 means the joins look like any neighbour pair.

    Args:
        arr: (H, W, C) tiled map.
        source: (H, W, 2) int, the input pixel (row, column) each output pixel was copied from
            (``meta["tileable"]`` does not keep it; :func:`make_tileable` with ``return_source=True``).

    Returns:
        ``{"ratio": mean energy over the neighbour pairs (wrap included) whose sources are not neighbours in the
        input / mean over those that are, "pairs": how many cut pairs}`` (ratio ``None`` without cut pairs or
        interior energy).
    """
    arr = np.asarray(arr)
    if arr.ndim == 2:
        arr = arr[..., None]
    cut_e, nat_e = [], []
    for axis, step in ((1, (0, 1)), (0, (1, 0))):
        a = arr
        s = source
        nxt_a = np.roll(a, -1, axis=axis)
        nxt_s = np.roll(s, -1, axis=axis)
        natural = (nxt_s[..., 0] - s[..., 0] == step[0]) & (nxt_s[..., 1] - s[..., 1] == step[1])
        e = _pair_energy(nxt_a, a)
        cut_e.append(e[~natural])
        nat_e.append(e[natural])
    cut = np.concatenate(cut_e)
    nat = np.concatenate(nat_e)
    interior = float(nat.mean(dtype=np.float64)) if nat.size else 0.0
    ratio = None if cut.size == 0 or interior <= 1e-20 else float(cut.mean(dtype=np.float64)) / interior
    return {"ratio": ratio, "pairs": int(cut.size)}


# ---------------------------------------------------------------------------------------------- the cut method

def map_weights(packed: np.ndarray, groups) -> np.ndarray:
    """Per-channel weights of a difference summed over several maps packed along the last axis (``groups``: one
    channel slice per map): each map counts once, normalised by its variance (constant maps: 0). (C,) float64."""
    w = np.zeros(packed.shape[-1], dtype=np.float64)
    for sl in groups:
        var = float(np.mean(np.var(packed[..., sl].astype(np.float64), axis=(0, 1))))
        if var > 1e-12:
            w[sl] = 1.0 / (var * (sl.stop - sl.start))
    return w


def _zone_error(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    d = a.astype(np.float64) - b.astype(np.float64)
    return np.einsum("...c,c->...", d * d, w)


def _vertical_cut(err: np.ndarray) -> np.ndarray:
    """Least-cost top-to-bottom path through an (H, o) error map, moving at most one column per row.

    Returns: (H,) int, the path's column in each row."""
    h, o = err.shape
    cost = err[0].copy()
    back = np.zeros((h, o), dtype=np.int8)
    for y in range(1, h):
        left = np.concatenate(([np.inf], cost[:-1]))
        right = np.concatenate((cost[1:], [np.inf]))
        choice = np.argmin(np.stack([left, cost, right]), axis=0)  # 0: from x-1, 1: x, 2: x+1
        cost = np.choose(choice, [left, cost, right]) + err[y]
        back[y] = choice - 1
    path = np.empty(h, dtype=np.int64)
    path[-1] = int(np.argmin(cost))
    for y in range(h - 1, 0, -1):
        path[y - 1] = path[y] + back[y, path[y]]
    return path


def _closed_vertical_cut(err: np.ndarray) -> np.ndarray:
    """As :func:`_vertical_cut`, but the path closes on itself: its last column is within one of its first
    (the rows wrap around). Solved exactly for every start column at once: (H, o, o) work."""
    h, o = err.shape
    big = np.inf
    cost = np.full((o, o), big)  # cost[start, column]
    cost[np.arange(o), np.arange(o)] = err[0]
    back = np.zeros((h, o, o), dtype=np.int8)
    pad = np.full((o, 1), big)
    for y in range(1, h):
        left = np.concatenate((pad, cost[:, :-1]), axis=1)
        right = np.concatenate((cost[:, 1:], pad), axis=1)
        stack = np.stack([left, cost, right])
        choice = np.argmin(stack, axis=0)
        cost = np.take_along_axis(stack, choice[None], axis=0)[0] + err[y][None, :]
        back[y] = choice - 1
    starts = np.arange(o)[:, None]
    close = np.abs(np.arange(o)[None, :] - starts) <= 1
    total = np.where(close, cost, big)
    s, end = np.unravel_index(int(np.argmin(total)), total.shape)
    path = np.empty(h, dtype=np.int64)
    path[-1] = end
    for y in range(h - 1, 0, -1):
        path[y - 1] = path[y] + back[y, s, path[y]]
    return path


def _zone(o: int) -> int:
    """Width of the overlap zones in which a cut may run: the outer ``o`` columns of each half of the strip.

    Not wider: the maps' own pixels next to their borders, where the network's maps are least reliable, stay out of
    the join (009-tileable-cut.md)."""
    return o


def _best_source(a: np.ndarray, o: int, w: np.ndarray) -> int:
    """Column of the ``4 o``-wide strip of ``a`` that best fits across the horizontal wrap (least summed squared
    difference over both overlap zones; searched on a grid of at most ~256 candidates and rows)."""
    h, wd = a.shape[:2]
    z = _zone(o)
    left_zone = a[:, wd - 2 * o:wd - 2 * o + z]
    right_zone = a[:, 2 * o - z:2 * o]
    step = max(1, wd // 256)
    rows = slice(None, None, max(1, h // 256))

    def error(c):
        e = _zone_error(a[rows, c:c + z], left_zone[rows], w).sum()
        return e + _zone_error(a[rows, c + 4 * o - z:c + 4 * o], right_zone[rows], w).sum()

    best, best_c = np.inf, 0
    for c in range(0, wd - 4 * o + 1, step):
        e = error(c)
        if e < best:
            best, best_c = e, c
    # refine around the grid's best
    for c in range(max(0, best_c - step + 1), min(wd - 4 * o, best_c + step - 1) + 1):
        e = error(c)
        if e < best:
            best, best_c = e, c
    return best_c


def _cut_wrap_x(a: np.ndarray, o: int, w: np.ndarray, closed: bool) -> np.ndarray:
    """Make the horizontal wrap of ``a`` (H, W, C) seamless with a copied strip and two cuts (module docstring)."""
    h, wd = a.shape[:2]
    z = _zone(o)
    c = _best_source(a, o, w)
    strip = a[:, c:c + 4 * o]
    out = a.copy()
    out[:, wd - 2 * o:] = strip[:, :2 * o]
    out[:, :2 * o] = strip[:, 2 * o:]
    cut = _closed_vertical_cut if closed else _vertical_cut
    cols = np.arange(z)[None, :]
    # left zone: the maps left of the cut, the strip from it on
    left = slice(wd - 2 * o, wd - 2 * o + z)
    k = cut(_zone_error(a[:, left], strip[:, :z], w))
    keep = cols < k[:, None]
    zone = out[:, left]
    zone[keep] = a[:, left][keep]
    # right zone: the strip left of the cut, the maps from it on
    right = slice(2 * o - z, 2 * o)
    k = cut(_zone_error(strip[:, 4 * o - z:], a[:, right], w))
    keep = cols >= k[:, None]
    zone = out[:, right]
    zone[keep] = a[:, right][keep]
    return out


def _cut(packed: np.ndarray, o: int, w: np.ndarray) -> np.ndarray:
    step1 = _cut_wrap_x(packed, o, w, closed=False)
    step2 = _cut_wrap_x(np.swapaxes(step1, 0, 1), o, w, closed=True)
    return np.ascontiguousarray(np.swapaxes(step2, 0, 1))


# -------------------------------------------------------------------------------------------- the blend method

def _vp_blend_x(a: np.ndarray) -> np.ndarray:
    h, wd = a.shape[:2]
    b = np.roll(a, wd // 2, axis=1)
    t = (np.arange(wd) + 0.5) / wd
    wt = (0.5 - 0.5 * np.cos(2 * np.pi * t))[None, :, None]  # 0 at the borders, 1 in the middle
    mu = a.mean(axis=(0, 1), keepdims=True)
    return mu + (wt * (a - mu) + (1 - wt) * (b - mu)) / np.sqrt(wt ** 2 + (1 - wt) ** 2)


def _blend(packed: np.ndarray) -> np.ndarray:
    out = _vp_blend_x(packed.astype(np.float64))
    out = np.swapaxes(_vp_blend_x(np.swapaxes(out, 0, 1)), 0, 1)
    return out.astype(np.float32)


# ------------------------------------------------------------------------------------------- the seam repair

def _guidance(out: np.ndarray, source: np.ndarray, inp: np.ndarray, axis: int) -> np.ndarray:
    """Forward differences along ``axis`` (1: to the next column, 0: to the row below; periodic) that the repaired
    maps should have: the cut result's own where the pair is natural (their sources are neighbours in the input),
    else one natural gradient of the input at the sources: the step from the first pixel's source to its own
    neighbour, or where that falls outside the input the step into the second pixel's source (0 where neither
    exists). Steps that touch the input's outer :data:`GUIDE_MARGIN` pixels are not used: a network's maps are
    least reliable at their borders (a last row unlike its neighbour asked a join for a 150x step). One sample, not an average of two: the join keeps the texture's own gradient energy."""
    h, w = inp.shape[:2]
    step = np.array((0, 1) if axis == 1 else (1, 0))
    nxt_src = np.roll(source, -1, axis=axis)
    natural = np.all(nxt_src - source == step, axis=-1)
    g = np.roll(out, -1, axis=axis) - out
    result = np.where(natural[..., None], g, np.float32(0))
    todo = ~natural
    for base, ahead in ((nxt_src - step, nxt_src), (source, source + step)):  # the second wins where both exist
        ok = todo & (base[..., 0] >= GUIDE_MARGIN) & (base[..., 1] >= GUIDE_MARGIN) \
            & (ahead[..., 0] < h - GUIDE_MARGIN) & (ahead[..., 1] < w - GUIDE_MARGIN)
        b, a = base[ok], ahead[ok]
        result[ok] = inp[a[:, 0], a[:, 1]] - inp[b[:, 0], b[:, 1]]
    return result


def _repair(out: np.ndarray, source: np.ndarray, inp: np.ndarray, o: int) -> np.ndarray:
    """Remove the steps across the cuts of ``out`` (H, W, C) with a periodic screened Poisson solve.

    Minimises ``sum |D_x u - G_x|^2 + |D_y u - G_y|^2 + eps |u - out|^2`` over the periodic image (forward
    differences ``D``, guidance ``G`` from :func:`_guidance`, ``eps = 1 / o^2``): every gradient of the cut result
    is kept except across the joins, where the input's own gradient is asked for, and the mismatch this frees is
    spread smoothly over about ``o`` pixels on both sides. Solved exactly with the FFT (the tile is periodic)."""
    u0 = out.astype(np.float32)
    inp = inp.astype(np.float32)
    gx = _guidance(u0, source, inp, 1)
    gy = _guidance(u0, source, inp, 0)
    return screened_poisson(u0, gx, gy, 1.0 / (REPAIR_SPREAD * float(o)) ** 2)


def screened_poisson(u0: np.ndarray, gx: np.ndarray, gy: np.ndarray, eps: float) -> np.ndarray:
    """The periodic image ``u`` (H, W, C) closest to the gradients ``gx, gy`` and, with weight ``eps``, to ``u0``:
    minimises ``sum |D_x u - gx|^2 + |D_y u - gy|^2 + eps |u - u0|^2`` (``D``: periodic forward differences, to
    the next column and to the row below). A step that the guidance does not ask for is spread smoothly over
    about ``1 / sqrt(eps)`` pixels. Solved exactly with the FFT. float32, the arrays' units."""
    h, w = u0.shape[:2]
    # D^T G at p: G(p - d) - G(p)
    rhs = eps * u0 + (np.roll(gx, 1, axis=1) - gx) + (np.roll(gy, 1, axis=0) - gy)
    wy = 2.0 - 2.0 * np.cos(2.0 * np.pi * np.fft.fftfreq(h))
    wx = 2.0 - 2.0 * np.cos(2.0 * np.pi * np.fft.rfftfreq(w))
    denom = (eps + wy[:, None] + wx[None, :])[..., None].astype(np.float32)
    spec = np.fft.rfft2(rhs.astype(np.float32), axes=(0, 1)) / denom
    return np.fft.irfft2(spec, s=(h, w), axes=(0, 1)).astype(np.float32)


# -------------------------------------------------------------------------------------------------- the API

def make_tileable(maps: Maps, method: str = "cut", overlap: Optional[int] = None, repair: bool = True,
                  return_source: bool = False):
    """A texture set of the same size whose maps repeat without a seam (see the module docstring).

    Args:
        maps: the texture set, (H, W) maps, all four or a subset; H and W >= :data:`MIN_SIZE`.
        method: ``"cut"`` (default) or ``"blend"`` (:data:`METHODS`).
        overlap: ``"cut"`` only: the overlap ``o`` in pixels (default :func:`default_overlap`); the copied strip
            is ``4 o`` wide and must fit, ``4 o <= min(H, W) / 2``.
        repair: ``"cut"`` only: remove the remaining steps across the cuts with the periodic screened Poisson
            solve (default; False: the raw cut, for comparison).
        return_source: also return the (H, W, 2) int map of the input pixel (row, column) each output pixel
            comes from (``"cut"``; for :func:`cut_scores`).

    Returns:
        :class:`Maps` with the same maps, size, ``render_config`` and meta, plus ``meta["tileable"]``:
        ``{"method", "overlap", "repair", "seam": {map: {"before": seam_scores, "after": seam_scores}},
        "join": {map: {"before": join score of the untiled map (its wrap), "after": join score of the result}}
        ("cut"; :func:`cut_scores`' ratio), "histogram_w1": {map: histogram_distance(before, after)}}``. Diffuse, specular and roughness stay in
        their ranges; normals stay unit length. With ``return_source``: ``(maps, source)``.

    Raises:
        SvbrdfError: unknown method, maps too small, or an overlap that does not fit.
    """
    if method not in METHODS:
        raise SvbrdfError(f"unknown tiling method {method!r}; expected one of {', '.join(METHODS)}")
    h, wd = maps.shape
    if min(h, wd) < MIN_SIZE:
        raise SvbrdfError(f"maps of {wd}x{h} px are too small to make tileable (at least {MIN_SIZE} px a side)")
    names = maps.names
    arrays = [getattr(maps, n) for n in names]
    groups, start = [], 0
    for arr in arrays:
        groups.append(slice(start, start + arr.shape[-1]))
        start += arr.shape[-1]
    identity = np.stack(np.mgrid[0:h, 0:wd], axis=-1)  # each pixel's own (row, column)
    coords = identity.astype(np.float32)  # exact up to 2^24 px
    packed = np.concatenate([a.astype(np.float32) for a in arrays] + [coords], axis=-1)
    o = None
    if method == "cut":
        o = default_overlap(h, wd) if overlap is None else int(overlap)
        if o < 1 or 8 * o > min(h, wd):
            raise SvbrdfError(f"overlap {o} px does not fit {wd}x{h} maps (need 1 <= 8 x overlap <= "
                              f"{min(h, wd)})")
        w = np.concatenate([map_weights(packed[..., :start], groups), np.zeros(2)])
        out = _cut(packed, o, w)
        source = np.rint(out[..., start:]).astype(np.int64)
        if repair:
            out[..., :start] = _repair(out[..., :start], source, packed[..., :start], o)
    else:
        out = _blend(packed[..., :start])
        source = identity
    del packed
    tiled = maps._with({name: out[..., sl].astype(np.float32) for name, sl in zip(names, groups)}).clipped()
    record = {"method": method, "overlap": o, "repair": bool(repair and method == "cut"), "seam": {},
              "histogram_w1": {}}
    if method == "cut":
        record["join"] = {}
    for name in names:
        before, after = getattr(maps, name), getattr(tiled, name)
        record["seam"][name] = {"before": seam_scores(before), "after": seam_scores(after)}
        record["histogram_w1"][name] = histogram_distance(before, after)
        if method == "cut":
            record["join"][name] = {"before": cut_scores(before, identity)["ratio"],
                                    "after": cut_scores(after, source)["ratio"]}
    tiled.meta["tileable"] = record
    if return_source:
        return tiled, source
    return tiled


def tile_grid(image: np.ndarray, reps: Tuple[int, int] = (2, 2)) -> np.ndarray:
    """``image`` (H, W, C) repeated ``reps`` (rows, columns) times: how a tiled set looks on a larger surface."""
    return np.tile(image, (reps[0], reps[1], 1))
