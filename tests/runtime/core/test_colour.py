"""The sRGB transfer functions (float32) against the closed-form IEC 61966-2-1 curve in float64.

Tolerances: :data:`ULPS` float32 steps at 1 (numpy's float32 power may use vectorised kernels documented to within a
few ULP, which differ between CPUs: not this CPU's own error)."""

import numpy as np
import pytest

from svbrdf.runtime.core.colour import linear_to_srgb, srgb_to_linear

#: Allowed error, float32 steps at 1 (values of the curve are at most 1 on [0, 1]).
ULPS = 8
TOL = ULPS * float(np.finfo(np.float32).eps)


def _srgb_to_linear_ref(s):
    s = s.astype(np.float64)
    return np.where(s <= 0.04045, s / 12.92, ((s + 0.055) / 1.055) ** 2.4)


def _linear_to_srgb_ref(x):
    x = x.astype(np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0.0), 1.0 / 2.4) - 0.055)


@pytest.mark.parametrize("shape", [(17, 23, 3), (9, 5, 1), (4, 4), (7,), (3, 2, 2, 5)])
def test_srgb_to_linear_matches_formula(shape):
    rng = np.random.default_rng(0)
    s = rng.random(shape, dtype=np.float32)
    out = srgb_to_linear(s)
    assert out.shape == s.shape and out.dtype == np.float32
    np.testing.assert_allclose(out, _srgb_to_linear_ref(s), atol=TOL, rtol=0)


@pytest.mark.parametrize("shape", [(17, 23, 3), (9, 5, 1), (4, 4)])
def test_linear_to_srgb_matches_formula(shape):
    rng = np.random.default_rng(1)
    x = rng.random(shape, dtype=np.float32)
    out = linear_to_srgb(x)
    assert out.shape == x.shape and out.dtype == np.float32
    np.testing.assert_allclose(out, _linear_to_srgb_ref(x), atol=TOL, rtol=0)


def test_curve_both_segments_and_round_trip():
    # Dense ramp covering the linear toe (s <= 0.04045) and the power segment, plus the end points.
    s = np.linspace(0.0, 1.0, 4097, dtype=np.float32).reshape(1, -1, 1)
    lin = srgb_to_linear(s)
    np.testing.assert_allclose(lin, _srgb_to_linear_ref(s), atol=TOL, rtol=0)
    assert lin[0, 0, 0] == pytest.approx(0.0, abs=1e-6) and lin[0, -1, 0] == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(linear_to_srgb(lin), s, atol=2 * TOL, rtol=0)
    # It is not the 2.2 gamma: mid-grey differs by far more than the tolerance.
    assert abs(float(srgb_to_linear(np.float32([0.5]))[0]) - 0.5 ** 2.2) > 3e-3


def test_input_not_modified_and_empty():
    x = np.full((2, 3, 3), 0.5, np.float32)
    srgb_to_linear(x)
    assert np.all(x == 0.5)
    assert srgb_to_linear(np.zeros((0, 3, 3), np.float32)).shape == (0, 3, 3)


def test_linear_to_srgb_clip_clips_then_encodes():
    out = linear_to_srgb(np.array([-1.0, 0.0, 0.0031308 / 2, 1.0, 4.0], np.float32), clip=True)
    assert out.dtype == np.float32
    assert out[0] == 0.0 and out[1] == 0.0 and out[3] == pytest.approx(1.0, abs=1e-6) and out[4] == out[3]
    assert out[2] == pytest.approx(12.92 * 0.0031308 / 2, rel=1e-3)  # the linear toe


def test_linear_segment_below_zero_and_power_segment_above_one():
    x = np.array([-0.5, -0.01, 1.0, 2.0], np.float32)
    enc = linear_to_srgb(x)
    np.testing.assert_allclose(enc[:2], 12.92 * x[:2], rtol=TOL)
    np.testing.assert_allclose(enc[2:], _linear_to_srgb_ref(x[2:]), rtol=TOL)
    np.testing.assert_allclose(srgb_to_linear(enc), x, rtol=4 * TOL)


def test_scalars_and_zero_d_arrays():
    for x in (0.4, np.float32(0.4), np.array(0.4, np.float32)):
        enc = linear_to_srgb(x)
        assert np.shape(enc) == () and float(enc) == pytest.approx(_linear_to_srgb_ref(np.float64(0.4)), abs=TOL)
        assert float(srgb_to_linear(enc)) == pytest.approx(0.4, abs=2 * TOL)
