"""Flash-trend removal (svbrdf.runtime.post.flash_trend): textures with a known radial trend added, and without one."""

import numpy as np
import pytest

from svbrdf.runtime.post import flash_trend as ft
from svbrdf.runtime.quality.burn_in import burn_in_scores
from svbrdf.runtime.core.maps import Maps


def _texture(n=128, seed=0):
    """A stationary texture set: smoothed noise in every map, tilted normals."""
    rng = np.random.default_rng(seed)

    def smooth(c):
        a = rng.uniform(0, 1, (n, n, c))
        for _ in range(3):
            a = (a + np.roll(a, 1, 0) + np.roll(a, 1, 1) + np.roll(a, -1, 0) + np.roll(a, -1, 1)) / 5
        return a

    normal = np.concatenate([0.2 * (smooth(2) - 0.5), np.ones((n, n, 1))], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return Maps(diffuse=(0.2 + 0.5 * smooth(3)).astype(np.float32), specular=(0.03 + 0.1 * smooth(1)).astype(np.float32),
                roughness=(0.3 + 0.4 * smooth(1)).astype(np.float32), normal=normal.astype(np.float32))


def _with_trend(maps, centre, amp=0.15, width=0.12):
    h, w = maps.shape
    bump = ft.radial_basis((h, w), centre, (width,))[0][..., None].astype(np.float32)
    return maps._with({"diffuse": maps.diffuse + amp * bump, "specular": maps.specular - 0.3 * amp * bump,
                       "roughness": maps.roughness - amp * bump, "normal": maps.normal})


def test_a_radial_trend_is_removed_and_the_texture_kept():
    clean = _texture()
    centre = (50.0, 70.0)
    burnt = _with_trend(clean, centre)
    assert burn_in_scores(burnt, centre)["burn_in"] > 0.5
    fixed = ft.remove_flash_trend(burnt, centre=centre)
    for name in ft.TREND_MAPS:  # up to a constant (the trend's mean stays: a level the fit cannot tell apart)
        def err(a):
            d = a - getattr(clean, name)
            return np.sqrt(np.mean((d - d.mean()) ** 2))
        assert err(getattr(fixed, name)) < 0.25 * err(getattr(burnt, name)), name
    assert burn_in_scores(fixed, centre)["burn_in"] < 0.2
    assert np.array_equal(fixed.normal, burnt.normal)  # normals are not touched
    meta = fixed.meta["flash_trend"]
    assert meta["centre"] == [50.0, 70.0] and meta["widths"] == list(ft.TREND_WIDTHS)
    assert meta["removed"]["diffuse"] > 0.01


def test_a_stationary_texture_is_hardly_changed_and_keeps_its_mean():
    clean = _texture(seed=3)
    out = ft.remove_flash_trend(clean)  # default centre: the image centre
    for name in ft.TREND_MAPS:
        a, b = getattr(clean, name), getattr(out, name)
        assert np.sqrt(np.mean((a - b) ** 2)) < 0.1 * a.std(), name
        assert abs(float(a.mean() - b.mean())) < 1e-3, name
        assert b.dtype == np.float32


def test_the_default_centre_is_the_photos_highlight():
    clean = _texture(n=96, seed=5)
    centre = (30.0, 60.0)
    burnt = _with_trend(clean, centre)
    photo = np.full((96, 96, 3), 0.1, np.float32) + 0.8 * ft.radial_basis((96, 96), centre, (0.1,))[0][..., None]
    out = ft.remove_flash_trend(burnt, photo=np.clip(photo, 0, 1).astype(np.float32))
    assert out.meta["flash_trend"]["centre"] == pytest.approx([30.0, 60.0], abs=4)
    assert burn_in_scores(out, centre)["burn_in"] < 0.5 * burn_in_scores(burnt, centre)["burn_in"]


def test_large_maps_fit_on_a_reduced_copy_and_match_the_full_fit():
    n = 3 * ft.FIT_MAX_SIDE // 2  # block size 2
    clean = _texture(n=n, seed=7)
    centre = (n / 2 + 10, n / 2 - 20)
    burnt = _with_trend(clean, centre)
    out = ft.remove_flash_trend(burnt, centre=centre)
    lum = burnt.diffuse.mean(axis=-1, keepdims=True)
    full = ft.fit_flash_trend(np.concatenate([lum, burnt.specular, burnt.roughness], -1), centre)
    basis = ft.radial_basis(burnt.shape, centre)
    basis -= basis.mean(axis=(1, 2), keepdims=True)
    trend = np.tensordot(basis, full, axes=([0], [0]))  # (H, W, 3): luminance, specular, roughness
    ref = ft.luminance_gain(burnt.diffuse, trend[..., 0], float(lum.mean()))
    assert np.abs(out.diffuse - ref).max() < 0.01
    assert np.abs(out.roughness - np.clip(burnt.roughness - trend[..., 2:], 0, 1)).max() < 0.01


def test_values_stay_in_range_and_missing_maps_stay_missing():
    clean = _texture(n=64, seed=2)
    burnt = _with_trend(clean, (32.0, 32.0), amp=2.0)  # pushes values far out of [0, 1]
    out = ft.remove_flash_trend(burnt.clipped(), centre=(32.0, 32.0))
    for name in ft.TREND_MAPS:
        a = getattr(out, name)
        assert a.min() >= 0.0 and a.max() <= 1.0
    part = Maps(roughness=clean.roughness, normal=clean.normal)
    out = ft.remove_flash_trend(part)
    assert out.diffuse is None and out.specular is None and out.roughness is not None
    nothing = ft.remove_flash_trend(Maps(normal=clean.normal))
    assert nothing.normal is clean.normal and "flash_trend" not in nothing.meta


def test_uniform_specular_is_the_median_level():
    clean = _texture(n=48, seed=4)
    out = ft.uniform_specular(clean)
    assert np.ptp(out.specular) == 0 and out.specular.shape == clean.specular.shape
    assert out.specular[0, 0, 0] == pytest.approx(float(np.median(clean.specular)), abs=1e-6)
    # A few metal-like pixels do not move the level of a dielectric.
    spec = np.full_like(clean.specular, 0.04)
    spec[:5] = 0.9
    outlier = ft.uniform_specular(clean._with({**dict(clean.items()), "specular": spec}))
    assert outlier.specular[0, 0, 0] == pytest.approx(0.04) and outlier.meta["uniform_specular"]["level"] == \
        pytest.approx(0.04)
    assert out.meta["uniform_specular"]["std_removed"] == pytest.approx(float(clean.specular.std()), abs=1e-6)
    for name in ("diffuse", "roughness", "normal"):
        assert np.array_equal(getattr(out, name), getattr(clean, name))
    no_spec = Maps(roughness=clean.roughness)
    assert ft.uniform_specular(no_spec) is no_spec


def test_postprocess_runs_the_asked_steps_and_scores_before_and_after():
    from svbrdf.runtime.quality.burn_in import photo_burn_in

    clean = _texture(n=64, seed=6)
    burnt = _with_trend(clean, (32.0, 32.0))
    photo = np.clip(0.1 + 0.8 * ft.radial_basis((64, 64), (32.0, 32.0), (0.1,))[0][..., None], 0, 1)
    photo = np.repeat(photo, 3, axis=-1).astype(np.float32)
    off = ft.postprocess(burnt, photo, flash_trend=False, specular_level=False)
    assert all(np.array_equal(getattr(off, n), getattr(burnt, n)) for n in ("diffuse", "specular", "roughness"))
    assert off.meta["burn_in"] == off.meta["burn_in_model"] == photo_burn_in(burnt, photo)
    assert "burn_in" not in burnt.meta  # the caller's maps are left alone
    on = ft.postprocess(burnt, photo)
    want = ft.uniform_specular(ft.remove_flash_trend(burnt, photo=photo))
    assert all(np.array_equal(getattr(on, n), getattr(want, n)) for n in ("diffuse", "specular", "roughness", "normal"))
    assert on.meta["burn_in_model"] == photo_burn_in(burnt, photo)
    assert on.meta["burn_in"]["burn_in"] < 0.5 * on.meta["burn_in_model"]["burn_in"]


def _lit_texture(h=96, w=128, seed=0):
    """A stationary colour texture (linear) and the same under a flash's fall-off (cosine cubed over the squared
    distance of a flash at 0.4 widths above the plane, centred off the image centre)."""
    tex = 0.2 + 0.5 * _texture(max(h, w), seed).diffuse[:h, :w]
    yy, xx = np.mgrid[0:h, 0:w] + 0.5
    r2 = ((yy - 40) ** 2 + (xx - 70) ** 2) / w ** 2
    light = (1.0 / (1.0 + r2 / 0.4 ** 2) ** 2).astype(np.float32)
    return tex.astype(np.float32), tex * light[..., None]


def test_even_lighting_takes_out_the_flash_and_keeps_the_texture_and_colour():
    tex, photo = _lit_texture()
    even = ft.even_lighting(photo, 0.25)
    assert even.shape == photo.shape and even.dtype == np.float32 and (even >= 0).all()
    lum, even_lum, tex_lum = photo.mean(-1), even.mean(-1), tex.mean(-1)
    assert np.median(even_lum) == pytest.approx(np.median(lum), rel=1e-5)  # the level is the photo's
    # Brightness under the flash against a corner, over the texture's own ratio: 11.7 in the photo; the narrower
    # the low pass, the closer to 1 (0.25 of the width takes out the broad fall-off only, 1/16 nearly all of it).
    spot, corner = (slice(30, 50), slice(60, 80)), (slice(84, 96), slice(0, 12))
    ratio = lambda a: a[spot].mean() / a[corner].mean() / (tex_lum[spot].mean() / tex_lum[corner].mean())  # noqa
    ratios = [ratio(ft.even_lighting(photo, s).mean(-1)) for s in (1 / 16, 1 / 8, 1 / 4)]
    assert ratio(lum) > 10 and ratios == sorted(ratios) and ratios[-1] < 0.5 * ratio(lum) and ratios[0] < 1.3
    # Every channel divided by the same field: a pixel's colour (channel ratios) is kept exactly.
    np.testing.assert_allclose(even[..., 0] * photo[..., 1], even[..., 1] * photo[..., 0], rtol=1e-4, atol=1e-7)


def test_an_evenly_lit_photo_is_left_as_it_is():
    tex, _ = _lit_texture()
    flat = np.full_like(tex, 0.3)
    np.testing.assert_allclose(ft.lighting_field(flat, 0.25), 0.3, rtol=1e-5)
    np.testing.assert_allclose(ft.even_lighting(flat, 0.25), flat, rtol=1e-5)
    # A pure texture is changed only by its own smooth part: most of it is kept.
    assert np.corrcoef(ft.even_lighting(tex, 0.25).mean(-1).ravel(), tex.mean(-1).ravel())[0, 1] > 0.95


@pytest.mark.parametrize("shape", [(9, 9), (37, 58), (300, 130)])
def test_lighting_field_shapes_and_small_photos(shape):
    rng = np.random.default_rng(1)
    photo = rng.uniform(0, 1, shape + (3,)).astype(np.float32)
    photo[0, 0] = 0.0  # black pixels are floored, not log(0)
    field = ft.lighting_field(photo, 0.25)
    assert field.shape == shape and field.dtype == np.float32 and np.isfinite(field).all() and (field > 0).all()


def test_the_trend_of_a_coloured_base_colour_is_removed_without_colouring_it():
    """Issue 67: a brown base colour with the flash's near-white highlight baked in (a flat-topped disc, which no
    sum of the fit's bumps matches exactly). Subtracted channel by channel, the fit's overshoot took the dark blue
    and green channels to 0 under the flash (a maroon blotch) and the trend, subtracted everywhere, greyed the rest;
    divided out as one gain per pixel, every pixel keeps the hue it had and no channel is zeroed."""
    from svbrdf.runtime.quality import foreign_colour

    n = 128
    grain = 1.0 + 2.0 * (_texture(n, seed=8).roughness - 0.5)  # a stationary texture around 1
    clean = (grain * np.array([0.12, 0.045, 0.02])).astype(np.float32)
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    disc = np.clip((0.18 - np.hypot(yy - 40, xx - 64) / n) / 0.04, 0, 1)[..., None]
    burnt = Maps(diffuse=np.clip(clean + disc * np.array([0.15, 0.15, 0.18]), 0, 1).astype(np.float32),
                 roughness=np.full((n, n, 1), 0.5, np.float32))
    fixed = ft.remove_flash_trend(burnt, centre=(40.0, 64.0))
    d = fixed.diffuse
    # The trend is gone: the disc is no brighter than the rest (within the texture's spread).
    inside, outside = disc[..., 0] > 0.99, disc[..., 0] == 0
    lum_in, lum_out = d.mean(-1)[inside].mean(), d.mean(-1)[outside].mean()
    assert abs(lum_in - lum_out) < 0.25 * abs(burnt.diffuse.mean(-1)[inside].mean() - lum_out)
    # No colour the base colour did not have at that place (the per-channel subtraction: 9.5 CIELAB units on
    # average, 8 % of the area above the visible threshold, 2 % of the blue channel at 0), no channel taken to 0,
    # each pixel's hue kept.
    colour = foreign_colour(d, burnt.diffuse)
    assert colour["foreign_colour"] < 1.0 and colour["foreign_colour_area"] == 0.0
    assert (d > 0).all()
    np.testing.assert_allclose(d[..., 2] * burnt.diffuse[..., 0], d[..., 0] * burnt.diffuse[..., 2], rtol=1e-4,
                               atol=1e-7)

