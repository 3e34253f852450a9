"""The ``--quality auto`` skip rule (svbrdf.runtime.quality.preview_check)."""

import numpy as np
import pytest

from svbrdf.runtime.quality import preview_check
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.quality.preview_check import SKIP_REFINE_BURN_IN, SKIP_REFINE_RMSE, check_preview
from svbrdf.runtime.core.render import ZHAO, render


def _preview(burn, size=16):
    normal = np.zeros((size, size, 3), np.float32)
    normal[..., 2] = 1.0
    return Maps(diffuse=np.full((size, size, 3), 0.5, np.float32), specular=np.full((size, size, 1), 0.04, np.float32),
                roughness=np.full((size, size, 1), 0.5, np.float32), normal=normal, meta={"burn_in": {"burn_in": burn}})


def test_a_preview_that_re_renders_the_photo_without_burn_in_is_kept():
    preview = _preview(0.1)
    photo = np.clip(render(preview, None, ZHAO), 0, 1)
    check = check_preview(preview, photo, ZHAO)
    assert check == {"skipped": True, "preview_input_rmse": pytest.approx(0.0, abs=1e-6),
                     "threshold": SKIP_REFINE_RMSE, "preview_burn_in": 0.1, "burn_in_threshold": SKIP_REFINE_BURN_IN}
    assert not check_preview(_preview(SKIP_REFINE_BURN_IN + 0.01), photo, ZHAO)["skipped"]  # burnt in
    assert not check_preview(preview, photo * 0.3, ZHAO)["skipped"]  # does not explain the photo


def test_thresholds_are_read_at_call_time(monkeypatch):
    preview = _preview(0.1)
    photo = np.clip(render(preview, None, ZHAO), 0, 1)
    monkeypatch.setattr(preview_check, "SKIP_REFINE_RMSE", -1.0)
    assert check_preview(preview, photo, ZHAO) == {**check_preview(preview, photo, ZHAO), "skipped": False}


def test_the_rule_reads_the_burn_in_of_the_networks_maps_first():
    preview = _preview(0.1)  # the delivered maps: flash trend removed, low burn-in
    photo = np.clip(render(preview, None, ZHAO), 0, 1)
    preview.meta["burn_in_model"] = {"burn_in": SKIP_REFINE_BURN_IN + 0.5}  # the network had baked the flash in
    check = check_preview(preview, photo, ZHAO)
    assert not check["skipped"] and check["preview_burn_in"] == SKIP_REFINE_BURN_IN + 0.5
