"""Closed-form and physical checks of the numpy renderer (svbrdf.runtime.core.render).

The expected values are computed here from first principles (pixel-centre geometry, Lambert's law, GGX
normalisation), not from the renderer's own helpers.
"""

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from svbrdf.runtime.core.maps import Maps, normal_gl_to_dx
from svbrdf.runtime.core.render import (ALPHA_MIN, DESCHAINTRE, ZHAO, RenderConfig, novel_lights, render, rerender_rmse,
                                   shade)


def _constant_maps(h, w, diffuse=(0.5, 0.5, 0.5), specular=0.0, roughness=0.5, normal=(0.0, 0.0, 1.0)):
    return Maps(
        diffuse=np.broadcast_to(np.asarray(diffuse, np.float32), (h, w, 3)).copy(),
        specular=np.full((h, w, 1), specular, np.float32),
        roughness=np.full((h, w, 1), roughness, np.float32),
        normal=np.broadcast_to(np.asarray(normal, np.float32), (h, w, 3)).copy(),
    )


def _random_maps(rng, h, w, max_tilt_deg=60.0):
    tilt = np.radians(rng.uniform(0, max_tilt_deg, (h, w)))
    az = rng.uniform(0, 2 * np.pi, (h, w))
    normal = np.stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)], -1)
    return Maps(
        diffuse=rng.uniform(0, 1, (h, w, 3)),
        specular=rng.uniform(0, 1, (h, w, 1)),
        roughness=rng.uniform(0.1, 1, (h, w, 1)),
        normal=normal,
    )


def _pixel_centres(h, w):
    """Pixel-centre coordinates of the scene convention: x in [-1, 1] across the width, +y up."""
    x = (2.0 * np.arange(w) + 1.0) / w - 1.0
    y = (h / w) * (1.0 - (2.0 * np.arange(h) + 1.0) / h)
    return np.meshgrid(x, y)  # (H, W) each


@pytest.mark.parametrize("falloff", [False, True])
@pytest.mark.parametrize("fov", [45.0, 66.0])
def test_lambertian_plane_closed_form(falloff, fov):
    h, w = 12, 20
    rho = np.array([0.2, 0.5, 0.9])
    intensity = 2.5
    cfg = RenderConfig(fov_deg=fov, intensity=intensity, falloff=falloff, fresnel="none")
    img = render(_constant_maps(h, w, diffuse=rho, specular=0.0), None, cfg)

    d = 1.0 / math.tan(math.radians(fov) / 2.0)
    x, y = _pixel_centres(h, w)
    r2 = x * x + y * y + d * d  # squared distance pixel -> co-located flash
    cos_theta = d / np.sqrt(r2)  # angle between the plane normal (0,0,1) and the direction to the flash
    expected = rho / math.pi * intensity * cos_theta[..., None]
    if falloff:
        expected = expected * (d * d / r2)[..., None]  # normalised so the centre of the photo is unchanged
    np.testing.assert_allclose(img, expected, rtol=1e-6)


def test_diffuse_conservation_scales_diffuse_by_one_minus_specular():
    h, w, rho_s = 6, 8, 0.3
    cfg = DESCHAINTRE.replace(fresnel="none")
    lit = render(_constant_maps(h, w, diffuse=(0.6, 0.6, 0.6), specular=rho_s), None, cfg)
    spec_only = render(_constant_maps(h, w, diffuse=(0.0, 0.0, 0.0), specular=rho_s), None, cfg)
    d = cfg.camera_distance
    x, y = _pixel_centres(h, w)
    expected = 0.6 * (1 - rho_s) / math.pi * cfg.intensity * (d / np.sqrt(x * x + y * y + d * d))
    np.testing.assert_allclose((lit - spec_only)[..., 0], expected, rtol=1e-4)


@pytest.mark.parametrize("geometry", ["schlick", "smith"])
def test_specular_peak_at_centre_closed_form_and_monotone(geometry):
    # At the centre pixel n = v = l = h, so D = 1 / (pi alpha^2), G = 1 and the peak is I F0 / (4 pi alpha^2).
    cfg = ZHAO.replace(fresnel="none", geometry=geometry)
    rough = np.linspace(0.05, 1.0, 40)
    peaks = []
    for r in rough:
        img = render(_constant_maps(3, 3, diffuse=(0, 0, 0), specular=0.5, roughness=r), None, cfg)
        peaks.append(img[1, 1, 0])
    peaks = np.array(peaks)
    alpha = np.maximum(rough ** 2, ALPHA_MIN)
    # rtol: in float32, 1 - (n.h)^2 (1 - alpha^2) cancels badly for alpha < 0.01 (0.3 % at r = 0.05).
    np.testing.assert_allclose(peaks, cfg.intensity * 0.5 / (4 * np.pi * alpha ** 2), rtol=5e-3)
    assert np.all(np.diff(peaks) < 0)


def _directional_albedo(theta_v_deg, roughness, geometry="smith"):
    """Integral over the hemisphere of f_spec(v, l) cos(theta_l) dl (F = 1), by the midpoint rule.

    The integrand is symmetric in phi about the plane of v, so phi runs over [0, pi] and is doubled.
    The grid is fine enough to resolve the lobe (width ~ 2 alpha in l): about 40 steps across it.
    """
    alpha = roughness ** 2
    n_theta = int(min(4000, max(400, 80 / alpha)))
    n_phi = 2 * n_theta
    dth, dph = (np.pi / 2) / n_theta, np.pi / n_phi
    phi = (np.arange(n_phi) + 0.5) * dph
    tv = math.radians(theta_v_deg)
    v = (math.sin(tv), 0.0, math.cos(tv))
    n = (0.0, 0.0, 1.0)
    cfg = RenderConfig(intensity=1.0, fresnel="none", geometry=geometry)
    total = 0.0
    for chunk in np.array_split((np.arange(n_theta) + 0.5) * dth, max(1, n_theta // 200)):
        th = chunk[:, None]
        lx, ly, lz = np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th) * np.ones_like(phi)
        # shade() returns I f cos(theta_l) with I = 1: exactly the integrand.
        _, f_cos = shade(n, v, (lx, ly, lz), np.float64(1.0), np.float64(roughness), cfg)
        total += np.sum(f_cos * np.sin(th)) * dth * dph
    return 2.0 * total


@pytest.mark.parametrize("theta_v", [0.0, 30.0, 60.0])
def test_specular_lobe_energy_at_most_one_and_near_one_when_smooth(theta_v):
    albedo = {r: _directional_albedo(theta_v, r) for r in (0.2, 0.5, 0.8, 1.0)}
    for r, e in albedo.items():
        assert e <= 1.0 + 2e-3, (r, e)
    assert albedo[0.2] > 0.97, albedo  # smooth GGX + Smith loses almost nothing to masking
    assert albedo[1.0] < albedo[0.2]  # single scattering loses energy as the surface gets rougher
    if theta_v == 0.0:
        # alpha = 1: D = 1/pi and G1(x) = 2x/(1+x), so E = (1/4pi) int 2cos/(1+cos) dw = 1 - ln 2.
        assert albedo[1.0] == pytest.approx(1.0 - math.log(2.0), abs=2e-3)


_unit_hemisphere = st.tuples(st.floats(0.0, 80.0), st.floats(0.0, 360.0))


def _direction(tilt_az):
    t, a = map(math.radians, tilt_az)
    return np.array([math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)])


@settings(max_examples=50, deadline=None)
@given(n=_unit_hemisphere, v=_unit_hemisphere, l=_unit_hemisphere, spec=st.floats(0, 1), rough=st.floats(0.1, 1),
       geometry=st.sampled_from(["schlick", "smith"]), fresnel=st.sampled_from(["schlick", "none"]))
def test_reciprocity(n, v, l, spec, rough, geometry, fresnel):
    n, v, l = _direction(n), _direction(v), _direction(l)
    assume(n @ v > 0.05 and n @ l > 0.05)  # away from the cosine clamps
    cfg = RenderConfig(geometry=geometry, fresnel=fresnel)
    dw_a, sp_a = shade(n, v, l, spec, rough, cfg)
    dw_b, sp_b = shade(n, l, v, spec, rough, cfg)
    # shade() returns I f (n.l): divide the cosine out to compare the BRDF values f(v, l) and f(l, v).
    # atol: a subnormal specular (hypothesis draws spec = 5e-324) rounds to 0 one way and not the other
    np.testing.assert_allclose(sp_a / (n @ l), sp_b / (n @ v), rtol=1e-9, atol=1e-300)
    np.testing.assert_allclose(dw_a / (n @ l), dw_b / (n @ v), rtol=1e-9, atol=1e-300)


def test_gl_dx_flip_mirrors_the_image_with_the_mirrored_light():
    rng = np.random.default_rng(3)
    maps = _random_maps(rng, 8, 10)
    light = (0.3, 0.4, 1.7)
    img = render(maps, light, ZHAO)
    # The same material seen upside down: rows reversed and, in the image frame, y of every normal negated,
    # which is exactly the GL <-> DX conversion. Lit by the mirrored light it must give the mirrored image.
    mirrored = Maps(diffuse=maps.diffuse[::-1], specular=maps.specular[::-1], roughness=maps.roughness[::-1],
                    normal=normal_gl_to_dx(maps.normal[::-1]))
    np.testing.assert_allclose(render(mirrored, (0.3, -0.4, 1.7), ZHAO), img[::-1], rtol=1e-5, atol=1e-6)
    # Without the normal conversion the mirror does not hold: the test is sensitive to the y convention.
    wrong = Maps(diffuse=mirrored.diffuse, specular=mirrored.specular, roughness=mirrored.roughness,
                 normal=maps.normal[::-1])
    assert np.abs(render(wrong, (0.3, -0.4, 1.7), ZHAO) - img[::-1]).max() > 1e-2


def test_tile_render_matches_crop_of_full_render():
    rng = np.random.default_rng(5)
    maps = _random_maps(rng, 16, 16)
    full = render(maps, None, ZHAO)
    tile = render(maps.crop(4, 8, 6, 5), None, ZHAO, full_size=(16, 16), offset=(4, 8))
    np.testing.assert_allclose(tile, full[4:10, 8:13], rtol=1e-6)


def test_extreme_inputs_stay_finite():
    # Roughness 0 (alpha clamped), black maps, zero normals, normals 89 deg from vertical, huge intensity.
    h, w = 5, 5
    tilt = math.radians(89.0)
    normals = [(0.0, 0.0, 0.0), (math.sin(tilt), 0.0, math.cos(tilt)), (0.0, -math.sin(tilt), math.cos(tilt))]
    for normal in normals:
        for r in (0.0, 1.0):
            for cfg in (ZHAO.replace(intensity=1e4), DESCHAINTRE.replace(intensity=1e4, falloff=True)):
                maps = _constant_maps(h, w, diffuse=(0, 0, 0), specular=1.0, roughness=r, normal=normal)
                img = render(maps, None, cfg)
                assert np.all(np.isfinite(img)) and np.all(img >= 0)


def test_falloff_needs_distance():
    with pytest.raises(ValueError, match="falloff"):
        shade((0, 0, 1), (0, 0, 1), (0, 0, 1), 0.5, 0.5, ZHAO.replace(falloff=True))


def test_maps_normalised_on_the_fly():
    # shade() normalises n itself: a scaled normal renders exactly like the unit one.
    rng = np.random.default_rng(7)
    maps = _random_maps(rng, 6, 6)
    scaled = Maps(diffuse=maps.diffuse, specular=maps.specular, roughness=maps.roughness, normal=maps.normal * 0.7)
    np.testing.assert_allclose(render(scaled), render(maps), rtol=1e-4, atol=1e-6)


def test_render_refuses_a_subset_with_one_line():
    part = Maps(diffuse=np.full((8, 8, 3), 0.5, np.float32), specular=np.full((8, 8, 1), 0.04, np.float32),
                roughness=None, normal=None)
    with pytest.raises(ValueError, match="rendering needs the roughness, normal"):
        render(part)


def test_rerender_rmse_against_maps_and_photo():
    rng = np.random.default_rng(2)
    gt = _random_maps(rng, 16, 16)
    lights = [tuple(p) for p in novel_lights(ZHAO)] + [None]
    photo = np.clip(render(gt, None, ZHAO), 0, 1)
    assert rerender_rmse(gt, photo, [None]) == pytest.approx(0.0, abs=1e-6)
    assert rerender_rmse(gt, gt, lights) == pytest.approx(0.0, abs=1e-9)
    darker = Maps(**{**dict(gt.items()), "diffuse": gt.diffuse * 0.5})
    assert rerender_rmse(darker, gt, lights) > 0.02
    assert rerender_rmse(darker, photo, [None]) == pytest.approx(rerender_rmse(darker, gt, [None]), abs=1e-6)
    with pytest.raises(ValueError, match="no lights"):
        rerender_rmse(gt, gt, [])
    with pytest.raises(ValueError, match="size mismatch"):
        rerender_rmse(gt, photo[:8], [None])


