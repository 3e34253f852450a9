"""The realistic photo model: each camera effect on its own, against values computed by hand."""

import numpy as np
import pytest

from svbrdf.trainer.camera_model import REALISTIC, Camera, expose, sample_camera, vignette
from svbrdf.runtime.core.colour import linear_to_srgb


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


def test_roll_off_keeps_the_darks_brings_white_to_one_and_rises():
    from svbrdf.trainer.camera_model import roll_off

    x = np.linspace(0.0, 6.0, 601)
    assert roll_off(x, 1.0) is x  # a linear camera: the identity
    for white in (1.5, 2.0, 4.0):
        y = roll_off(x, white)
        assert np.all(np.diff(y) > 0)  # never reverses an order of brightness
        assert y[1] == pytest.approx(x[1], rel=0.02)  # slope 1 at 0: the darks stay
        assert roll_off(np.array(white), white) == pytest.approx(1.0)
        assert np.all(y[(x > 0) & (x < white)] < x[(x > 0) & (x < white)])  # below white, brights come down
    # a highlight 2x over the clip keeps a shape with white 4 where a linear camera clips it flat
    spot = np.array([[[0.5], [1.0], [1.5], [2.0]]]).repeat(3, axis=2)
    assert np.unique(expose(spot, Camera())).size == 2
    assert np.all(np.diff(expose(spot, Camera(white=4.0))[0, :, 0]) > 0)


def test_a_camera_without_roll_off_is_as_before_and_white_is_checked():
    x = np.random.default_rng(1).uniform(0, 2, (8, 8, 3))
    cam = Camera(ev=0.3, vignetting=0.1, shot=1e-3, read=2e-3, quantize=True)
    same = Camera(**{**cam.to_dict(), "white": 1.0})
    assert cam.white == 1.0 and np.array_equal(expose(x, cam, seed=5), expose(x, same, seed=5))
    assert sample_camera(7).white == 1.0  # the benchmark's synthetic inputs stay linear
    assert sample_camera(7, {**REALISTIC, "white": (2.0, 3.0)}).ev == sample_camera(7).ev  # drawn last
    assert 2.0 <= sample_camera(7, {**REALISTIC, "white": (2.0, 3.0)}).white <= 3.0
    with pytest.raises(ValueError):
        Camera(white=0.9)
