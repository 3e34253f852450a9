"""The label-free relief check (svbrdf.runtime.quality.relief_check): a dome, a bowl and a stationary relief with known
answers, invariance to the height's scale and offset, the centre, large maps and bad input."""

import numpy as np
import pytest

from svbrdf.runtime.quality import RELIEF_METRICS, relief_radial


def _distance(h, w, centre):
    i, j = np.mgrid[0:h, 0:w]
    return np.hypot(i + 0.5 - centre[0], j + 0.5 - centre[1])


def _texture(h, w, seed=0):
    """A stationary relief: periodic noise blurred over a few pixels."""
    rng = np.random.default_rng(seed)
    fy = np.fft.fftfreq(h)[:, None]
    fx = np.fft.rfftfreq(w)[None, :]
    return np.fft.irfft2(np.fft.rfft2(rng.normal(size=(h, w))) * np.exp(-2 * (np.pi * 1.5) ** 2 * (fx ** 2 + fy ** 2)),
                         s=(h, w))


def test_a_dome_a_bowl_and_a_stationary_relief():
    h, w, centre = 120, 160, (50.0, 90.0)
    r = _distance(h, w, centre)
    dome = np.exp(-(r / (0.3 * w)) ** 2)
    s = relief_radial(dome, centre)
    assert set(s) == set(RELIEF_METRICS)
    assert s["relief_radial_corr"] < -0.9 and s["relief_radial_share"] > 0.95
    bowl = relief_radial(-dome, centre)
    assert bowl["relief_radial_corr"] > 0.9 and bowl["relief_radial_share"] == pytest.approx(s["relief_radial_share"])
    tex = _texture(h, w)
    t = relief_radial(tex, centre)
    assert abs(t["relief_radial_corr"]) < 0.1 and t["relief_radial_share"] < 0.1
    # the dome on top of the texture is found; it is the texture's scale that sets how much
    mixed = relief_radial(tex / tex.std() + 3 * dome / dome.std(), centre)
    assert mixed["relief_radial_corr"] < -0.7 and mixed["relief_radial_share"] > 0.5


def test_scale_offset_and_the_written_map_score_alike():
    h, w, centre = 64, 96, (20.0, 30.0)
    field = _texture(h, w, 1) + 0.5 * np.exp(-(_distance(h, w, centre) / 30.0) ** 2)
    a = relief_radial(field, centre)
    b = relief_radial(0.5 + field / (2.5 * np.abs(field).max()), centre)  # as a written map in [0, 1]
    c = relief_radial(field[..., None].astype(np.float32) * 1e-3, centre)  # (H, W, 1), map widths
    for other in (b, c):
        for key in RELIEF_METRICS:
            assert other[key] == pytest.approx(a[key], abs=1e-5)


def test_the_centre_matters_and_defaults_to_the_image_centre():
    h, w = 80, 80
    dome = np.exp(-(_distance(h, w, (40.0, 40.0)) / 20.0) ** 2)
    assert relief_radial(dome) == relief_radial(dome, (40.0, 40.0))
    off = relief_radial(dome, (10.0, 10.0))
    assert off["relief_radial_share"] < relief_radial(dome)["relief_radial_share"]
    assert abs(off["relief_radial_corr"]) < abs(relief_radial(dome)["relief_radial_corr"])


def test_a_large_height_is_scored_on_block_means_like_a_small_one():
    centre = (300.0, 400.0)
    big = np.exp(-(_distance(600, 800, centre) / 200.0) ** 2) + 0.1 * np.random.default_rng(2).normal(size=(600, 800))
    small = big.reshape(150, 4, 200, 4).mean(axis=(1, 3))
    a, b = relief_radial(big, centre), relief_radial(small, (75.0, 100.0))
    assert a["relief_radial_corr"] == pytest.approx(b["relief_radial_corr"], abs=0.02)
    assert a["relief_radial_share"] == pytest.approx(b["relief_radial_share"], abs=0.02)


def test_constant_tiny_and_bad_heights():
    assert relief_radial(np.full((16, 16), 0.5)) == {"relief_radial_corr": 0.0, "relief_radial_share": 0.0}
    assert set(relief_radial(np.arange(3.0)[None, :])) == set(RELIEF_METRICS)  # a 1 x 3 map
    for bad in (np.zeros(5), np.zeros((4, 4, 3)), np.zeros((0, 4))):
        with pytest.raises(ValueError, match="relief_radial"):
            relief_radial(bad)
