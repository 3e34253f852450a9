"""Relief maps from a normal map: a height field (least-squares integration) and ambient occlusion (pure numpy).

Two maps artists expect next to the SVBRDF, computed from the normal map alone, so they work for any
normal map (the network's, a refined one, an imported one):

* :func:`height_from_normals`: the height field whose slopes are the normal map's, by a least-squares Poisson
  solve (periodic by FFT for tileable maps; otherwise Neumann boundaries by a DCT, nothing wraps), without the
  relief broader than the map that the normals barely show (a tilt, the dome of the flash's faint radial tilt:
  :data:`LOW_CUT`, :data:`BROAD_SHARE`);
  :func:`normalise` turns it into the written map (white = high, mid-grey = the mean level) and its scale.
* :func:`ambient_occlusion`: horizon-based, cosine-weighted ambient occlusion of that height field
  (1 = open), on a pyramid so that the cost stays bounded at 4K.
* :func:`slope_correlation`: how well a height's slopes agree with a normal map's, for tests, benchmarks and
  sidecars.

Conventions (docs/conventions.md, section 2): normals are unit vectors in the OpenGL frame: +x to the right of
the image, **+y up the image** (towards row 0), +z out of the surface. A surface ``z = h(x, y)`` has the normal
``(-dh/dx, -dh/dy, 1) / norm``, so the normal map's slopes are

    ``p = -nx / nz`` (rise per run to the right),    ``q = -ny / nz`` (rise per run up the image).

Units. Slopes are dimensionless (rise over run), and a pixel step is the run: integrating them over pixel steps
gives a height **in pixels** (``h_px[i, j + 1] - h_px[i, j] ~ p``, ``h_px[i - 1, j] - h_px[i, j] ~ q``).
The API's height is in **units of the map's width**: ``height = h_px / W`` (a height of 1 is as tall as the
map is wide), so the same material at another resolution gets the same heights. ``scale`` (see
:func:`normalise`) is in the same units. Height is linear data (no colour space); float32 everywhere.

Memory stays within a few (H, W) float32 arrays: large maps are processed in strips, blocks and slices, on
:data:`THREADS` threads; the values do not depend on the strip, slice or thread count.

Decisions: docs/decisions/001-relief-low-cut.md (the broad relief), docs/decisions/002-ao-strength.md (the AO's
depth), docs/decisions/003-relief-memory.md (strips and threads).

Everything here imports numpy and the project's error type only.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import Any, Callable, Dict, Optional, Tuple

import numpy as np

from ..errors import SvbrdfError
from .filters import all_finite
from .stats import pearson

__all__ = ["MAX_SLOPE", "MIN_NORMAL_LENGTH", "LOW_CUT", "LOW_ORDER", "BROAD_SHARE", "BROAD_FLOOR", "AO_RADIUS",
           "AO_DIRECTIONS", "AO_MAX_SIZE", "height_from_normals", "normalise", "denormalise", "ambient_occlusion",
           "slope_correlation", "normal_slopes", "clamped_slopes", "SLOPE_MIN_NZ", "RELIEF_NAMES", "Relief",
           "relief_maps", "with_relief", "AO_STRENGTH"]

#: Steepest slope a normal is integrated with (rise over run; 10 = a tilt of 84.3 deg); steeper normals, and
#: normals with z <= 0, are clamped to this tilt in their own azimuth.
MAX_SLOPE = 10.0
#: A normal shorter than this (before renormalising) is "zero-length": an error, or flat with ``zero="flat"``.
MIN_NORMAL_LENGTH = 1e-3
#: Smallest ``n_z`` :func:`clamped_slopes` divides by (slopes up to 20 for a unit normal).
SLOPE_MIN_NZ = 0.05
#: Default AO search radius, in units of the map's width (1/16: 16 px at 256 px, 256 px at 4096 px).
AO_RADIUS = 1.0 / 16.0
#: Direction counts :func:`ambient_occlusion` supports (the 4 axis directions, or those and the 4 diagonals).
AO_DIRECTIONS = (4, 8)
#: The AO is computed on a grid of at most this many pixels a side (the pyramid level that fits), then upsampled.
AO_MAX_SIZE = 2048
#: Cut-off of the height's high-pass, in cycles across the map (:func:`height_from_normals`). Weight ``rho^6 /
#: (rho^6 + 1.5^6)`` of a component of ``rho`` cycles: 0.08 at 1, 0.85 at 2, 0.985 at 3.
#: Decision: docs/decisions/001-relief-low-cut.md.
LOW_CUT = 1.5
#: Order of that high-pass: the weight is ``rho^(2 LOW_ORDER) / (rho^(2 LOW_ORDER) + LOW_CUT^(2 LOW_ORDER))``.
LOW_ORDER = 3
#: ``(lo, hi)``: the broad relief is taken out in full while its slope energy is at most ``lo`` of the height's plus
#: the floor's (:data:`BROAD_FLOOR`), kept from ``hi``, in proportion between (:func:`height_from_normals`).
#: Decision: docs/decisions/001-relief-low-cut.md.
BROAD_SHARE = (0.02, 0.05)
#: The floor: the energy of an RMS slope of 0.02 (1.1 deg) over the map is added to the height's (a map holding
#: little but a faint broad tilt stays flat).
BROAD_FLOOR = 0.02
#: Rows processed at a time by the per-pixel loops (keeps the temporaries in cache; any value gives the same result).
_STRIP = 32
#: Threads of the relief's large passes: the height's DCTs (each thread a slice of rows or columns), the slopes and
#: the AO levels (each thread a run of row strips); the same values with any count.
THREADS = 2
#: Pixels from which those passes are split over :data:`THREADS` (smaller maps: one thread, no start-up cost).
_THREAD_PIXELS = 1 << 21
#: Lines of the other axis a DCT pass transforms at a time (:func:`_sliced`; the same values with any count).
_SLICE_LINES = 1024
#: Rows processed at a time in the finest AO level (keeps the temporaries in cache; any value gives the same AO).
_AO_STRIP = 16


# ------------------------------------------------------------------------------------------------- checks

def _check_normal(normal, zero: str) -> np.ndarray:
    """Validated (H, W, 3) float32 normals (not renormalised: slopes do not depend on the length); raises
    SvbrdfError with one line. Zero-length normals are checked by :func:`normal_slopes`."""
    if zero not in ("error", "flat", "unit"):
        raise SvbrdfError(f"zero={zero!r}: expected 'error', 'flat' or 'unit'")
    arr = np.asarray(normal)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise SvbrdfError(f"normal map: expected an (H, W, 3) array of unit normals, got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating):
        raise SvbrdfError(f"normal map: expected decoded float normals in [-1, 1], got dtype {arr.dtype} "
                          "(decode stored values v with n = 2 v - 1)")
    arr = arr.astype(np.float32, copy=False)
    if not all_finite(arr):
        bad = ~np.isfinite(arr).all(axis=-1)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise SvbrdfError(f"normal map: {int(bad.sum())} pixel(s) are NaN or infinite (first at row {i}, "
                              f"column {j})")
    big = max(float(arr.max()), -float(arr.min()))
    if big > 2.0 and zero != "unit":
        raise SvbrdfError(f"normal map: components up to {big:.3g} in magnitude; expected decoded unit normals "
                          "in [-1, 1]")
    return arr


def _check_height(height, name: str = "height") -> np.ndarray:
    arr = np.asarray(height)
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[..., 0]
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise SvbrdfError(f"{name}: expected an (H, W) array, got shape {np.shape(height)}")
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise SvbrdfError(f"{name}: expected a real array, got dtype {arr.dtype}")
    arr = arr.astype(np.float32, copy=False)
    if not all_finite(arr):
        bad = ~np.isfinite(arr)
        i, j = np.argwhere(bad)[0]
        raise SvbrdfError(f"{name}: {int(bad.sum())} pixel(s) are NaN or infinite (first at row {i}, column {j})")
    return arr


def _check_scale(scale) -> float:
    try:
        s = float(scale)
    except (TypeError, ValueError):
        raise SvbrdfError(f"height scale: expected a number, got {scale!r}") from None
    if not np.isfinite(s) or s < 0:
        raise SvbrdfError(f"height scale: expected a finite number >= 0, got {s}")
    return s


def _low_cut(value) -> float:
    """``low_cut`` as a float >= 0 and finite (cycles across the map); SvbrdfError otherwise."""
    try:
        cut = float(value)
    except (TypeError, ValueError):
        raise SvbrdfError(f"low_cut: expected a number, got {value!r}") from None
    if not (np.isfinite(cut) and cut >= 0):
        raise SvbrdfError(f"low_cut: expected a number >= 0 (cycles across the map), got {cut}")
    return cut


def _positive(value, name: str, unit: str = "") -> float:
    """``value`` as a float > 0 and finite; SvbrdfError naming ``name`` (and the ``unit`` expected) otherwise."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise SvbrdfError(f"{name}: expected a number, got {value!r}") from None
    if not (np.isfinite(number) and number > 0):
        raise SvbrdfError(f"{name}: expected a number > 0{unit}, got {number}")
    return number


# ------------------------------------------------------------------------------------------------- slopes

def normal_slopes(normal, *, max_slope: float = MAX_SLOPE, zero: str = "error") -> Tuple[np.ndarray, np.ndarray]:
    """The normal map's slopes ``p = -nx / nz`` (to the right) and ``q = -ny / nz`` (up the image).

    Args:
        normal: (H, W, 3) float normals, OpenGL frame. Their length does not matter (the slopes are ratios).
        max_slope: the largest slope magnitude ``sqrt(p^2 + q^2)``; steeper normals (and z <= 0) are clamped to
            it, keeping their azimuth: ``(p, q) = -(nx, ny) / max(nz, |(nx, ny)| / max_slope)``.
        zero: what a degenerate normal gets (zero-length, or one whose x, y and z are all below
            :data:`MIN_NORMAL_LENGTH`, e.g. pointing straight into the surface): ``"error"`` (SvbrdfError) or
            ``"flat"`` (the documented repair: slope 0, as (0, 0, 1)); ``"unit"``: the normals as the writers store
            them, each strip made unit first by :func:`~svbrdf.runtime.core.maps.normalize_normals` (z clamped
            at 0, a zero vector made (0, 0, 1), any length accepted): the slopes of the written normal map, to the
            bit, without a normalised copy of the whole map.

    Returns:
        ``(p, q)``: two (H, W) float32 arrays, dimensionless (rise over run, run = one pixel step).

    Raises:
        SvbrdfError: as :func:`height_from_normals` (shape, dtype, NaN/inf, degenerate normals with ``"error"``,
            ``zero``, ``max_slope``).
    """
    n = _check_normal(normal, zero)
    inv_max = _inverse_max_slope(max_slope)
    h, w = n.shape[:2]
    p = np.empty((h, w), np.float32)
    q = np.empty((h, w), np.float32)
    counts = _strips(lambda r0, r1: _slope_rows(n, r0, r1, zero, inv_max, p[r0:r1], q[r0:r1]), h, _STRIP, h * w)
    _raise_degenerate(counts, zero)
    return p, q


def clamped_slopes(normal: Any, axis: int = -1) -> Any:
    """The slopes ``-(n_x, n_y) / max(n_z, SLOPE_MIN_NZ)`` of normals, numpy or torch (the benchmark's
    ``normal_slope_corr`` and the trainer's slope loss; the relief's integration uses :func:`normal_slopes`, which
    clamps the slope's magnitude instead).

    Args:
        normal: array or tensor whose axis ``axis`` holds (x, y, z) (e.g. (H, W, 3) with -1, (B, 3, H, W) with 1).

    Returns:
        the same kind and dtype, with 2 entries (x, y slope) along ``axis``.
    """
    from .render import _clamp_min  # (render imports maps, which imports this module)

    lead = (Ellipsis,) if axis < 0 else (slice(None),) * axis
    tail = (slice(None),) * (-axis - 1) if axis < 0 else ()
    xy, z = normal[lead + (slice(0, 2),) + tail], normal[lead + (slice(2, 3),) + tail]
    return -xy / _clamp_min(z, SLOPE_MIN_NZ)


def _inverse_max_slope(max_slope) -> np.float32:
    """``1 / max_slope`` as the slope clamp uses it (``max_slope`` checked > 0)."""
    return np.float32(1.0 / _positive(max_slope, "max_slope"))


def _slope_rows(n: np.ndarray, r0: int, r1: int, zero: str, inv_max: np.float32, p: np.ndarray,
                q: np.ndarray) -> Tuple[int, Optional[Tuple[int, int]]]:
    """The slopes of :func:`normal_slopes` of the rows ``r0:r1`` of ``n`` written into ``p`` and ``q`` ((r1 - r0, W)
    float32 each); returns ``(degenerate count, (row, column) of the first or None)``."""
    degenerate, first = 0, None
    if zero == "unit":
        from .maps import normalize_normals  # (maps imports this module)

        strip = normalize_normals(n[r0:r1])
    else:
        strip = n[r0:r1]
    nx, ny, nz = strip[..., 0], strip[..., 1], strip[..., 2]
    d = nx * nx
    d += ny * ny
    np.sqrt(d, out=d)
    tilt = d  # |n_xy|, kept below for the degenerate check
    d = tilt * inv_max
    np.maximum(d, nz, out=d)  # >= |n_xy| / max_slope: the slope's magnitude is at most max_slope
    small = d < np.float32(MIN_NORMAL_LENGTH)
    if small.any():
        bad = small & (tilt < np.float32(MIN_NORMAL_LENGTH)) & (nz < np.float32(MIN_NORMAL_LENGTH))
        if bad.any():
            degenerate += int(bad.sum())
            i, j = np.argwhere(bad)[0]
            first = (r0 + int(i), int(j))
        # below MIN_NORMAL_LENGTH but not degenerate: tiny, well-defined normals; keep d > 0
        d[small] = np.where(bad[small], np.float32(1.0), np.maximum(d[small], np.float32(1e-30)))
    np.reciprocal(d, out=d)
    d *= np.float32(-1.0)
    np.multiply(nx, d, out=p)
    np.multiply(ny, d, out=q)
    if degenerate:
        p[bad] = 0.0
        q[bad] = 0.0
    return degenerate, first


def _raise_degenerate(counts: list, zero: str) -> None:
    """The one-line error of :func:`normal_slopes` for degenerate normals (``counts``: :func:`_slope_rows`' results)."""
    found = [f for _, f in counts if f is not None]
    degenerate, first = sum(c for c, _ in counts), (found[0] if found else None)
    if degenerate and zero == "error":
        raise SvbrdfError(f"normal map: {degenerate} zero-length normal(s) (first at row {first[0]}, column "
                          f"{first[1]}); pass zero='flat' to treat them as flat")


def _pair_slopes(p: np.ndarray, q: np.ndarray, tileable: bool) -> Tuple[np.ndarray, np.ndarray]:
    """Slopes asked of each pixel pair, in pixel units: ``gx[i, j]`` for ``h[i, j + 1] - h[i, j]`` and
    ``gy[i, j]`` for ``h[i + 1, j] - h[i, j]`` (down the image), the mean of the two pixels' slopes (exact for
    a slope that varies linearly). Tileable: every pair including the wrap's (shape (H, W)); otherwise the
    interior pairs only (shapes (H, W - 1) and (H - 1, W))."""
    if tileable:
        gx = 0.5 * (p + np.roll(p, -1, axis=1))
        gy = -0.5 * (q + np.roll(q, -1, axis=0))
    else:
        gx = 0.5 * (p[:, 1:] + p[:, :-1])
        gy = -0.5 * (q[1:, :] + q[:-1, :])
    return gx.astype(np.float32, copy=False), gy.astype(np.float32, copy=False)


# ------------------------------------------------------------------------------------- DCT-II by real FFT

def _along(axis: int, index) -> tuple:
    """An index tuple selecting ``index`` along ``axis`` (0 or 1) of a 2-D array."""
    return (index, slice(None)) if axis == 0 else (slice(None), index)


def _twiddle(n: int, half: int, axis: int, sign: float) -> np.ndarray:
    tw = np.exp(sign * 0.5j * np.pi * np.arange(half) / n).astype(np.complex64)
    return tw[:, None] if axis == 0 else tw[None, :]


def _dct2(x: np.ndarray, axis: int, out: Optional[np.ndarray] = None) -> np.ndarray:
    """Unnormalised DCT-II of a 2-D float32 array along ``axis`` (0 or 1):
    ``X[k] = sum_n x[n] cos(pi k (2 n + 1) / (2 N))``, by one real FFT of length N of the even samples followed
    by the odd ones reversed (Makhoul 1980): ``X[k] = Re(exp(-i pi k / 2N) V[k])``, ``X[N - k] = -Im(...)``.
    Everything stays in the array's own layout (no transposes)."""
    n = x.shape[axis]
    c, half = (n + 1) // 2, n // 2 + 1
    v = np.empty(x.shape, np.float32)
    v[_along(axis, slice(0, c))] = x[_along(axis, slice(0, None, 2))]
    v[_along(axis, slice(c, None))] = x[_along(axis, slice(1, None, 2))][_along(axis, slice(None, None, -1))]
    w = np.fft.rfft(v, axis=axis, norm="forward")  # scaled 1/n, undone below (003-relief-memory.md)
    del v
    w *= _twiddle(n, half, axis, -1.0) * np.float32(n)
    out = np.empty(x.shape, np.float32) if out is None else out
    out[_along(axis, slice(0, half))] = w.real
    m = (n - 1) // 2  # X[n - k] = -Im(w[k]) for k = 1..m
    if m:
        tail = out[_along(axis, slice(n - m, None))]
        tail[...] = w.imag[_along(axis, slice(m, 0, -1))]
        tail *= np.float32(-1.0)  # not np.negative(out=): wrong on this strided view (003-relief-memory.md)
    return out


def _strips(work: Callable[[int, int], object], h: int, strip: int, pixels: int) -> list:
    """``[work(r0, r1) for each strip of `strip` rows of h]``, in order; for ``pixels`` >= ``_THREAD_PIXELS``
    the strips are cut into :data:`THREADS` runs done on threads (each strip's work is its own, so the result is the
    same)."""
    starts = list(range(0, h, strip))
    if THREADS < 2 or pixels < _THREAD_PIXELS or len(starts) < THREADS:
        return [work(r0, min(h, r0 + strip)) for r0 in starts]
    cuts = [len(starts) * i // THREADS for i in range(THREADS + 1)]

    def run(i: int) -> list:
        return [work(r0, min(h, r0 + strip)) for r0 in starts[cuts[i]:cuts[i + 1]]]

    with ThreadPoolExecutor(THREADS) as pool:
        return [r for part in pool.map(run, range(THREADS)) for r in part]


def _sliced(fn: Callable[[np.ndarray, int], np.ndarray], x: np.ndarray, axis: int) -> np.ndarray:
    """``fn(x, axis)`` of a transform along ``axis`` (:func:`_dct2`, :func:`_idct2`) for a large ``x``: in slices
    of at most :data:`_SLICE_LINES` lines of the other axis, each transformed into its part of the output (the
    transform treats its lines independently, so the values are the same; its temporaries stay those of a slice),
    on :data:`THREADS` threads. numpy leaves the GIL in its FFT."""
    other = 1 - axis
    n = x.shape[other]
    if x.size < _THREAD_PIXELS or n < 2:
        return fn(x, axis)
    out = np.empty(x.shape, np.float32)
    count = max(THREADS, -(-n // _SLICE_LINES))
    part = [_along(other, slice(n * i // count, n * (i + 1) // count)) for i in range(count)]
    if THREADS < 2:
        for p in part:
            fn(x[p], axis, out=out[p])
        return out
    with ThreadPoolExecutor(THREADS) as pool:
        list(pool.map(lambda p: fn(x[p], axis, out=out[p]), part))
    return out


def _idct2(X: np.ndarray, axis: int, out: Optional[np.ndarray] = None) -> np.ndarray:
    """The inverse of :func:`_dct2` along ``axis``: ``w[k] = X[k] - i X[N - k]`` (``X[N] = 0``) times
    ``exp(i pi k / 2N)``, an inverse real FFT, and the samples put back in order. float32."""
    n = X.shape[axis]
    c, half = (n + 1) // 2, n // 2 + 1
    shape = (half, X.shape[1]) if axis == 0 else (X.shape[0], half)
    w = np.empty(shape, np.complex64)
    w.real = X[_along(axis, slice(0, half))]
    w.imag[_along(axis, slice(0, 1))] = 0.0
    if half > 1:
        tail = w.imag[_along(axis, slice(1, None))]
        tail[...] = X[_along(axis, slice(n - 1, n - half, -1))]
        tail *= np.float32(-1.0)
    w *= _twiddle(n, half, axis, 1.0)
    v = np.fft.irfft(w, n=n, axis=axis)
    del w
    out = np.empty(X.shape, np.float32) if out is None else out
    out[_along(axis, slice(0, None, 2))] = v[_along(axis, slice(0, c))]
    out[_along(axis, slice(1, None, 2))] = v[_along(axis, slice(c, None))][_along(axis, slice(None, None, -1))]
    return out


# ------------------------------------------------------------------------------------------------- height

def _laplacian_eigen(n: int, periodic: bool, rfft: bool = False) -> np.ndarray:
    """Eigenvalues of the 1-D graph Laplacian ``D^T D`` of n pixels: periodic (FFT order) or Neumann (DCT)."""
    if periodic:
        f = np.fft.rfftfreq(n) if rfft else np.fft.fftfreq(n)
        return (2.0 - 2.0 * np.cos(2.0 * np.pi * f)).astype(np.float32)
    return (2.0 - 2.0 * np.cos(np.pi * np.arange(n) / n)).astype(np.float32)


def _slope_divergence(n: np.ndarray, inv_max: np.float32, zero: str, tileable: bool) -> np.ndarray:
    """``D^T g`` of the pair slopes ``g`` (:func:`_pair_slopes`) of the normals ``n`` (checked (H, W, 3)), without
    forming them: at each pixel the pair arriving minus the pair leaving, ``(p[j-1] - p[j+1]) / 2 + (q[i+1] -
    q[i-1]) / 2``; with Neumann borders (not tileable) a missing pair counts 0, i.e. ``p[-1] = -p[0]``, ``p[W] =
    -p[W-1]`` (same for q). (H, W) float32. The slopes are made strip by strip (:func:`_slope_rows`, each strip with
    the q of the row above and below it): no (H, W) slope map is held. Raises
    :func:`normal_slopes`' error for degenerate normals."""
    h, w = n.shape[:2]
    rhs = np.empty((h, w), np.float32)

    def neighbour_q(i: int) -> np.ndarray:  # q of row i (-1 or h: across the border), (1, W)
        row = np.empty((1, w), np.float32)
        src = i % h if tileable else min(max(i, 0), h - 1)
        _slope_rows(n, src, src + 1, zero, inv_max, np.empty((1, w), np.float32), row)
        if not tileable and i in (-1, h):
            row *= np.float32(-1.0)
        return row

    def strip(r0: int, r1: int) -> Tuple[int, Optional[Tuple[int, int]]]:
        p = np.empty((r1 - r0, w), np.float32)
        q = np.empty((r1 - r0 + 2, w), np.float32)  # rows r0 - 1 .. r1
        found = _slope_rows(n, r0, r1, zero, inv_max, p, q[1:-1])
        out = rhs[r0:r1]
        if w > 1:
            np.subtract(p[:, :-2], p[:, 2:], out=out[:, 1:-1])
            if tileable:
                np.subtract(p[:, -1], p[:, 1], out=out[:, 0])
                np.subtract(p[:, -2], p[:, 0], out=out[:, -1])
            else:
                np.add(p[:, 0], p[:, 1], out=out[:, 0])
                out[:, 0] *= np.float32(-1.0)
                np.add(p[:, -2], p[:, -1], out=out[:, -1])
        else:
            out[:] = 0.0
        if h > 1:
            q[0] = neighbour_q(r0 - 1)
            q[-1] = neighbour_q(r1)
            out += q[2:]
            out -= q[:-2]
        out *= np.float32(0.5)
        return found

    _raise_degenerate(_strips(strip, h, _STRIP, h * w), zero)
    return rhs


def _divide_by_eigenvalues(spec: np.ndarray, ly: np.ndarray, lx: np.ndarray, factor: float = 1.0,
                           cuts: Optional[Tuple[np.ndarray, np.ndarray]] = None, taken: float = 0.0) -> None:
    """``spec[i, j] /= (ly[i] + lx[j]) * factor`` in place, in row blocks (no (H, W) temporary); the constant
    term (the mean level, eigenvalue 0) is set to 0. With ``cuts`` (:func:`_cut_axes`) each term is also weighted by
    ``1 - taken * s`` (``s`` its low-pass share, :func:`_low_share`): the high-pass of :func:`height_from_normals`."""
    ly = (ly * factor).astype(spec.real.dtype)
    lx = (lx * factor).astype(spec.real.dtype)
    for r0 in range(0, spec.shape[0], 256):
        r1 = min(spec.shape[0], r0 + 256)
        lam = ly[r0:r1, None] + lx[None, :]
        if r0 == 0:
            lam[0, 0] = 1.0
        if cuts is not None and taken > 0:  # lam / (1 - taken s)
            share = _low_share(cuts, r0, r1)
            share *= spec.real.dtype.type(-taken)
            share += spec.real.dtype.type(1.0)
            if r0 == 0:
                share[0, 0] = 1.0
            lam /= share
        spec[r0:r1] /= lam
    spec[0, 0] = 0.0


def _cut_axes(cy: np.ndarray, cx: np.ndarray, low_cut: float) -> Tuple[np.ndarray, np.ndarray]:
    """``(cy / low_cut)^2`` and ``(cx / low_cut)^2`` (float32): the terms' cycles across the map's height and width,
    relative to the cut-off, for :func:`_low_share`."""
    return np.square(cy / low_cut).astype(np.float32), np.square(cx / low_cut).astype(np.float32)


def _low_share(cuts: Tuple[np.ndarray, np.ndarray], r0: int, r1: int) -> np.ndarray:
    """The low-pass share ``1 / (1 + (rho / low_cut)^(2 m))`` (``m`` = :data:`LOW_ORDER`) of the terms of rows
    ``r0:r1``, (r1 - r0, W) float32; 1 at the constant term."""
    share = cuts[0][r0:r1, None] + cuts[1][None, :]
    with np.errstate(over="ignore"):  # (a tiny low_cut: inf, whose inverse 0 is the limit)
        share **= LOW_ORDER
    share += np.float32(1.0)
    np.reciprocal(share, out=share)
    return share


def _broad_energy(spec: np.ndarray, ly: np.ndarray, lx: np.ndarray, cuts: Tuple[np.ndarray, np.ndarray],
                  wy: np.ndarray, wx: np.ndarray) -> Tuple[float, float]:
    """Slope energies ``h^T L h`` of the solution of ``spec`` (a transformed right-hand side, before
    :func:`_divide_by_eigenvalues`) and of its low-pass part: ``sum w |spec|^2 / lam`` and ``sum w s^2 |spec|^2 /
    lam`` over the non-constant terms (``s`` :func:`_low_share`, ``w = wy[i] wx[j]`` the terms' inverse basis
    norms), float64 sums over row blocks."""
    total = low = 0.0
    for r0 in range(0, spec.shape[0], 256):
        r1 = min(spec.shape[0], r0 + 256)
        lam = ly[r0:r1, None] + lx[None, :]
        if r0 == 0:
            lam[0, 0] = np.inf
        part = np.square(np.abs(spec[r0:r1])) if np.iscomplexobj(spec) else np.square(spec[r0:r1])
        part /= lam
        part *= wy[r0:r1, None].astype(np.float32)
        part *= wx[None, :].astype(np.float32)
        total += float(part.sum(dtype=np.float64))
        part *= np.square(_low_share(cuts, r0, r1))
        low += float(part.sum(dtype=np.float64))
    return total, low


def _taken(broad: float, total: float, pixels: int) -> float:
    """The share of the broad relief taken out (:data:`BROAD_SHARE`): 1 while its slope energy ``broad`` is at most
    ``BROAD_SHARE[0]`` of ``total + pixels BROAD_FLOOR^2``, 0 from ``BROAD_SHARE[1]``, linear between."""
    den = total + pixels * BROAD_FLOOR ** 2
    ratio = broad / den if den > 0 else 0.0
    lo, hi = BROAD_SHARE
    return float(min(1.0, max(0.0, (hi - ratio) / (hi - lo))))


def _neumann_laplacian_1d(u: np.ndarray) -> np.ndarray:
    """``D^T D u`` of a 1-D vector on a path graph (Neumann ends): ``2 u[k] - u[k - 1] - u[k + 1]``, ``u[0] -
    u[1]`` and ``u[n - 1] - u[n - 2]`` at the ends (float64)."""
    out = np.zeros_like(u)
    if u.size > 1:
        d = np.diff(u)  # the pair differences D u
        out[:-1] -= d
        out[1:] += d
    return out


def _fit_quadratic(rhs: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """The quadratic height ``Q`` (``x, y, x^2, x y, y^2``, pixel units) whose pair slopes ``D Q`` fit ``g`` best in
    least squares, from ``rhs = D^T g`` (:func:`_slope_divergence`, not tileable): the normal equations need only
    ``sum f_k rhs`` (``= (D f_k) . g``) and the basis's own products. Each ``f_k = a_k(row) b_k(column)`` is
    separable, so ``Q = A B^T`` and ``L Q = sum_k c_k ((L a_k) b_k^T + a_k (L b_k)^T) = U V^T``.

    Returns:
        ``(A, B, U, V, energy)``: (H, K), (W, K), (H, 2K), (W, 2K) float64 factors (the coefficients folded into
        ``A`` and ``U``) and ``energy = |D Q|^2``, the fit's slope energy (pixel units)."""
    h, w = rhs.shape
    y = (np.arange(h) - (h - 1) / 2.0) / max(h, w)
    x = (np.arange(w) - (w - 1) / 2.0) / max(h, w)
    one_y, one_x = np.ones(h), np.ones(w)
    rows = np.stack([one_y, y, one_y, y, y * y], axis=1)  # a_k
    cols = np.stack([x, one_x, x * x, x, one_x], axis=1)  # b_k
    lrows = np.stack([_neumann_laplacian_1d(a) for a in rows.T], axis=1)
    lcols = np.stack([_neumann_laplacian_1d(b) for b in cols.T], axis=1)
    gram = (rows.T @ lrows) * (cols.T @ cols) + (rows.T @ rows) * (cols.T @ lcols)  # (D f_k) . (D f_l)
    proj = np.zeros(rows.shape[1])
    cols32 = cols.astype(np.float32)
    for r0 in range(0, h, 256):
        part = (rhs[r0:r0 + 256] @ cols32).astype(np.float64)  # (rows, K): each row's sum of rhs b_k
        proj += np.einsum("rk,rk->k", rows[r0:r0 + 256], part)
    coef = np.linalg.lstsq(gram, proj, rcond=1e-10)[0]
    return (rows * coef, cols, np.concatenate([lrows * coef, rows * coef], axis=1),
            np.concatenate([cols, lcols], axis=1), float(coef @ gram @ coef))


def _add_outer(arr: np.ndarray, u: np.ndarray, v: np.ndarray, scale: float) -> None:
    """``arr += scale * u v^T`` in place ((H, W) float32; u (H, K), v (W, K)), a block of rows at a time."""
    uu = (u * scale).astype(np.float32)
    vt = v.T.astype(np.float32)
    for r0 in range(0, arr.shape[0], 256):
        arr[r0:r0 + 256] += uu[r0:r0 + 256] @ vt


def height_from_normals(normal, *, tileable: bool = False, max_slope: float = MAX_SLOPE,
                        zero: str = "error", low_cut: Optional[float] = None) -> Tuple[np.ndarray, float]:
    """The height field of a material whose slopes are the normal map's: least squares, without what is broader
    than the map.

    Minimises ``sum over neighbour pairs (h[b] - h[a] - g_ab)^2``, where ``g_ab`` is the mean of the two
    pixels' slopes along the pair (``p = -nx / nz`` to the right, ``-q = ny / nz`` down the image, pixel units;
    see the module docstring). The normal equations are a Poisson equation ``L h = D^T g`` with ``L`` the
    grid's graph Laplacian, solved exactly in its eigenbasis:

    * ``tileable=True``: every pair including the wrap's (column W - 1 to 0, row H - 1 to 0); periodic
      Laplacian, solved by a real FFT. A periodic height cannot tilt, so the map's mean slope is dropped (its
      non-zero mean, if any, is the only part of the slopes that cannot be matched).
    * ``tileable=False``: interior pairs only, nothing is asked across the border (Neumann boundaries);
      solved by a DCT-II (computed with real FFTs of the same size, no padding).

    Broad relief (``low_cut`` > 0, the default :data:`LOW_CUT`): a tilt, or the dome or bowl that a faint radial
    tilt of the normals integrates to. Not tileable, the quadratic height ``Q`` (``x, y, x^2, x y, y^2``) whose
    slopes fit ``g`` best is taken out first (``g - D Q`` is integrated: no tilt, bowl or dome, wherever its
    centre); then, either way, each eigen-component of ``rho`` cycles across the map (``rho^2 = cy^2 + cx^2``, cy
    across its height, cx across its width; DCT index k: k / 2 cycles, FFT index k: |k|) is weighted by
    ``rho^(2 m) / (rho^(2 m) + low_cut^(2 m))``, ``m`` = :data:`LOW_ORDER` (a high-pass in the same solve). Only
    broad relief the normals barely show is taken out: with ``E_b`` the slope energy (``|D h|^2``) of ``Q`` plus
    the low-passed rest, ``E`` that of the whole height and ``N`` the pixel count, the share ``t`` taken out is 1
    while ``E_b / (E + N BROAD_FLOOR^2) <= BROAD_SHARE[0]``, 0 from ``BROAD_SHARE[1]``, linear between (the
    height is ``(1 - t) Q + `` the rest weighted ``1 - t (1 - weight)``): a lone pit or a stone as large as the
    map keeps its shape. Decision: docs/decisions/001-relief-low-cut.md.

    ``low_cut=0``: the plain least-squares height (a mean slope kept when not tileable); the slopes' curl-free
    part is matched exactly, their curl (which no height has) is what remains.

    Cost: the input plus two (H, W) float32 arrays at the peak (the right-hand side, made from the normals strip
    by strip, and one transform pass's output; the quadratic's fit and the weights go in row blocks); four
    real-FFT passes over the map.

    Args:
        normal: (H, W, 3) float unit normals, OpenGL frame (+x right, +y up the image, +z out), components in
            [-1, 1] (any length > :data:`MIN_NORMAL_LENGTH`: the slopes are ratios). Decoded data, not the
            stored ``(n + 1) / 2`` values.
        tileable: integrate across the wrap (periodic) or not (see above).
        max_slope: steepest slope integrated (:data:`MAX_SLOPE`); steeper normals and z <= 0 are clamped.
        zero: degenerate (zero-length) normals: ``"error"`` (default), ``"flat"`` (documented repair:
            treated as (0, 0, 1)) or ``"unit"`` (the normals as written, made unit first); see
            :func:`normal_slopes`.
        low_cut: the high-pass's cut-off in cycles across the map (>= 0; None: :data:`LOW_CUT`; 0: none).

    Returns:
        ``(height, scale)``: ``height`` (H, W) float32, linear data, **in units of the map's width**, mean 0
        (the mean level removed); ``scale`` = ``2 max |height|`` (float, >= 0, same units), the span of the
        written map (see :func:`normalise`). A flat normal map gives zeros and scale 0.

    Raises:
        SvbrdfError: wrong shape or dtype, NaN/inf, components above 2 in magnitude (but with ``zero="unit"``),
            zero-length normals (with ``zero="error"``), an unknown ``zero``, ``max_slope`` <= 0, a bad ``low_cut``.
    """
    height, _ = _integrate(normal, tileable, max_slope, zero, low_cut)
    return height, _scale_of(height)


def _integrate(normal, tileable: bool, max_slope: float, zero: str,
               low_cut: Optional[float]) -> Tuple[np.ndarray, float]:
    """:func:`height_from_normals`' height and the share of the broad relief taken out (in [0, 1]; 0 without
    ``low_cut``)."""
    n = _check_normal(normal, zero)
    low_cut = _low_cut(LOW_CUT if low_cut is None else low_cut)
    h, w = n.shape[:2]
    rhs = _slope_divergence(n, _inverse_max_slope(max_slope), zero, tileable)
    quad, taken = None, 0.0
    if low_cut > 0 and not tileable:
        quad = _fit_quadratic(rhs)
        _add_outer(rhs, quad[2], quad[3], -1.0)  # g - D Q integrated; Q added back below for what is kept
    if tileable:
        # both transforms scaled, 1 / (H W) each way (003-relief-memory.md); the eigenvalues divided by H W
        spec = np.fft.rfft2(rhs, norm="forward")
        del rhs
        ly, lx = _laplacian_eigen(h, True), _laplacian_eigen(w, True, rfft=True)
        cuts = _cut_axes(np.abs(np.fft.fftfreq(h) * h), np.fft.rfftfreq(w) * w, low_cut) if low_cut > 0 else None
        if cuts is not None:  # an rfft column stands for itself and its mirror, but the first and the Nyquist one
            wx = np.full(lx.shape, 2.0)
            wx[0] = 1.0
            if w % 2 == 0:
                wx[-1] = 1.0
            total, low = _broad_energy(spec, ly, lx, cuts, np.ones(h), wx)  # of the spectrum scaled 1 / (H W)
            taken = _taken(low * (h * w), total * (h * w), h * w)
        _divide_by_eigenvalues(spec, ly, lx, 1.0 / (h * w), cuts, taken)
        hpx = np.fft.irfft2(spec, s=(h, w)).astype(np.float32, copy=False)
    else:
        spec = _sliced(_dct2, rhs, 1)
        del rhs  # each pass's input freed as soon as it is transformed (003-relief-memory.md)
        spec = _sliced(_dct2, spec, 0)
        ly, lx = _laplacian_eigen(h, False), _laplacian_eigen(w, False)
        cuts = _cut_axes(np.arange(h) / 2.0, np.arange(w) / 2.0, low_cut) if low_cut > 0 else None
        if cuts is not None:  # the DCT-II's basis norms: n / 2, n for the constant
            wy = np.where(np.arange(h) == 0, 1.0 / h, 2.0 / h)
            wx = np.where(np.arange(w) == 0, 1.0 / w, 2.0 / w)
            total, low = _broad_energy(spec, ly, lx, cuts, wy, wx)
            taken = _taken(quad[4] + low, quad[4] + total, h * w)
        _divide_by_eigenvalues(spec, ly, lx, 1.0, cuts, taken)
        spec = _sliced(_idct2, spec, 0)
        hpx = _sliced(_idct2, spec, 1)
        if quad is not None and taken < 1.0:
            _add_outer(hpx, quad[0], quad[1], 1.0 - taken)
    del spec
    hpx -= np.float32(hpx.mean(dtype=np.float64))  # exact 0 mean after float32 rounding
    return hpx / np.float32(w), taken


def _scale_of(height: np.ndarray) -> float:
    """``2 max |height|`` (from the largest and the smallest value: no (H, W) temporary)."""
    return 2.0 * max(float(height.max()), -float(height.min())) if height.size else 0.0


def normalise(height) -> Tuple[np.ndarray, float]:
    """The height as the written map: ``h01 = 0.5 + (height - mean) / scale`` with ``scale = 2 max |height -
    mean|``, so white (1) = high, mid-grey (0.5) = the mean level, and the values fill [0, 1] on the side of the
    larger excursion.

    Args:
        height: (H, W) float height, linear data, in units of the map's width (:func:`height_from_normals`).

    Returns:
        ``(h01, scale)``: (H, W) float32 in [0, 1], linear data (write it as 16-bit or float, no sRGB curve);
        ``scale`` the height black-to-white spans, in units of the map's width (record it in the sidecar).
        A flat height gives all 0.5 and scale 0.
    """
    return _normalise(_check_height(height))


def _normalise(arr: np.ndarray, out: Optional[np.ndarray] = None) -> Tuple[np.ndarray, float]:
    """:func:`normalise` of a checked float32 height, into ``out`` when given (``out=arr``: in place, no second
    (H, W) array)."""
    centred = np.subtract(arr, np.float32(arr.mean(dtype=np.float64)), out=out)
    scale = _scale_of(centred)
    if scale <= 0.0:
        return np.full(arr.shape, 0.5, np.float32), 0.0
    centred /= np.float32(scale)  # in place, the operations of clip(0.5 + centred / scale, 0, 1) in float32
    centred += np.float32(0.5)
    np.clip(centred, 0.0, 1.0, out=centred)
    return centred.astype(np.float32, copy=False), scale


def denormalise(h01, scale: float) -> np.ndarray:
    """Inverse of :func:`normalise`: ``(h01 - 0.5) * scale``, (H, W) float32 in units of the map's width (mean
    level 0 when the map was written by :func:`normalise`)."""
    arr = _check_height(h01, "height map")
    return ((arr - np.float32(0.5)) * np.float32(_check_scale(scale))).astype(np.float32, copy=False)


# ------------------------------------------------------------------------------------- slope correlation

def slope_correlation(height, normal, *, tileable: bool = False, max_slope: float = MAX_SLOPE,
                      zero: str = "error") -> Dict[str, Optional[float]]:
    """Pearson correlation between a height's slopes and a normal map's, per component (OpenGL convention).

    The height's slope of each neighbour pair (``W (h[i, j + 1] - h[i, j])`` to the right, ``W (h[i, j] -
    h[i + 1, j])`` up the image, pixel units) against the mean of the normal map's slopes ``p = -nx / nz``,
    ``q = -ny / nz`` at the pair's two pixels.

    Args:
        height: (H, W) float height in units of the map's width (only its slopes matter: any scale > 0 or offset
            gives the same correlations).
        normal: (H, W, 3) float unit normals, OpenGL frame.
        tileable: include the wrap's pairs, and report them alone too.

    Returns:
        ``{"x": .., "y": ..}`` over all pairs (the wrap's included when tileable); with ``tileable`` also
        ``"wrap_x"`` (the H pairs column W - 1 -> 0) and ``"wrap_y"`` (the W pairs row H - 1 -> 0).
        ``None`` where a component has no pairs or no variation.

    Raises:
        SvbrdfError: bad arrays (see :func:`height_from_normals`) or sizes that differ.
    """
    hh = _check_height(height)
    p, q = normal_slopes(normal, max_slope=max_slope, zero=zero)
    if hh.shape != p.shape:
        raise SvbrdfError(f"height is {hh.shape[1]}x{hh.shape[0]} px but the normal map is "
                          f"{p.shape[1]}x{p.shape[0]} px")
    w = hh.shape[1]
    hpx = hh.astype(np.float64) * w
    gx, gy = _pair_slopes(p, q, tileable)
    if tileable:
        dx = np.roll(hpx, -1, axis=1) - hpx
        dy = np.roll(hpx, -1, axis=0) - hpx
    else:
        dx = hpx[:, 1:] - hpx[:, :-1]
        dy = hpx[1:, :] - hpx[:-1, :]
    out = {"x": pearson(dx, gx), "y": pearson(-dy, -gy)}
    if tileable:
        out["wrap_x"] = pearson(dx[:, -1], gx[:, -1])
        out["wrap_y"] = pearson(-dy[-1, :], -gy[-1, :])
    return out


# ------------------------------------------------------------------------------------ ambient occlusion

def _pad(a: np.ndarray, k: int, tileable: bool) -> np.ndarray:
    """Pad (H, W) by k on every side: periodically, or by odd reflection about the border pixel
    (``a[-m] = 2 a[0] - a[m]``, index clamped: a tilted plane continues as itself; a 1-px axis stays constant)."""
    if tileable:
        return np.pad(a, k, mode="wrap")
    out = a
    for axis in (0, 1):
        n = out.shape[axis]
        m = np.minimum(np.arange(1, k + 1), n - 1)
        first = np.take(out, [0], axis=axis)
        last = np.take(out, [n - 1], axis=axis)
        before = 2 * first - np.take(out, m[::-1], axis=axis)
        after = 2 * last - np.take(out, n - 1 - m, axis=axis)
        out = np.concatenate([before, out, after], axis=axis)
    return out.astype(np.float32, copy=False)


def _downsample(a: np.ndarray, tileable: bool) -> np.ndarray:
    """2 x 2 box average (an odd last row / column is paired with its wrap neighbour or with itself)."""
    if a.shape[0] % 2:
        a = np.concatenate([a, a[:1] if tileable else a[-1:]], axis=0)
    if a.shape[1] % 2:
        a = np.concatenate([a, a[:, :1] if tileable else a[:, -1:]], axis=1)
    return (0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2])).astype(np.float32)


def _upsample(a: np.ndarray, shape: Tuple[int, int], tileable: bool) -> np.ndarray:
    """2x bilinear upsampling (pixel centres at half-pixel offsets: ``out[2i] = 3/4 a[i] + 1/4 a[i-1]``,
    ``out[2i+1] = 3/4 a[i] + 1/4 a[i+1]``, the border continued by wrap or by edge), cropped to ``shape``.

    Along the columns, then the rows, in blocks of :data:`_UPSAMPLE_BLOCK` input rows (each with its neighbour rows):
    no column-upsampled copy of the whole map is held, the same values."""
    n0 = a.shape[0]
    out = np.empty((min(shape[0], 2 * n0), min(shape[1], 2 * a.shape[1])), np.float32)
    for i0 in range(0, n0, _UPSAMPLE_BLOCK):
        i1 = min(n0, i0 + _UPSAMPLE_BLOCK)
        rows = np.arange(i0 - 1, i1 + 1)  # the block and a neighbour row each side, continued by wrap or by edge
        rows = rows % n0 if tileable else np.clip(rows, 0, n0 - 1)
        cols = _upsample_axis(a[rows], 1, tileable)[:, : out.shape[1]]
        # along the rows as _upsample_axis, the neighbour rows standing in for its padding (no copy of the block)
        quarter = cols * np.float32(0.25)
        three = cols[1:-1] * np.float32(0.75)
        for parity, neighbour in ((0, quarter[:-2]), (1, quarter[2:])):
            dst = out[2 * i0 + parity: 2 * i1: 2]
            np.add(three[: len(dst)], neighbour[: len(dst)], out=dst)
    return out


#: Lines (of the other axis) :func:`_upsample_axis` treats at a time: its temporaries stay small (the same values).
_UPSAMPLE_BLOCK = 256


def _upsample_axis(a: np.ndarray, axis: int, tileable: bool) -> np.ndarray:
    n = a.shape[axis]
    pad = [(0, 0), (0, 0)]
    pad[axis] = (1, 1)
    shape = list(a.shape)
    shape[axis] = 2 * n
    out = np.empty(shape, np.float32)
    other = 1 - axis
    for b0 in range(0, a.shape[other], _UPSAMPLE_BLOCK):  # each block of lines on its own
        lines = _along(other, slice(b0, b0 + _UPSAMPLE_BLOCK))
        block, dst = a[lines], out[lines]
        quarter = np.pad(block, pad, mode="wrap" if tileable else "edge")
        quarter *= np.float32(0.25)
        three = block * np.float32(0.75)
        np.add(three, quarter[_along(axis, slice(0, n))], out=dst[_along(axis, slice(0, None, 2))])
        np.add(three, quarter[_along(axis, slice(2, None))], out=dst[_along(axis, slice(1, None, 2))])
    return out


#: The direction pairs (row step, column step): the 2 axes, then the 2 diagonals.
_PAIRS = ((0, 1), (1, 0), (1, 1), (1, -1))


def _slice_visibility(a: np.ndarray, b: np.ndarray, bb1: np.ndarray, acc: np.ndarray, sign: float) -> None:
    """``acc += cos^2(atan(a) - atan(s b))`` where ``a > s b`` (else ``acc += 1``; 0 past 90 deg), in place.

    ``a``: the horizon's elevation (tangent) in a direction, ``s b`` (``s`` = ``sign``, +-1) the tangent
    plane's, ``bb1 = 1 + b^2``. The cosine-weighted share of a half-slice of the hemisphere (about the local
    tangent) above a horizon raised by the angle t is ``cos^2 t``, and ``cos(atan a - atan b) = (1 + a b) /
    sqrt((1 + a^2)(1 + b^2))``. ``a`` is overwritten."""
    if sign > 0:
        np.maximum(a, b, out=a)
        num = a * b
        num += np.float32(1.0)
    else:
        np.maximum(a, -b, out=a)
        num = a * b
        np.subtract(np.float32(1.0), num, out=num)
    np.maximum(num, np.float32(0.0), out=num)  # a horizon more than 90 deg above the tangent hides it all
    num *= num
    a *= a
    a += np.float32(1.0)
    a *= bb1
    num /= a
    acc += num


def _level_ao(hs, rows: slice, width: int) -> np.ndarray:
    """Sum of the slice visibilities of the output rows ``rows`` of one pyramid level, over the directions.

    Args:
        hs: per direction pair ``(dy, dx, full, half)``: the level's heights padded by 2 px on every side,
            divided by the pair's step length (so that a height difference is an elevation tangent), and half
            that (for the samples 2 steps away).
        rows: output rows; width: output columns.
    """
    r0, r1 = rows.start, rows.stop
    acc = np.zeros((r1 - r0, width), np.float32)
    for dy, dx, full, half in hs:
        def at(arr: np.ndarray, m: int) -> np.ndarray:
            return arr[2 + r0 + m * dy: 2 + r1 + m * dy, 2 + m * dx: 2 + m * dx + width]

        centre, centre_half = at(full, 0), at(half, 0)
        tangent = at(half, 1) - at(half, -1)  # central difference: the tangent plane's slope along +d
        bb1 = tangent * tangent
        bb1 += np.float32(1.0)
        for m in (1, -1):
            horizon = at(full, m) - centre  # 1 step away
            far = at(half, 2 * m) - centre_half  # 2 steps away, per step
            np.maximum(horizon, far, out=horizon)
            _slice_visibility(horizon, tangent, bb1, acc, float(m))
    return acc


def _level_heights(arr: np.ndarray, unit: float, pairs, tileable: bool):
    padded = _pad(arr, 2, tileable)
    out = []
    for dy, dx in pairs:
        full = padded * np.float32(1.0 / (unit * np.hypot(dy, dx)))
        out.append((dy, dx, full, full * np.float32(0.5)))
    return out


def ambient_occlusion(height, scale: Optional[float] = None, *, tileable: bool = False, directions: int = 8,
                      radius: float = AO_RADIUS, max_size: int = AO_MAX_SIZE, strength: float = 1.0) -> np.ndarray:
    """Horizon-based ambient occlusion of a height field: (H, W) float32 in [0, 1], 1 = open.

    Model. In each of ``directions`` azimuths (the 4 axis directions, and with 8 the 4 diagonals too) the
    horizon is the steepest elevation ``atan((h(x + r d) - h(x)) / r)`` of the height field seen from the pixel
    at the sample distances r; it is measured from the local tangent plane in that azimuth (central
    differences), so a flat or uniformly tilted plane is unoccluded. A horizon raised by the angle t above the
    tangent hides ``1 - cos^2 t`` of the cosine-weighted (Lambert) half-slice of the hemisphere on that side
    (``cos^2 t`` of ``integral cos(z) sin(z) dz``); AO is the mean of ``cos^2 t`` over the directions (1 =
    nothing hides the sky; 0 = walls at 90 deg on every side). Inter-reflections are ignored.

    Distances on a pyramid (bounded cost): level l is the height averaged over 2^l x 2^l pixels; at each level
    the samples are 1 and 2 of its pixels away (2^l and 2^(l+1) px), for the levels whose samples stay within
    ``radius``; each level's AO is computed at its own resolution and bilinearly upsampled, and the pixel's AO
    is the **minimum over levels** (the most occluding scale; a max over all distances per direction would be
    at most this dark). The finest level computed is the first whose long side is at most ``max_size``
    (:data:`AO_MAX_SIZE` = 2048): a 4096 px map gets its AO from the 2048 px level, bilinearly upsampled, so
    relief narrower than ~2 px at 4K occludes only through its average. Cost: about 1.3 x the finest level's,
    ~110 float32 array operations per pixel with 8 directions, in row strips that stay in cache.

    Depth. ``ambient_occlusion(height, strength=k)`` is ``ambient_occlusion(k * height)`` (the same float32
    products) without a scaled copy held through the call. The written AO's default: :data:`AO_STRENGTH`.

    Args:
        height: (H, W) float height. Without ``scale``: in units of the map's width, as returned by
            :func:`height_from_normals`. With ``scale``: the written map in [0, 1] (:func:`normalise`), converted
            back with ``(h01 - 0.5) * scale``.
        scale: the written map's scale (units of the map's width), or None (see ``height``).
        tileable: the height wraps (samples across the border read the opposite side); otherwise the border is
            continued by odd reflection (a plane continues as a plane).
        directions: 4 or 8 (:data:`AO_DIRECTIONS`).
        radius: the farthest sample, in units of the map's width (:data:`AO_RADIUS` = 1/16); at least 2 px.
        max_size: the largest grid the AO is computed on (see above; >= 16).
        strength: the AO is that of ``strength x`` the height (see Depth).

    Returns:
        (H, W) float32 AO in [0, 1], linear data, 1 = open; exactly 1 on a flat (or planar) height.

    Raises:
        SvbrdfError: bad height (shape, dtype, NaN/inf), scale (< 0 or not finite), directions, radius or strength
            (<= 0 or not finite), or ``max_size`` < 16.
    """
    hh = _check_height(height, "height" if scale is None else "height map")
    if scale is not None:
        hh = denormalise(hh, scale)
    if directions not in AO_DIRECTIONS:
        raise SvbrdfError(f"directions={directions!r}: expected one of {', '.join(map(str, AO_DIRECTIONS))}")
    radius = _positive(radius, "radius", " (units of the map's width)")
    h, w = hh.shape
    if max_size < 16:
        raise SvbrdfError(f"max_size={max_size!r}: expected at least 16")
    pairs = _PAIRS[: directions // 2]
    radius_px = max(2.0, radius * w)
    strength = _positive(strength, "strength")
    if strength != 1.0:  # k * height, then in pixels: the products of ambient_occlusion(k * height)
        hpx = (hh * np.float32(strength)) * np.float32(w)
    else:
        hpx = (hh * np.float32(w)).astype(np.float32)  # heights in pixels, like the distances
    if not np.any(hpx != hpx.flat[0]):
        return np.ones((h, w), np.float32)
    # level l: heights averaged over 2^l x 2^l px; its samples are 2^l and 2^(l+1) px away. Levels finer than
    # max_size are skipped; the coarsest is the last whose farthest sample stays within the radius.
    levels = [hpx]
    while 2 ** (len(levels) + 1) <= radius_px and min(levels[-1].shape) >= 4 or max(levels[-1].shape) > max_size:
        levels.append(_downsample(levels[-1], tileable))
    first = 0
    while max(levels[first].shape) > max_size:
        first += 1
    shapes = [lv.shape for lv in levels]
    levels[:first] = [None] * first  # the levels finer than max_size only gave the coarser ones
    del hpx
    ao = None
    for lev in range(len(levels) - 1, first - 1, -1):
        arr = levels[lev]
        hs = _level_heights(arr, float(2 ** lev), pairs, tileable)
        cur = np.empty(arr.shape, np.float32)

        def strip_ao(r0: int, r1: int, cur=cur, hs=hs, width=arr.shape[1]) -> None:
            cur[r0:r1] = _level_ao(hs, slice(r0, r1), width)

        _strips(strip_ao, arr.shape[0], _AO_STRIP, arr.size)
        cur *= np.float32(1.0 / (2 * len(pairs)))
        del hs
        if ao is not None:
            np.minimum(cur, _upsample(ao, arr.shape, tileable), out=cur)
        ao = cur
    for lev in range(first - 1, -1, -1):  # back to full resolution (bilinear)
        ao = _upsample(ao, shapes[lev], tileable)
    np.clip(ao, 0.0, 1.0, out=ao)
    return ao


# ------------------------------------------------------------------------------------------ relief maps

#: Names of the relief maps, derived from the normal map on demand, in the order they are written.
RELIEF_NAMES: Tuple[str, ...] = ("height", "ao")
#: Default depth gain of the written AO: the AO is that of ``AO_STRENGTH x`` the height the normal map implies; the
#: height map and its ``height_scale`` stay those of the normal map. Decision: docs/decisions/002-ao-strength.md.
AO_STRENGTH = 8.0
#: The sidecar's ``ao.strength_reason`` when the AO's strength is :data:`AO_STRENGTH` (:meth:`Relief.info`).
AO_STRENGTH_REASON = ("the packaged model's normal maps are measured 0.12 x as steep as the ground truth (median RMS "
                      "slope, 20 synthetic Des18 test materials): the AO is that of the height x 8, the median true "
                      "depth; the height map and height_scale are the normal map's own")


@dataclass(frozen=True)
class Relief:
    """The relief maps of a texture set, derived from its normal map (:func:`relief_maps`).

    Attributes:
        height: (H, W) float32 in [0, 1], linear data: the written height map, white = high, 0.5 = the mean level
            (:func:`normalise`); ``None`` when not asked for. ``denormalise(height, scale)`` gives it back in units
            of the map's width.
        scale: the height black to white spans, in units of the map's width (0 for a flat normal map).
        ao: (H, W) float32 in [0, 1], linear data, 1 = open (:func:`ambient_occlusion` with its defaults);
            ``None`` when not asked for.
        tileable: the height was integrated across the wrap and the AO sees across it.
        ao_strength: the AO is that of ``ao_strength x`` the height (1 = the depth the normal map implies).
        low_cut: the height's high-pass cut-off, cycles across the map (:func:`height_from_normals`; 0 = none).
        broad_taken: the share of the broad relief taken out of the height, in [0, 1] (1: all of it, a bias the
            normals barely show; 0: none, relief the normals show; :data:`BROAD_SHARE`).
    """

    height: Optional[np.ndarray]
    scale: float
    ao: Optional[np.ndarray]
    tileable: bool = False
    ao_strength: float = 1.0
    low_cut: float = 0.0
    broad_taken: float = 0.0

    @property
    def names(self) -> Tuple[str, ...]:
        """The relief maps present, in :data:`RELIEF_NAMES` order."""
        return tuple(n for n in RELIEF_NAMES if getattr(self, n) is not None)

    @property
    def shape(self) -> Tuple[int, int]:
        """(H, W) of the maps."""
        return getattr(self, self.names[0]).shape[:2]

    def info(self) -> dict:
        """How the maps were made, for a sidecar (JSON-serialisable)."""
        out = {"maps": list(self.names),
               "height_scale": self.scale,
               "height_scale_unit": "map widths (the height black to white spans; 0 = flat)",
               "height": {"method": "least-squares integration of the normal map's slopes (Poisson solve, "
                                    + ("periodic FFT across the wrap)" if self.tileable else
                                       "DCT, Neumann boundaries)")
                                    + (f"; relief broader than the map taken out where the normals barely "
                                       f"show it (the slopes' best quadratic height when not tileable, then a "
                                       f"high-pass of cut-off {self.low_cut:g} cycles across the map, order "
                                       f"{LOW_ORDER}; broad_taken: the share taken out)" if self.low_cut > 0 else ""),
                          "encoding": "h = (value - 0.5) * height_scale; white = high, 0.5 = mean level",
                          "max_slope": MAX_SLOPE, "low_cut": self.low_cut,
                          "low_cut_unit": "cycles across the map (0 = none)",
                          "broad_taken": self.broad_taken},
               "tileable": self.tileable}
        if self.ao is not None:
            out["ao"] = {"method": "horizon-based, cosine-weighted, of the height x strength; 1 = open",
                         "directions": 8, "radius": AO_RADIUS, "radius_unit": "map widths",
                         "max_size": AO_MAX_SIZE, "strength": self.ao_strength,
                         "strength_reason": (AO_STRENGTH_REASON if self.ao_strength == AO_STRENGTH else
                                             "chosen by the caller" if self.ao_strength != 1.0 else
                                             "the depth the normal map implies"),
                         "mean": float(np.mean(self.ao, dtype=np.float64))}
        return out


def relief_maps(normal, *, tileable: bool = False, maps=RELIEF_NAMES, zero: str = "error",
                ao_strength: float = AO_STRENGTH, low_cut: Optional[float] = None) -> Relief:
    """The height map and ambient occlusion of a normal map, as written next to the texture set.

    Args:
        normal: (H, W, 3) float unit normals, OpenGL frame (decoded, in [-1, 1]), or an object with a ``normal``
            attribute holding them (a :class:`~svbrdf.runtime.core.maps.Maps`).
        tileable: the maps repeat: integrate and occlude across the wrap.
        maps: the relief maps wanted, names of :data:`RELIEF_NAMES` (the AO needs the height, which is computed
            either way).
        zero: zero-length normals: ``"error"`` or ``"flat"`` (the repair of :func:`normal_slopes`); ``"unit"``: the
            normals as written, made unit first (:func:`normal_slopes`).
        ao_strength: the AO is that of ``ao_strength x`` the height (> 0; 1 = the depth the normal map implies;
            default :data:`AO_STRENGTH`).
        low_cut: the height's relief broader than the map taken out (:func:`height_from_normals`; None:
            :data:`LOW_CUT`; 0: the plain least-squares height).

    Returns:
        A :class:`Relief`: ``height`` (H, W) in [0, 1] (:func:`normalise`), ``scale`` (map widths, the normal map's
        own depth), ``ao`` (H, W) in [0, 1], 1 = open. A flat normal map gives a height of 0.5 everywhere, scale 0
        and AO 1.

    Raises:
        SvbrdfError: no normal map, a bad one (shape, dtype, NaN/inf, zero-length normals with ``zero="error"``),
            unknown or no map names, ``ao_strength`` <= 0, or a bad ``low_cut``.
    """
    if not isinstance(normal, np.ndarray) and hasattr(normal, "normal"):
        if normal.normal is None:
            raise SvbrdfError("the height and AO need the normal map; this texture set has none")
        normal = normal.normal
    ao_strength = _positive(ao_strength, "ao_strength")
    names = (maps,) if isinstance(maps, str) else tuple(maps)
    unknown = [n for n in names if n not in RELIEF_NAMES]
    if unknown or not names:
        raise SvbrdfError(f"relief maps: unknown or no names {unknown!r}; valid names: {', '.join(RELIEF_NAMES)}")
    low_cut = _low_cut(LOW_CUT if low_cut is None else low_cut)
    height, taken = _integrate(normal, bool(tileable), MAX_SLOPE, zero, low_cut)
    ao = ambient_occlusion(height, tileable=tileable, strength=ao_strength) if "ao" in names else None
    h01, scale = _normalise(height, out=height)  # the height itself is not kept
    return Relief(h01 if "height" in names else None, scale, ao, bool(tileable), ao_strength, low_cut, taken)


def with_relief(texture_set, /, *, tileable: bool = False, maps=RELIEF_NAMES, ao_strength: float = AO_STRENGTH):
    """A copy of a texture set (a :class:`~svbrdf.runtime.core.maps.Maps`) with its ``relief``: the height map and
    ambient occlusion of its normal map, as written (:func:`relief_maps`; ``maps`` picks ``"height"`` and/or
    ``"ao"``). The copy has the same arrays, a copy of the meta and the same render config.

    The normals are made unit length as the writers make them (``normalize_normals``: a zero-length normal becomes
    (0, 0, 1), the documented repair), strip by strip as their slopes are taken (``zero="unit"`` of
    :func:`normal_slopes`), so the height's slopes are those of the written normal map. ``tileable``: the maps
    repeat (the height is integrated across the wrap). ``ao_strength``: the AO is that of the height times it
    (default :data:`AO_STRENGTH`, docs/decisions/002-ao-strength.md; 1 = the normal map's own depth).

    Raises:
        SvbrdfError: no normal map, NaN/Inf normals, unknown or no names, or ``ao_strength`` <= 0.
    """
    if texture_set.normal is None:
        raise SvbrdfError(f"the height and AO need the normal map; this texture set has only "
                          f"{', '.join(texture_set.names)}")
    if not all_finite(texture_set.normal):
        raise SvbrdfError("normal map: NaN or infinite values; the height and AO need finite normals")
    relief = relief_maps(texture_set.normal, tileable=tileable, maps=maps, ao_strength=ao_strength, zero="unit")
    return replace(texture_set, meta=dict(texture_set.meta), relief=relief)
