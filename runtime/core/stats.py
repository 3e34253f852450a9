"""Statistics of arrays shared by the runtime's checks and the benchmark's metrics (pure numpy)."""

from __future__ import annotations

from typing import Optional

import numpy as np

__all__ = ["pearson"]


def pearson(a: np.ndarray, b: np.ndarray) -> Optional[float]:
    """Pearson correlation of two arrays of the same size (any shapes), over all their values, in float64.

    Returns:
        the correlation in [-1, 1] (up to rounding), or ``None`` when there are fewer than two values or either
        array is constant (the product of the two spreads ``sqrt(sum (a - mean)^2 sum (b - mean)^2) <= 1e-300``);
        callers that want a number there choose it (``0.0`` in the benchmark).
    """
    a = np.asarray(a).astype(np.float64).ravel()
    b = np.asarray(b).astype(np.float64).ravel()
    if a.size < 2:
        return None
    a = a - a.mean()
    b = b - b.mean()
    den = np.sqrt(np.dot(a, a) * np.dot(b, b))
    return None if den <= 1e-300 else float(np.dot(a, b) / den)
