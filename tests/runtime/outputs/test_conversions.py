"""The Principled BSDF conversions (Blender): base colour and Specular = F0 / 0.08, and their inverses.

The other conversions are tested with their targets in test_targets.py; that Cycles renders these inputs as our
renderer renders our maps is tests/runtime/outputs/test_blender.py."""

import numpy as np
import pytest

from svbrdf.runtime.core.render import DESCHAINTRE, ZHAO
from svbrdf.runtime.outputs import conversions as cv


@pytest.fixture
def maps():
    rng = np.random.default_rng(3)
    return rng.uniform(0.02, 0.9, (16, 12, 3)).astype(np.float32), rng.uniform(0.0, 0.7, (16, 12, 1)).astype(
        np.float32)


def test_principled_f0_per_specular_is_the_manuals_eight_percent():
    assert cv.PRINCIPLED_F0_PER_SPECULAR == 0.08
    # Specular 0.5 (Blender's default) is the 4 % of a dielectric of index 1.5
    assert cv.from_principled_specular(np.float32(0.5)) == pytest.approx(float(cv.ior_to_f0(1.5)), rel=1e-6)


@pytest.mark.parametrize("config", [ZHAO, DESCHAINTRE])
def test_principled_base_is_our_weighted_diffuse_and_round_trips(maps, config):
    diffuse, specular = maps
    base = cv.to_principled_base(diffuse, specular, config)
    w_d = (1.0 - specular) if config.diffuse_conservation else 1.0
    # Principled 2.8-3.x: diffuse lobe base / pi, not weighted by the Fresnel term; ours w_d rho_d / pi
    np.testing.assert_allclose(base, diffuse * w_d, rtol=1e-6)
    np.testing.assert_allclose(cv.from_principled_base(base, specular, config), diffuse, rtol=1e-5, atol=1e-6)
    assert base.dtype == np.float32 and base.shape == diffuse.shape


def test_principled_base_is_not_the_weighted_base_of_the_khronos_targets(maps):
    diffuse, specular = maps  # a mix-up would brighten the base colour by 1 / (1 - F0)
    assert np.abs(cv.to_principled_base(diffuse, specular) - cv.to_weighted_base(diffuse, specular)).max() > 0.05


def test_principled_specular_scale_only_above_eight_percent(maps):
    _, specular = maps
    scale, tex = cv.to_principled_specular(specular)
    assert scale == pytest.approx(float(specular.max()) / 0.08, rel=1e-6) and scale > 1
    assert 0.0 <= tex.min() and tex.max() == pytest.approx(1.0)
    np.testing.assert_allclose(cv.from_principled_specular(tex, scale), specular, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(scale * tex, specular / 0.08, rtol=1e-5)

    low = np.clip(specular, 0.0, 0.06)  # every F0 within 0.08: the texture is the Specular input itself
    scale, tex = cv.to_principled_specular(low)
    assert scale == 1.0
    np.testing.assert_allclose(tex, low / 0.08, rtol=1e-6)


def test_principled_specular_of_a_black_map():
    scale, tex = cv.to_principled_specular(np.zeros((4, 4, 1), np.float32))
    assert scale == 1.0 and not tex.any()
