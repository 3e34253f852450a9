"""The per-photo pipeline: estimate(..., post=PostProcess), and the camera of its corrections (fov_deg). PhotoOptions,
process_photo and write_maps: tests/runtime/workflow/."""

import numpy as np
import pytest

pytest.importorskip("onnxruntime")
from svbrdf.runtime.inference.pipeline import estimate  # noqa: E402
from svbrdf.runtime.post import PostProcess  # noqa: E402


def test_the_default_post_is_what_estimate_did_without_it(session, small_flash_photo):
    photo = small_flash_photo()
    a, b = estimate(photo, session), estimate(photo, session, post=PostProcess())
    for name in a.names:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_without_corrections_estimate_returns_the_networks_maps(session, small_flash_photo):
    photo = small_flash_photo()
    bare = estimate(photo, session, post=PostProcess.off())
    assert bare.meta["even_lighting"] is None
    assert bare.meta["burn_in"] == bare.meta["burn_in_model"]
    assert "flash_trend" not in bare.meta and "uniform_specular" not in bare.meta
    raw = session.run(photo)
    np.testing.assert_allclose(bare.roughness[..., 0], raw[..., 4].clip(0, 1), atol=1e-6)
    shipped = estimate(photo, session)
    assert np.ptp(shipped.specular) == 0 and np.ptp(bare.specular) > 0  # one specular level only when asked
    one_off = estimate(photo, session, post=PostProcess(uniform_specular=False))
    assert np.ptp(one_off.specular) > 0 and "flash_trend" in one_off.meta


def test_estimate_models_the_flash_with_the_photos_camera(session):
    """``fov_deg`` is the camera of the corrections that model the flash (the highlight's shoulder, filled) and of
    the maps' render_config; without it, the session's."""
    from svbrdf.runtime.post import highlight_fill as hf

    n = 96
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float32)
    lobe = np.exp(-((yy - n / 2) ** 2 + (xx - n / 2) ** 2) / (2 * 10.0 ** 2))[..., None]
    photo = np.clip(0.25 + 0.6 * lobe + 0.01 * np.sin(xx / 2)[..., None], 0, 1).astype(np.float32) * [1, 0.9, 0.8]
    photo = photo.astype(np.float32)
    default, narrow = estimate(photo, session), estimate(photo, session, fov_deg=20.0)
    assert default.render_config.fov_deg == session.render_config.fov_deg and narrow.render_config.fov_deg == 20.0
    assert default.meta["highlight_fill"]["pixels"] == int(hf.highlight_mask(photo).sum())
    assert narrow.meta["highlight_fill"]["pixels"] == int(hf.highlight_mask(photo, fov_deg=20.0).sum())
    assert hf.highlight_mask(photo, fov_deg=20.0).sum() != hf.highlight_mask(photo).sum()
