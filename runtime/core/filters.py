"""Block and box means of (H, W, C) arrays: the low-pass filters shared by the image reader, the scores and the
post-processing; and the finiteness check of large arrays (pure numpy)."""

from __future__ import annotations

import numpy as np

__all__ = ["block_mean", "box_mean", "all_finite"]


def all_finite(arr: np.ndarray) -> bool:
    """Whether every value of a float array (any shape, broadcast views too) is finite, without a temporary of its
    size: one float32 sum is non-finite iff some value is (NaN and infinities propagate through a sum), except
    that finite values near the float32 limit can overflow it; such a sum is checked value by value."""
    a = np.asarray(arr)
    if a.size == 0 or not np.issubdtype(a.dtype, np.inexact):
        return True
    with np.errstate(over="ignore", invalid="ignore"):
        total = np.sum(a, dtype=np.float32)
    return bool(np.isfinite(total) or np.isfinite(a).all())


def block_mean(arr: np.ndarray, k: int, partial: bool = False) -> np.ndarray:
    """Mean over k x k blocks of an (H, W, C) array, float32, the block grid starting at the top-left corner.

    When H or W is not a multiple of ``k``, the last block row/column is dropped (``partial=False``: every block has
    k x k pixels, as the low-frequency scores want) or averaged over the pixels it has (``partial=True``: the strip
    reader, which must cover the whole image). Rows are summed first, over contiguous memory, then the
    block's columns, one slice add each.

    Returns:
        (H // k, W // k, C), or (ceil(H / k), ceil(W / k), C) with ``partial``; ``k = 1`` returns the array as
        float32.
    """
    if k == 1:
        return np.asarray(arr, dtype=np.float32)
    r, w, c = arr.shape
    if partial and r % k == 0 and w % k == 0:  # no partial block: the same sums and divisor without the padded copy
        partial = False
    if partial:
        rr, cc = -(-r // k) * k, -(-w // k) * k
        a = np.zeros((rr, cc, c), np.float32)
        a[:r, :w] = arr
    else:
        rr, cc = (r // k) * k, (w // k) * k
        a = np.ascontiguousarray(arr[:rr, :cc], dtype=np.float32)
    rows = a.reshape(rr // k, k, cc * c).sum(axis=1, dtype=np.float32)
    if c == 1:  # each block's k values are contiguous: one reduction
        sums = rows.reshape(rr // k, cc // k, k, 1).sum(axis=2)
    else:  # the k pixels of a block added in order, as the reduction over that axis adds them (the same bits)
        rows = rows.reshape(rr // k, cc // k, k * c)
        sums = rows[:, :, :c].copy()
        for j in range(1, k):
            sums += rows[:, :, j * c:(j + 1) * c]
    if not partial:
        return sums / np.float32(k * k)
    n_rows = np.minimum(k, r - k * np.arange(rr // k)).astype(np.float32)
    n_cols = np.minimum(k, w - k * np.arange(cc // k)).astype(np.float32)
    return sums / (n_rows[:, None, None] * n_cols[None, :, None])


def box_mean(x: np.ndarray, r: int, dtype=np.float64) -> np.ndarray:
    """Mean of ``x`` (h, w, C) over the (2r + 1)^2 window around each pixel (edges repeated).

    ``dtype`` float64 (default): summed-area tables, any ``r`` at the same cost. float32: the window's rows and then
    its columns added as ``2r + 1`` shifted slices, in float32 (rounding about 1e-7 of the values, cost growing with
    ``r``): for the small windows of :func:`svbrdf.runtime.inference.guided.local_gain`.
    """
    if np.dtype(dtype) == np.float32:
        h, w = x.shape[:2]
        a = np.pad(np.asarray(x, np.float32), ((r, r), (r, r), (0, 0)), mode="edge")
        rows = a[:h].copy()
        for d in range(1, 2 * r + 1):
            rows += a[d:d + h]
        out = rows[:, :w].copy()
        for d in range(1, 2 * r + 1):
            out += rows[:, d:d + w]
        out *= np.float32(1.0 / (2 * r + 1) ** 2)
        return out
    a = np.pad(x.astype(np.float64), ((r + 1, r), (r + 1, r), (0, 0)), mode="edge")
    c = a.cumsum(0).cumsum(1)
    n = 2 * r + 1
    return (c[n:, n:] - c[:-n, n:] - c[n:, :-n] + c[:-n, :-n]) / (n * n)
