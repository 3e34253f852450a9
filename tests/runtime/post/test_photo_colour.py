"""The base colour's colours from the photo (svbrdf.runtime.post.photo_colour): the global balance and the coarse
local colours (local_colour), scored with the foreign-colour check (svbrdf.runtime.quality.colour_check)."""

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from svbrdf.runtime.post.photo_colour import LOCAL_GAIN_MAX, local_colour, photo_colour
from svbrdf.runtime.quality import foreign_colour

N = 128


def _scene(seed=0):
    """A textured wood-like albedo with fine colour stripes (linear) and its photo under a grey flash."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:N, 0:N] / N
    grain = 0.6 + 0.3 * np.sin(2 * np.pi * 11 * yy) + 0.1 * rng.standard_normal((N, N))
    albedo = grain[..., None] * np.where((np.sin(2 * np.pi * 16 * xx) > 0)[..., None], [0.5, 0.2, 0.08],
                                         [0.35, 0.25, 0.12])
    albedo = np.clip(albedo, 0.01, 1).astype(np.float32)
    r2 = (yy - 0.45) ** 2 + (xx - 0.55) ** 2
    photo = np.clip(albedo * (1.5 / (1 + 8 * r2)[..., None]), 0, 1).astype(np.float32)
    return albedo, photo, r2


def test_a_cast_under_the_flash_is_taken_out_and_the_texture_kept():
    albedo, photo, r2 = _scene()
    # The network's base colour: the albedo, with a blue-green disc under the flash and greyed far from it.
    disc = np.exp(-r2 / (2 * 0.12 ** 2))[..., None]
    lum = albedo.mean(-1, keepdims=True)
    cast = albedo * (1 + disc * np.array([-0.5, 0.3, 1.2]))
    cast = cast * (lum / cast.mean(-1, keepdims=True))
    far = np.clip((np.sqrt(r2) - 0.35) / 0.3, 0, 1)[..., None]
    cast = np.clip((1 - 0.7 * far) * cast + 0.7 * far * cast.mean(-1, keepdims=True), 0, 1).astype(np.float32)
    before = foreign_colour(cast, photo)
    assert before["foreign_colour"] > 8 and before["foreign_colour_area"] > 0.1
    balanced = photo_colour(cast, photo)  # the photo's overall balance first, as the preview does
    out = local_colour(balanced, photo)
    after = foreign_colour(out, photo)
    assert after["foreign_colour"] < 0.4 * before["foreign_colour"] and after["foreign_colour_area"] < 0.01
    assert after["foreign_colour_p99"] < 0.6 * before["foreign_colour_p99"]
    # Not by greying: the colour comes back where it was greyed.
    chroma = lambda a: (a.max(-1) - a.min(-1)).mean()  # noqa: E731
    assert chroma(out) > chroma(cast) and chroma(out) == pytest.approx(chroma(albedo), rel=0.15)
    # Each pixel keeps its luminance, and the fine stripes their contrast.
    np.testing.assert_allclose(out.mean(-1), balanced.mean(-1), rtol=1e-4, atol=1e-6)
    assert np.corrcoef(out[..., 0].ravel(), albedo[..., 0].ravel())[0, 1] > 0.97
    # A global balance alone cannot do it: the cast is not the same everywhere.
    assert foreign_colour(balanced, photo)["foreign_colour"] > 1.5 * after["foreign_colour"]


def test_a_base_colour_with_the_photos_colours_is_left_as_it_is():
    albedo, photo, _ = _scene(seed=1)
    assert local_colour(albedo, photo) is albedo
    np.testing.assert_allclose(local_colour(0.5 * albedo, photo), 0.5 * albedo, rtol=1e-6)
    everything_clipped = np.ones_like(photo)
    np.testing.assert_array_equal(local_colour(albedo, everything_clipped), albedo)


def test_the_factors_are_bounded():
    albedo, photo, _ = _scene(seed=2)
    green = np.clip(albedo.mean(-1, keepdims=True) * np.array([0.2, 1.0, 0.2]), 0, 1).astype(np.float32)
    out = local_colour(green, photo)
    with np.errstate(divide="ignore", invalid="ignore"):
        factor = (out / out.mean(-1, keepdims=True)) / (green / green.mean(-1, keepdims=True))
    assert np.nanmax(factor) <= LOCAL_GAIN_MAX ** 2 + 1e-3  # a channel's factor, then the luminance kept
    assert foreign_colour(out, photo)["foreign_colour"] < foreign_colour(green, photo)["foreign_colour"]
    assert (out >= 0).all() and (out <= 1).all() and out.dtype == np.float32


EXAMPLE = Path(str(resources.files("svbrdf.runtime"))) / "examples" / "carved_wood.png"


def test_the_bundled_example_has_no_foreign_patch():
    """Issue 67: the example's base colour had a maroon patch with green fringes under the flash and teal dark
    grooves (foreign colour 15.8 on average, 99th percentile 69, 36 % of the area above the visible threshold)."""
    from svbrdf.runtime.inference.pipeline import estimate
    from svbrdf.runtime.inference.session import load_session
    from svbrdf.runtime.io.images import read_image

    photo = read_image(EXAMPLE)
    maps = estimate(photo, load_session(threads=1))
    score = foreign_colour(maps.diffuse, photo)
    assert score["foreign_colour"] < 10 and score["foreign_colour_p99"] < 35 and score["foreign_colour_area"] < 0.1
    assert (maps.diffuse.min(axis=-1) > 0).mean() > 0.99  # no channel taken to 0 (the teal grooves)
