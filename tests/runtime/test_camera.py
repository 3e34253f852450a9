"""The realistic photo model: each camera effect on its own, against values computed by hand."""

import numpy as np
import pytest

from svbrdf.runtime.camera import REALISTIC, Camera, expose, sample_camera, vignette
from svbrdf.runtime.colour import linear_to_srgb


def test_identity_camera_only_clips():
    x = np.linspace(0, 2, 48, dtype=np.float32).reshape(4, 4, 3)
    assert np.array_equal(expose(x, Camera()), np.clip(x, 0, 1))


def test_exposure_scales_by_stops():
    x = np.full((4, 4, 3), 0.1, np.float32)
    assert np.allclose(expose(x, Camera(ev=1.0)), 0.2)
    assert np.allclose(expose(x, Camera(ev=-1.0)), 0.05)


def test_vignetting_darkens_the_corners_only():
    v = vignette(64, 64, 0.3)[..., 0]
    assert v[31:33, 31:33].min() > 0.999  # the centre is untouched
    assert v[0, 0] == pytest.approx(1 - 0.3 * (31.5 ** 2 * 2) / (32 ** 2 * 2), abs=1e-6)
    assert np.allclose(v, v[::-1]) and np.allclose(v, v[:, ::-1])  # radial


def test_noise_variance_follows_signal():
    x = np.concatenate([np.full((64, 64, 3), 0.05), np.full((64, 64, 3), 0.5)], axis=1)
    cam = Camera(shot=1e-3, read=2e-3)
    y = expose(x, cam, seed=3).astype(np.float64)
    dark, bright = y[:, :64] - 0.05, y[:, 64:] - 0.5
    assert dark.var() == pytest.approx(1e-3 * 0.05 + 4e-6, rel=0.1)
    assert bright.var() == pytest.approx(1e-3 * 0.5 + 4e-6, rel=0.1)
    assert np.array_equal(y, expose(x, cam, seed=3))  # seeded
    assert not np.array_equal(y, expose(x, cam, seed=4))


def test_quantize_gives_8bit_srgb_codes():
    x = np.random.default_rng(0).uniform(0, 1, (8, 8, 3))
    y = expose(x, Camera(quantize=True))
    s = linear_to_srgb(y).astype(np.float64) * 255
    assert np.abs(s - np.round(s)).max() < 0.01


def test_sample_camera_is_seeded_and_in_range():
    a, b = sample_camera(7), sample_camera(7)
    assert a == b and a != sample_camera(8) and a.quantize
    for key, (lo, hi) in REALISTIC.items():
        assert lo <= getattr(a, key) <= hi


def test_bad_camera_is_refused():
    with pytest.raises(ValueError):
        Camera(vignetting=1.0)
    with pytest.raises(ValueError):
        Camera(shot=-1.0)
