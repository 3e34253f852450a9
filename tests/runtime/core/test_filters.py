"""The finiteness check of large arrays (svbrdf.runtime.core.filters.all_finite)."""

import numpy as np
import pytest

from svbrdf.runtime.core.filters import all_finite


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_one_non_finite_value_anywhere_is_found(bad, dtype):
    a = np.random.default_rng(0).uniform(-1, 1, (37, 41, 3)).astype(dtype)
    assert all_finite(a)
    for idx in [(0, 0, 0), (36, 40, 2), (17, 3, 1)]:
        b = a.copy()
        b[idx] = bad
        assert not all_finite(b)


def test_opposite_infinities_and_overflowing_finite_values():
    big = np.finfo(np.float32).max
    assert all_finite(np.full((64, 64), big, np.float32))  # the sum overflows; every value is finite
    assert all_finite(np.array([big, -big, big], np.float32))
    assert not all_finite(np.array([np.inf, -np.inf], np.float32))  # the sum is NaN
    assert not all_finite(np.array([big, big, np.nan], np.float32))


def test_views_empty_and_integers():
    row = np.array([0.1, np.nan, 0.3], np.float32)
    assert not all_finite(np.broadcast_to(row, (1000, 1000, 3)))
    assert all_finite(np.broadcast_to(np.float32(0.5), (8192, 8192, 3)))
    assert all_finite(np.zeros((0, 3), np.float32))
    assert all_finite(np.arange(10))
