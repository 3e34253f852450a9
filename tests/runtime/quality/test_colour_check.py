"""The foreign-colour score (svbrdf.runtime.quality.colour_check): zero for the photo's own colour, monotone in a
pasted patch of another hue, blind to brightness, clipped highlights (and their shoulder) and near-black blocks."""

import math

import numpy as np
import pytest

from svbrdf.runtime.quality import foreign_colour
from svbrdf.runtime.quality.colour_check import CLIP_LEVEL, chroma_ab, chroma_distance

N = 256


def _material(seed=0) -> np.ndarray:
    """(N, N, 3) linear albedo: wood-like orange with a grey streak, textured at every scale."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:N, 0:N] / N
    grain = 0.55 + 0.35 * np.sin(2 * np.pi * (9 * yy + 0.7 * np.sin(2 * np.pi * 2 * xx)))
    grain = grain * (1 + 0.2 * rng.standard_normal((N, N)))
    colour = np.where((xx > 0.7)[..., None], [0.2, 0.2, 0.2], [0.45, 0.18, 0.08])
    return np.clip(grain[..., None] * colour, 0.005, 1).astype(np.float32)


def _flash(albedo: np.ndarray) -> np.ndarray:
    """The albedo lit by a grey flash above the centre (radial fall-off), as a photo in [0, 1]."""
    yy, xx = (np.mgrid[0:N, 0:N] + 0.5) / N - 0.5
    light = 1.6 / (1 + 6 * (xx ** 2 + yy ** 2)) ** 1.5
    return np.clip(albedo * light[..., None], 0, 1).astype(np.float32)


def _paste(base: np.ndarray, side: int, colour, top=16, left=96) -> np.ndarray:
    """``base`` with a ``side`` x ``side`` square recoloured: its luminance kept, its chromaticity ``colour``'s."""
    out = base.copy()
    patch = out[top:top + side, left:left + side]
    lum = patch.mean(axis=-1, keepdims=True)
    c = np.asarray(colour, np.float32)
    out[top:top + side, left:left + side] = lum * c / c.mean()
    return out


def test_the_photos_own_colour_scores_zero():
    albedo = _material()
    photo = _flash(albedo)
    same = foreign_colour(photo, photo)
    assert same["foreign_colour"] == pytest.approx(0, abs=1e-9)
    assert same["foreign_colour_area"] == 0.0
    # The albedo is the photo divided by a smooth grey light: its colour is the photo's, its brightness is not.
    even = foreign_colour(albedo, photo)
    assert even["foreign_colour"] < 1.0 and even["foreign_colour_p99"] < 3.0
    assert even["foreign_colour_area"] == 0.0
    # Brightness alone never counts.
    assert foreign_colour(0.3 * albedo, photo)["foreign_colour"] == pytest.approx(even["foreign_colour"], abs=1e-6)


def test_monotone_in_the_size_of_a_pasted_patch():
    albedo = _material()
    photo = _flash(albedo)
    maroon = [0.6, 0.02, 0.05]
    scores = [foreign_colour(_paste(albedo, side, maroon), photo) for side in (0, 16, 32, 64, 96)]
    means = [s["foreign_colour"] for s in scores]
    areas = [s["foreign_colour_area"] for s in scores]
    assert all(a < b for a, b in zip(means, means[1:])), means
    assert all(a < b for a, b in zip(areas, areas[1:])), areas
    assert scores[-1]["foreign_colour_p99"] > 30


def test_monotone_in_the_hue_of_a_pasted_patch():
    albedo = _material()
    photo = _flash(albedo)
    own = albedo[16:80, 96:160].reshape(-1, 3).mean(axis=0)
    teal = np.array([0.05, 0.3, 0.3])
    scores = [foreign_colour(_paste(albedo, 64, (1 - t) * own + t * teal), photo) for t in (0, 0.25, 0.5, 0.75, 1)]
    means = [s["foreign_colour"] for s in scores]
    p99 = [s["foreign_colour_p99"] for s in scores]
    assert all(a < b for a, b in zip(means, means[1:])), means
    assert all(a < b for a, b in zip(p99, p99[1:])), p99


def test_greying_the_base_colour_is_not_a_way_to_win():
    albedo = _material()
    photo = _flash(albedo)
    grey = albedo.mean(axis=-1, keepdims=True)
    scores = [foreign_colour((1 - t) * albedo + t * grey, photo)["foreign_colour"] for t in (0, 0.3, 0.6, 1)]
    assert all(a < b for a, b in zip(scores, scores[1:])), scores


def test_clipped_and_near_black_blocks_are_left_out():
    albedo = _material()
    photo = _flash(albedo)
    teal = [0.05, 0.3, 0.3]
    clipped = photo.copy()
    clipped[:64, 96:160] = CLIP_LEVEL  # a clipped highlight: the photo does not tell the colour there
    assert foreign_colour(_paste(albedo, 64, teal, top=0, left=96), clipped)["foreign_colour"] == \
        pytest.approx(foreign_colour(albedo, clipped)["foreign_colour"], abs=1e-9)
    dark = photo.copy()
    dark[:64, 96:160] *= 1e-3
    assert foreign_colour(_paste(albedo, 64, teal, top=0, left=96), dark)["foreign_colour"] == \
        pytest.approx(foreign_colour(albedo, dark)["foreign_colour"], abs=1e-9)
    distance, kept = chroma_distance(albedo, clipped)
    assert distance.shape == kept.shape == (16, 16) and not kept[:4, 6:10].any()  # the clipped patch's blocks
    assert kept.sum() == 256 - 16  # nothing else without an unknown region
    # the caller's unknown region (the bench's: the highlight and its shoulder, where the photo shows the light's
    # colour) is left out too
    from svbrdf.runtime.post.highlight_fill import highlight_mask

    _, kept = chroma_distance(albedo, clipped, unknown=highlight_mask(np.clip(clipped, 0, 1)))
    assert not kept[:4, 6:10].any() and 0.5 * 256 < kept.sum() < 256 - 16
    patch = np.zeros(photo.shape[:2], bool)
    patch[128:192, 0:64] = True
    assert foreign_colour(_paste(albedo, 64, teal, top=128, left=0), photo, unknown=patch)["foreign_colour"] == \
        pytest.approx(foreign_colour(albedo, photo, unknown=patch)["foreign_colour"], abs=1e-9)
    assert chroma_distance(albedo, 0.5 * photo)[1].all()  # nothing clipped: every block counts
    everything = foreign_colour(albedo, np.ones_like(photo))
    assert all(math.isnan(v) for v in everything.values())


def test_chroma_is_zero_for_greys_and_refuses_other_shapes():
    assert np.abs(chroma_ab(np.array([[0.0, 0, 0], [0.01, 0.01, 0.01], [1, 1, 1]]))).max() < 1e-6
    red, grey = chroma_ab(np.array([0.5, 0.05, 0.05])), chroma_ab(np.array([0.3, 0.3, 0.3]))
    assert red[0] > 40 and np.hypot(*grey) < 1e-6
    with pytest.raises(ValueError):
        foreign_colour(np.zeros((8, 8, 3)), np.zeros((8, 9, 3)))
