"""The after-refine check that keeps the preview (svbrdf.runtime.quality.refine_check)."""

import numpy as np
import pytest

from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, render
from svbrdf.runtime.quality.burn_in import photo_burn_in
from svbrdf.runtime.quality.refine_check import KEEP_BURN_IN_MARGIN, KEEP_INPUT_GAIN, check_refine


def _maps(diffuse, size=64):
    normal = np.zeros((size, size, 3), np.float32)
    normal[..., 2] = 1.0
    d = np.broadcast_to(np.asarray(diffuse, np.float32), (size, size, 3)).copy() if np.ndim(diffuse) < 3 else diffuse
    return Maps(diffuse=d, specular=np.full((size, size, 1), 0.04, np.float32),
                roughness=np.full((size, size, 1), 0.5, np.float32), normal=normal)


def _burnt(maps, gain=0.4):
    """``maps`` with the flash painted into the base colour: a bright disc at the centre."""
    size = maps.shape[0]
    yy, xx = np.mgrid[:size, :size]
    disc = np.exp(-((yy - size / 2 + 0.5) ** 2 + (xx - size / 2 + 0.5) ** 2) / (2 * (0.1 * size) ** 2))
    return Maps(diffuse=np.clip(maps.diffuse + gain * disc[..., None], 0, 1).astype(np.float32),
                specular=maps.specular, roughness=maps.roughness, normal=maps.normal)


def test_a_refine_that_raises_the_burn_in_keeps_the_preview():
    rng = np.random.default_rng(0)
    truth = _maps(0.3 + 0.2 * rng.random((64, 64, 1)).repeat(3, -1).astype(np.float32))
    photo = np.clip(render(truth, None, ZHAO), 0, 1).astype(np.float32)
    refined = _burnt(truth)
    assert photo_burn_in(refined, photo)["burn_in"] > photo_burn_in(truth, photo)["burn_in"] + KEEP_BURN_IN_MARGIN
    check = check_refine(truth, refined, photo, ZHAO)
    assert check["kept_preview"].startswith("the refine raised the burn-in")
    assert check["refined_burn_in"] > check["preview_burn_in"]


def test_a_refine_that_explains_the_photo_better_without_burn_in_is_kept():
    truth, preview = _maps(0.5), _maps(0.3)  # the preview's base colour too dark; both flat, no burn-in
    photo = np.clip(render(truth, None, ZHAO), 0, 1).astype(np.float32)
    check = check_refine(preview, truth, photo, ZHAO)
    assert check["kept_preview"] is None
    assert check["refined_input_rmse"] < check["preview_input_rmse"] - KEEP_INPUT_GAIN
    assert check["burn_in_margin"] == KEEP_BURN_IN_MARGIN and check["input_gain"] == KEEP_INPUT_GAIN


def test_a_refine_that_does_not_lower_the_input_error_keeps_the_preview():
    truth = _maps(0.5)
    photo = np.clip(render(truth, None, ZHAO), 0, 1).astype(np.float32)
    check = check_refine(truth, _maps(0.3), photo, ZHAO)  # the refine moved away from the photo
    assert check["kept_preview"].startswith("the refine did not lower the input re-render error")


def test_size_mismatch_is_one_error():
    with pytest.raises(ValueError, match="differ in size"):
        check_refine(_maps(0.5, 32), _maps(0.5, 64), np.zeros((32, 32, 3), np.float32), ZHAO)
