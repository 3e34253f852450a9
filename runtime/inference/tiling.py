"""Overlapping tiles with smooth blending, to run a fully convolutional model on images of any size.

An image axis of length ``L`` is cut into the fewest windows of ``tile`` pixels that overlap by at least
``overlap`` pixels, spread evenly (inner starts on a ``TILE_ALIGN`` grid): the first starts at 0, the last ends at
``L``, and neighbours overlap by about the same amount, often much more than ``overlap`` (at 2048 px with 1024 px
tiles: three windows, 512 px apart). Each tile's output is weighted by a separable raised-cosine ramp over the whole of its overlap with each
neighbour (never on an image border; a tile with neighbours on both sides ramps over at most half its length on
each) and the weighted sum is normalised. Where two neighbours' ramps cover the same pixels they sum to one
(cos^2 + sin^2), so the blend is a partition of unity; the weights are strictly positive inside each tile, so every
pixel has a non-zero total weight.

Why the whole overlap: a network with per-image normalisation gives each tile its own levels, and a ramp only
``overlap`` pixels wide turns that difference into a visible line; spread over the overlap it is a gradual change.
Decision: docs/decisions/011-even-tiles.md.

Pure numpy (part of the light runtime).
"""

from __future__ import annotations

from typing import Callable, List, Tuple

import numpy as np

#: Overlap in pixels of neighbouring tiles (each side), the default of the preview's tiled inference.
DEFAULT_OVERLAP = 64
#: Inner tiles start on multiples of this many pixels: the generators downsample by up to 16 (the U-Net's four
#: stride-2 levels; v1: 4), and a tile that starts off that grid is sampled differently from the whole image
#: (tests/runtime/inference/test_session.py).
TILE_ALIGN = 32

__all__ = ["DEFAULT_OVERLAP", "TILE_ALIGN", "tile_starts", "tile_boxes", "ramp_weights", "tile_weights", "tiled_apply"]


def _check(tile: int, overlap: int) -> None:
    if tile < 1:
        raise ValueError(f"tile must be >= 1, got {tile}")
    if overlap < 0 or 2 * overlap > tile:
        raise ValueError(f"overlap must be in [0, tile/2], got overlap={overlap} for tile={tile}")


def tile_starts(length: int, tile: int, overlap: int, align: int = TILE_ALIGN) -> List[int]:
    """Start offsets of the windows covering ``[0, length)``.

    Windows are ``min(tile, length)`` long; there are as few as keep every two neighbours overlapping by at least
    ``overlap`` pixels, spread evenly, each inner start rounded to a multiple of ``align`` (so that a strided
    network samples a tile on the same grid as the whole image; of ``align / 2``, ``align / 4``, ... where that
    would take another window); the first starts at 0 and the last ends at ``length``.
    """
    _check(tile, overlap)
    if align < 1:
        raise ValueError(f"align must be >= 1, got {align}")
    if length <= tile:
        return [0]
    gaps = -(-(length - tile) // (tile - overlap))  # windows - 1: the fewest with steps of at most tile - overlap
    grid = align
    while True:  # the coarsest grid, align halved down to 1, that keeps the fewest windows (1 always fits)
        starts = [0] + [grid * round(k * (length - tile) / gaps / grid) for k in range(1, gaps)] + [length - tile]
        if grid == 1 or all(0 < q - p <= tile - overlap for p, q in zip(starts, starts[1:])):
            return starts
        grid = max(1, grid // 2)


def tile_boxes(height: int, width: int, tile: int, overlap: int) -> List[Tuple[int, int, int, int]]:
    """Row-major list of tiles ``(y0, x0, h, w)`` covering an ``height x width`` image (clipped to it)."""
    return [
        (y0, x0, min(tile, height), min(tile, width))
        for y0 in tile_starts(height, tile, overlap)
        for x0 in tile_starts(width, tile, overlap)
    ]


def ramp_weights(n: int, start: int, end: int) -> np.ndarray:
    """1-D blend weights of a window of ``n`` pixels, in ``(0, 1]``, float32.

    Args:
        n: window length.
        start: length of the ramp up over the first pixels (the overlap with a neighbour before this window; 0: an
            image border, no ramp).
        end: length of the ramp down over the last pixels (the overlap with a neighbour after it; 0: none).
            ``start + end <= n``.
    """
    if start < 0 or end < 0 or start + end > n:
        raise ValueError(f"ramps of {start} and {end} pixels do not fit a window of {n}")
    w = np.ones(n, dtype=np.float64)
    # Raised cosine sampled at pixel centres: strictly inside (0, 1), and the up and down ramps of two neighbours
    # over the same pixels sum to 1.
    if start:
        w[:start] *= 0.5 - 0.5 * np.cos(np.pi * (np.arange(start) + 0.5) / start)
    if end:
        w[n - end:] *= (0.5 - 0.5 * np.cos(np.pi * (np.arange(end) + 0.5) / end))[::-1]
    return w.astype(np.float32)


def _ramps(origin: int, n: int, length: int, overlap: int) -> Tuple[int, int]:
    """Ramp lengths (start, end) of the window at ``origin`` of :func:`tile_starts` (``length``, tile ``n``)."""
    if n >= length:
        return 0, 0
    starts = tile_starts(length, n, overlap)
    k = starts.index(origin)
    start = starts[k - 1] + n - origin if k > 0 else 0
    end = origin + n - starts[k + 1] if k + 1 < len(starts) else 0
    if start and end:  # neighbours on both sides: each ramp over at most half the window
        start, end = min(start, n // 2), min(end, n - n // 2)
    return start, end


def tile_weights(box: Tuple[int, int, int, int], height: int, width: int, overlap: int) -> np.ndarray:
    """Separable ``(h, w)`` blend weights of one tile of :func:`tile_boxes`: ramps over its overlaps with its
    neighbours (none on the image's borders)."""
    y0, x0, h, w = box
    wy = ramp_weights(h, *_ramps(y0, h, height, overlap))
    wx = ramp_weights(w, *_ramps(x0, w, width, overlap))
    return wy[:, None] * wx[None, :]


def tiled_apply(
    fn: Callable[[np.ndarray], np.ndarray],
    image: np.ndarray,
    tile: int,
    overlap: int,
) -> np.ndarray:
    """Apply a size-preserving image operator tile by tile and blend the results.

    Memory is bounded by one tile of ``fn`` work plus the ``(H, W, C_out)`` float32 output and an
    ``(H, W)`` weight sum. With a single tile, ``fn`` is called once on the whole image.

    Args:
        fn: maps an ``(h, w, C)`` array to an ``(h, w, C_out)`` array (same ``h, w``).
        image: ``(H, W, C)`` array.
        tile: tile size in pixels (square tiles, clipped to the image).
        overlap: overlap between neighbouring tiles, ``0 <= 2 * overlap <= tile``.

    Returns:
        ``(H, W, C_out)`` float32 array.
    """
    if image.ndim != 3:
        raise ValueError(f"image must be (H, W, C), got shape {image.shape}")
    height, width = image.shape[:2]
    boxes = tile_boxes(height, width, tile, overlap)
    if len(boxes) == 1:
        return np.asarray(fn(image), dtype=np.float32)
    acc = None
    wsum = np.zeros((height, width, 1), dtype=np.float32)
    for box in boxes:
        y0, x0, h, w = box
        out = np.asarray(fn(image[y0 : y0 + h, x0 : x0 + w]), dtype=np.float32)
        if out.ndim != 3 or out.shape[:2] != (h, w):
            raise ValueError(f"fn must return an ({h}, {w}, C) array, got shape {out.shape}")
        if acc is None:
            acc = np.zeros((height, width, out.shape[2]), dtype=np.float32)
        wt = tile_weights(box, height, width, overlap)[:, :, None]
        acc[y0 : y0 + h, x0 : x0 + w] += out * wt
        wsum[y0 : y0 + h, x0 : x0 + w] += wt
    acc /= wsum
    return acc
