"""The named starting settings of a prior run (trainer/prior/presets.py)."""

import json

import pytest

from svbrdf.trainer.prior import PriorConfig, prior_preset

pytestmark = pytest.mark.usefixtures("one_thread")


def test_v1_preset_is_the_default_and_v2_changes_only_what_it_names(tiny):
    assert prior_preset("v1") == PriorConfig()
    v1, v2 = PriorConfig(), prior_preset("v2")
    assert (v1.losses.render_views, v1.losses.grad, v1.materials.batched, v1.optim.bf16, v1.monitor.log_every,
            v1.monitor.compact_checkpoint) == (0, 0.0, False, False, 1, False)
    assert v2.generator.arch == "unet" and v2.materials.batched and v2.monitor.compact_checkpoint
    assert v2.losses.render_views > 0
    assert PriorConfig.from_dict(json.loads(json.dumps(v2.to_dict()))) == v2
    with pytest.raises(ValueError, match="unknown prior preset"):
        prior_preset("v3")
    with pytest.raises(ValueError, match="grazing_deg"):
        tiny({"losses.grazing_deg": (70.0, 95.0)})


def test_the_v2_preset_has_the_values_it_had_as_flat_settings():
    """``PRIOR_PRESETS["v2"]`` as the flat ``to_dict()`` recorded it before the groups (every value that differs from
    the defaults), read through the flat names."""
    old = {"generator": {"width": 0.25, "decoder_blocks": 4, "train_encoder": True, "arch": "unet",
                         "height_activation": "linear", "height_scale": 32.0},
           "size": 256, "photo_size": 512, "batch": 32, "iters": 40000, "lr": 1e-3, "lr_min": 2e-5, "render_lights": 3,
           "render_views": 6, "grazing_share": 0.5, "lambda_grad": 1.0, "lambda_amount": 2.0,
           "amount_maps": ["roughness"], "amount_windows": [32], "batched": True, "bf16": True, "log_every": 50,
           "compact_checkpoint": True, "checkpoint_every": 2000, "eval_every": 500, "eval_batch": 32}
    assert prior_preset("v2") == PriorConfig.from_dict(old)
    assert prior_preset("v2") is not prior_preset("v2")  # a fresh config each time
