"""Highlight fill (svbrdf.runtime.post.highlight_fill): periodic texture sets with a burnt-in disc under a clipped
highlight, whose truth is known, and photos whose clipped pixels are placed by hand."""

import math

import numpy as np
import pytest

from svbrdf.runtime.post import highlight_fill as hf
from svbrdf.runtime.quality.burn_in import burn_in_scores
from svbrdf.runtime.post.flash_trend import postprocess
from svbrdf.runtime.core.maps import Maps

N = 128
PERIOD = 16


def _periodic(n=N, period=PERIOD, seed=0):
    """A texture set that repeats every ``period`` px (a random tile): a copy from a whole number of periods away
    is the truth itself."""
    rng = np.random.default_rng(seed)
    reps = n // period

    def tile(c, lo, hi):
        return np.tile(rng.uniform(lo, hi, (period, period, c)), (reps, reps, 1)).astype(np.float32)

    normal = np.concatenate([tile(2, -0.3, 0.3), np.ones((n, n, 1), np.float32)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return Maps(diffuse=tile(3, 0.1, 0.7), specular=tile(1, 0.02, 0.08), roughness=tile(1, 0.2, 0.8),
                normal=normal)


def _disc(n, centre, radius):
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    return np.hypot(yy - centre[0], xx - centre[1]) <= radius


def _photo(n, clipped):
    photo = np.full((n, n, 3), 0.3, np.float32)
    photo[clipped] = 1.0
    return photo


def _burnt(maps, region):
    """The maps with what estimators leave under a clipped highlight: a dark base colour, a low roughness."""
    d = maps.diffuse.copy()
    r = maps.roughness.copy()
    d[region] = 0.02
    r[region] = 0.05
    return maps._with({**dict(maps.items()), "diffuse": d, "roughness": r})


@pytest.mark.parametrize("patches", [False, True])
def test_a_burnt_disc_in_a_periodic_texture_is_restored(patches):
    truth = _periodic()
    centre = (60.0, 70.0)
    clipped = _disc(N, centre, 5)
    mask = hf.highlight_mask(_photo(N, clipped), centre)
    burnt = _burnt(truth, mask)
    filled = hf.fill_highlight(burnt, _photo(N, clipped), centre=centre, patches=patches)
    rec = filled.meta["highlight_fill"]
    assert rec["filled"] and rec["reason"] is None
    if rec["offset"] is not None:  # one copy (else patches, each from a whole number of periods away)
        assert rec["offset"][0] % PERIOD == 0 and rec["offset"][1] % PERIOD == 0, rec["offset"]
    for name in hf.FILL_MAPS:
        err = np.abs(getattr(filled, name) - getattr(truth, name)).max()
        assert err < 1e-3, (name, err)
    spec = burnt.specular.copy()
    spec[mask] = 0.5  # the specular is kept: the highlight is where the photo shows its level
    kept = hf.fill_highlight(burnt._with({**dict(burnt.items()), "specular": spec}), mask=mask)
    np.testing.assert_array_equal(kept.specular, spec)
    assert burn_in_scores(burnt, centre)["burn_in"] > 0.8
    assert burn_in_scores(filled, centre)["burn_in"] < 0.2


def test_the_fill_copies_texture_and_joins_a_level_step():
    """Off the period grid (no exact copy exists) the region still gets texture, not a flat colour, and the
    edge of the region carries no step larger than the texture's own neighbour differences."""
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 1, (N, N, 1)).astype(np.float32)
    for _ in range(2):
        a = (a + np.roll(a, 1, 0) + np.roll(a, 1, 1)) / 3
    ramp = np.linspace(0.0, 0.3, N, dtype=np.float32)[None, :, None]  # a slow level change across the map
    maps = Maps(roughness=np.clip(0.3 + a + ramp, 0, 1))
    centre = (64.0, 64.0)
    mask = _disc(N, centre, 14)
    burnt = maps._with({"roughness": np.where(mask[..., None], np.float32(0.05), maps.roughness)})
    filled = hf.fill_highlight(burnt, mask=mask)
    assert filled.meta["highlight_fill"]["filled"]
    inside = filled.roughness[mask, 0]
    assert inside.std() > 0.5 * maps.roughness[mask, 0].std()
    assert abs(inside.mean() - maps.roughness[mask, 0].mean()) < 0.05
    natural = np.abs(np.diff(maps.roughness[..., 0], axis=1)).mean()
    edge = mask[:, 1:] != mask[:, :-1]
    step = np.abs(np.diff(filled.roughness[..., 0], axis=1))[edge].mean()
    assert step < 1.5 * natural, (step, natural)


def test_the_mask_is_the_highlight_grown_and_not_the_glints_or_white_flecks():
    centre = (64.0, 64.0)
    clipped = _disc(N, centre, 6)
    clipped[10:12, 10:12] = True  # a white fleck far from the highlight
    clipped[64, 100] = True  # a glint 36 px away, not touching the highlight
    mask = hf.highlight_mask(_photo(N, clipped), centre)
    assert mask[_disc(N, centre, 6)].all()
    assert not mask[10:12, 10:12].any() and not mask[64, 100]
    r_eq = math.sqrt(_disc(N, centre, 6).sum() / math.pi)
    grown = r_eq * (1 + hf.GROW)
    assert mask[_disc(N, centre, grown - 1.5)].all()
    assert not mask[~_disc(N, centre, grown + 1.5)].any()


def test_nothing_is_filled_without_a_highlight_or_without_room():
    maps = _periodic()
    out = hf.fill_highlight(maps, _photo(N, np.zeros((N, N), bool)))
    assert not out.meta["highlight_fill"]["filled"]
    assert out.meta["highlight_fill"]["reason"] == "no clipped highlight and no shoulder"
    np.testing.assert_array_equal(out.diffuse, maps.diffuse)
    big = _disc(N, (64.0, 64.0), 40)
    out = hf.fill_highlight(maps, mask=big)
    assert not out.meta["highlight_fill"]["filled"] and "covers" in out.meta["highlight_fill"]["reason"]
    with pytest.raises(ValueError, match="mask of"):
        hf.fill_highlight(maps, mask=np.zeros((N, N + 1), bool))
    with pytest.raises(ValueError, match="photo or a mask"):
        hf.fill_highlight(maps)


def test_postprocess_fills_before_the_trend_removal():
    truth = _periodic()
    centre = (60.0, 70.0)
    photo = _photo(N, _disc(N, centre, 5))
    # The photo's colours are the material's (the trend removal takes out the base colour's casts against them).
    photo = np.where(photo < 1, 0.3 * truth.diffuse / truth.diffuse.mean(), photo).astype(np.float32)
    burnt = _burnt(truth, hf.highlight_mask(photo, centre))
    out = postprocess(burnt, photo, flash_trend=True, specular_level=False, highlight_fill=True)
    assert out.meta["highlight_fill"]["filled"]
    # The filled disc leaves no radial trend to remove, so the result is the truth up to a small level change.
    assert np.abs(out.diffuse - truth.diffuse).max() < 0.02
    assert out.meta["burn_in"]["burn_in"] < out.meta["burn_in_model"]["burn_in"]
    plain = postprocess(burnt, photo, flash_trend=True, specular_level=False)
    assert "highlight_fill" not in plain.meta


@pytest.mark.parametrize("h,w", [(8, 8), (9, 13), (31, 200), (300, 17)])
@pytest.mark.parametrize("clip", ["pixel", "corner", "border", "all", "two"])
def test_odd_sizes_and_highlights_give_valid_maps_or_nothing(h, w, clip):
    rng = np.random.default_rng(h * w)
    normal = np.concatenate([rng.uniform(-0.2, 0.2, (h, w, 2)), np.ones((h, w, 1))], -1)
    maps = Maps(diffuse=rng.uniform(0, 1, (h, w, 3)).astype(np.float32),
                specular=rng.uniform(0, 0.1, (h, w, 1)).astype(np.float32),
                roughness=rng.uniform(0, 1, (h, w, 1)).astype(np.float32),
                normal=(normal / np.linalg.norm(normal, axis=-1, keepdims=True)).astype(np.float32))
    photo = np.full((h, w, 3), 0.3, np.float32)
    if clip == "pixel":
        photo[h // 2, w // 2] = 1
    elif clip == "corner":
        photo[:3, :3] = 1
    elif clip == "border":
        photo[:, :2] = 1
    elif clip == "all":
        photo[:] = 1
    else:
        photo[h // 2, w // 4] = photo[h // 2, 3 * w // 4] = 1
    out = hf.fill_highlight(maps, photo)
    rec = out.meta["highlight_fill"]
    assert rec["filled"] == (rec["reason"] is None)
    for name, arr in out.items():
        assert arr.shape == getattr(maps, name).shape and np.isfinite(arr).all()
    np.testing.assert_allclose(np.linalg.norm(out.normal, axis=-1), 1, atol=1e-5)
    if not rec["filled"]:
        for name, arr in out.items():
            np.testing.assert_array_equal(arr, getattr(maps, name))
    if clip == "all":
        assert not rec["filled"] and "covers" in rec["reason"]


def test_a_subset_of_maps():
    truth = _periodic()
    centre = (60.0, 70.0)
    photo = _photo(N, _disc(N, centre, 5))
    burnt = _burnt(truth, hf.highlight_mask(photo, centre))
    rough = hf.fill_highlight(burnt.subset("roughness"), photo, centre=centre)
    assert rough.names == ("roughness",) and rough.meta["highlight_fill"]["filled"]
    assert np.abs(rough.roughness - truth.roughness).max() < 1e-3
    spec = hf.fill_highlight(burnt.subset("specular"), photo, centre=centre)
    assert not spec.meta["highlight_fill"]["filled"] and spec.meta["highlight_fill"]["reason"] == "no map to fill"


def test_a_large_region_is_filled_patch_by_patch_from_whole_periods():
    n = 256
    truth = _periodic(n)
    centre = (100.0, 120.0)
    photo = _photo(n, _disc(n, centre, 14))
    mask = hf.highlight_mask(photo, centre)
    burnt = _burnt(truth, mask)
    filled = hf.fill_highlight(burnt, photo, centre=centre)
    rec = filled.meta["highlight_fill"]
    assert rec["filled"] and rec["offset"] is None and rec["patches"] > 1, rec
    for name in hf.FILL_MAPS:  # every patch from a whole number of periods away: the truth itself
        assert np.abs(getattr(filled, name) - getattr(truth, name)).max() < 1e-3, name


def _flash_photo(n, lobe_amp, lobe_sigma, seed=0):
    """A matte textured plane under the shoulder's flash (the one renderer), plus a round highlight lobe of
    ``lobe_amp`` (linear) and ``lobe_sigma`` px at the image centre."""
    from svbrdf.runtime.core.render import render

    rng = np.random.default_rng(seed)
    diffuse = np.repeat(rng.uniform(0.15, 0.35, (n, n, 1)), 3, axis=-1).astype(np.float32)
    normal = np.zeros((n, n, 3), np.float32)
    normal[..., 2] = 1.0
    matte = Maps(diffuse=diffuse, specular=np.zeros((n, n, 1), np.float32),
                 roughness=np.ones((n, n, 1), np.float32), normal=normal)
    photo = render(matte, config=hf.SHOULDER_GEOMETRY)
    photo = photo / photo.max() * 0.15
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    lobe = lobe_amp * np.exp(-0.5 * (np.hypot(yy - n / 2, xx - n / 2) / lobe_sigma) ** 2)
    return np.minimum(photo + lobe[..., None], 1.0).astype(np.float32)


def test_a_matte_photo_has_no_shoulder():
    photo = _flash_photo(N, 0.0, 1.0)
    assert not hf.shoulder_mask(photo, (N / 2, N / 2), hf.SHOULDER).any()
    assert not hf.highlight_mask(photo, (N / 2, N / 2)).any()


def test_the_shoulder_of_an_unclipped_highlight_is_the_region():
    photo = _flash_photo(N, 0.8, 8.0)  # peak 0.9: nothing clips
    centre = (N / 2, N / 2)
    assert not hf.highlight_mask(photo, centre, shoulder=False).any()
    mask = hf.highlight_mask(photo, centre)
    assert mask[_disc(N, centre, 6)].all()  # where the lobe is several times the matte level
    assert not mask[~_disc(N, centre, 30)].any()  # where it has faded
    np.testing.assert_array_equal(mask, hf.shoulder_mask(photo, centre, hf.SHOULDER))
    # the region is filled: a burnt disc there is restored from the periodic texture around it
    truth = _periodic()
    out = hf.fill_highlight(_burnt(truth, mask), photo, centre=centre)
    assert out.meta["highlight_fill"]["filled"]
    assert np.abs(out.roughness - truth.roughness)[mask].mean() < 0.1


def test_a_shoulder_too_large_leaves_the_clipped_highlight(monkeypatch):
    centre = (N / 2, N / 2)
    photo = _flash_photo(N, 0.8, 8.0)
    photo[_disc(N, centre, 2.5)] = 1.0  # a small clipped core on top of the shoulder
    core = hf.highlight_mask(photo, centre, shoulder=False)
    shoulder = hf.shoulder_mask(photo, centre, hf.SHOULDER)
    assert 0 < core.mean() < 0.01 < 0.02 < shoulder.mean()
    np.testing.assert_array_equal(hf.highlight_mask(photo, centre), core | shoulder)
    monkeypatch.setattr(hf, "MAX_SHARE", 0.02)  # the shoulder no longer fits: the clipped core alone
    np.testing.assert_array_equal(hf.highlight_mask(photo, centre), core)


def test_no_shoulder_when_it_is_switched_off(monkeypatch):
    photo = _flash_photo(N, 0.8, 8.0)
    centre = (N / 2, N / 2)
    assert hf.highlight_mask(photo, centre).any()
    monkeypatch.setattr(hf, "SHOULDER", None)
    assert not hf.highlight_mask(photo, centre).any()


def test_the_offset_search_cost_is_the_weighted_ssd_at_every_offset():
    """_Source.ssd, its channels' correlations added in the frequency domain, against the sum written out for
    every periodic offset."""
    rng = np.random.default_rng(2)
    h, w = 12, 10
    xs = rng.uniform(0, 1, (h, w, 4))
    wts = np.array([0.5, 0.0, 2.0, 1.5])
    b = (rng.uniform(0, 1, (h, w)) > 0.6).astype(np.float64)
    target = rng.uniform(0, 1, (h, w, 4))
    src = hf._Source(xs, wts, np.zeros((h, w), bool))
    got = src.ssd(b, target)
    for oy in range(h):
        for ox in range(w):
            shifted = np.roll(xs, (-oy, -ox), axis=(0, 1))  # shifted[p] = xs[p + o]
            want = float(np.einsum("hw,hwc,c->", b, (target - shifted) ** 2, wts))
            assert got[oy, ox] == pytest.approx(want, rel=1e-9, abs=1e-9)


def _glossy_plane(fov: float, n: int = 128) -> np.ndarray:
    """A uniform glossy plane photographed by the flash camera of field of view ``fov`` (no clipping)."""
    from svbrdf.runtime.core.render import ZHAO, render

    flat = np.dstack([np.zeros((n, n, 2)), np.ones((n, n, 1))]).astype(np.float32)
    maps = Maps(np.full((n, n, 3), 0.4, np.float32), np.full((n, n, 1), 0.5, np.float32),
                np.full((n, n, 1), 0.3, np.float32), flat)
    img = render(maps, config=ZHAO.replace(falloff=True, fov_deg=fov))
    return (img / img.max() * 0.9).astype(np.float32)


def test_the_shoulder_is_judged_with_the_photos_own_camera():
    """The matte fall-off the shoulder is measured against is the photo's: a narrow camera's flat fall-off read with
    the default 66° camera hides part of the highlight's shoulder, a wide camera's steep one shows too much."""
    n = 128
    narrow, wide = _glossy_plane(20.0, n), _glossy_plane(90.0, n)
    centre = (n / 2, n / 2)
    own_narrow = hf.shoulder_mask(narrow, centre, hf.SHOULDER, 20.0).mean()
    own_wide = hf.shoulder_mask(wide, centre, hf.SHOULDER, 90.0).mean()
    assert own_narrow > 1.2 * hf.shoulder_mask(narrow, centre, hf.SHOULDER).mean() > 0
    assert own_wide < 0.8 * hf.shoulder_mask(wide, centre, hf.SHOULDER).mean()
    assert hf.shoulder_mask(narrow, centre, hf.SHOULDER, 66.0).mean() == hf.shoulder_mask(narrow, centre, hf.SHOULDER).mean()


def test_the_fill_takes_the_camera_the_maps_carry():
    from svbrdf.runtime.core.render import ZHAO

    n = 128
    photo = _glossy_plane(20.0, n)
    rng = np.random.default_rng(0)
    flat = np.dstack([np.zeros((n, n, 2)), np.ones((n, n, 1))]).astype(np.float32)
    base = Maps(rng.uniform(0.2, 0.6, (n, n, 3)).astype(np.float32), np.full((n, n, 1), 0.5, np.float32),
                rng.uniform(0.2, 0.6, (n, n, 1)).astype(np.float32), flat)
    own = hf.fill_highlight(Maps(*[base.diffuse, base.specular, base.roughness, base.normal],
                                 render_config=ZHAO.replace(fov_deg=20.0)), photo)
    default = hf.fill_highlight(base, photo)
    assert own.meta["highlight_fill"]["pixels"] > default.meta["highlight_fill"]["pixels"]
    assert own.meta["highlight_fill"]["pixels"] == int(hf.highlight_mask(photo, fov_deg=20.0).sum())
