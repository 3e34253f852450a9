"""The field of view from the flash's fall-off (:mod:`svbrdf.runtime.core.falloff`): planes rendered by the project's
renderer (fall-off on) at known fields of view, textured; a highlight that disturbs the fit; a flat photo; a flash
out of frame; the time it takes."""

import math

import numpy as np
import pytest

from svbrdf.runtime.core.falloff import estimate_fov
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, physical_config, render


def _plane(fov, n=256, specular=0.0, roughness=0.3, texture=0.3, light=None, seed=0):
    """A flat, textured (8 px blocks, log-normal albedo of spread ``texture``) coloured plane, rendered with the
    renderer's physics at ``fov`` (the flash above the centre, or at ``light``), exposed so its top is 0.9."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(0.0, 1.0, (n // 8, n // 8, 1)).repeat(8, 0).repeat(8, 1)
    diffuse = np.clip(np.array([0.45, 0.3, 0.2]) * np.exp(texture * noise), 0, 1).astype(np.float32)
    maps = Maps(diffuse=diffuse, specular=np.full((n, n, 1), specular, np.float32),
                roughness=np.full((n, n, 1), roughness, np.float32),
                normal=np.dstack([np.zeros((n, n, 2)), np.ones((n, n, 1))]).astype(np.float32))
    img = render(maps, light, physical_config(ZHAO.replace(fov_deg=fov)))
    return np.clip(img / np.percentile(img, 99.5) * 0.9, 0.0, 1.0).astype(np.float32)


@pytest.mark.parametrize("fov", [20.0, 45.0, 70.0])
def test_a_textured_diffuse_plane_gives_its_field_of_view(fov):
    est = estimate_fov(_plane(fov))
    assert est.fov_deg == pytest.approx(fov, rel=0.08)
    assert est.centre == pytest.approx((0.0, 0.0), abs=0.1)
    # a wide field of view is a strong fall-off: reliable; a narrow one is too faint against the texture to trust
    assert est.reliable == (fov == 70.0), est.reason
    assert est.reliable or est.reason


def test_a_broad_highlight_that_steepens_the_luminance_is_not_trusted():
    # at 20 deg a roughness-0.3 lobe covers the middle half of the photo: the luminance says a much wider camera
    est = estimate_fov(_plane(20.0, specular=0.04, roughness=0.3))
    assert not est.reliable and est.fov_deg > 40.0
    # at 70 deg the same material's highlight is small: the estimate holds
    est = estimate_fov(_plane(70.0, specular=0.04, roughness=0.3))
    assert est.reliable and est.fov_deg == pytest.approx(70.0, rel=0.1)


def test_a_photo_without_fall_off_is_unreliable_and_says_no_flash():
    flat = _plane(45.0)
    rng = np.random.default_rng(1)
    flat = np.clip(np.array([0.45, 0.3, 0.2]) * np.exp(0.3 * rng.normal(0, 1, (32, 32, 1))).repeat(8, 0).repeat(8, 1),
                   0, 1).astype(np.float32)
    est = estimate_fov(flat)
    assert not est.reliable and est.reason
    assert est.out_of_frame == "absent"


def test_a_flash_beside_the_photo_is_out_of_frame():
    d = 1.0 / math.tan(math.radians(22.5))
    est = estimate_fov(_plane(45.0, light=[2.5, 0.0, d]))
    assert est.out_of_frame == "out of frame"
    assert est.centre[0] > 1.5
    assert estimate_fov(_plane(45.0)).out_of_frame == ""


def test_clipped_and_tiny_photos():
    photo = _plane(70.0)
    clipped = np.clip(photo * 50.0, 0.0, 1.0)  # everything clipped: nothing to fit
    est = estimate_fov(clipped)
    assert not est.reliable and "too few" in est.reason
    with pytest.raises(ValueError, match="too small"):
        estimate_fov(photo[:1])  # one row: fewer than 2 cells a side


def test_a_non_square_photo_and_the_time_it_takes():
    photo = _plane(70.0, n=256)[32:224]  # 256 wide, 192 high: the width's field of view is unchanged
    est = estimate_fov(photo)
    assert est.fov_deg == pytest.approx(70.0, rel=0.08)
    assert est.seconds < 1.0  # about 0.05-0.1 s at 256 px on one shared core
