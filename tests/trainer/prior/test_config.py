"""The stage one's settings (trainer/prior/config.py): groups, one dotted name per setting, the flat names of earlier
records, validation in one place."""

import dataclasses
import json
from pathlib import Path

import pytest

from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer.config import parse_settings
from svbrdf.trainer.prior import PriorConfig, prior_preset
from svbrdf.trainer.prior.config import FLAT_NAMES, GROUPS, override, setting_name
from svbrdf.trainer.prior.recipes import RECIPES

pytestmark = pytest.mark.usefixtures("one_thread")

SHIPPED = Path(__file__).resolve().parents[3] / "models" / "svbrdf_prior_v2.pt"


def _old_flat(config: PriorConfig) -> dict:
    """``config`` as the flat ``to_dict()`` of the records written before the groups (inverse of FLAT_NAMES)."""
    back = {dotted: flat for flat, dotted in FLAT_NAMES.items()}
    return {("generator" if k == "generator" else back[k]): v for k, v in config.flat_dict().items()
            if k != "finetune_preset"} | {"finetune_preset": config.finetune_preset}


def test_config_round_trip_and_validation(tiny):
    c = tiny({"materials.families": None})
    assert PriorConfig.from_dict(json.loads(json.dumps(c.to_dict()))) == c
    with pytest.raises(ValueError, match="photo_size"):
        tiny({"photos.photo_size": 16})
    with pytest.raises(ValueError, match="multiple"):
        tiny({"photos.size": 34})
    with pytest.raises(ValueError, match="unknown families"):
        tiny({"materials.families": ("marshmallow",)})
    with pytest.raises(ValueError, match="unknown prior settings: nonsense"):
        PriorConfig.from_dict({"nonsense": 1})


def test_every_setting_has_one_dotted_name_and_at_most_one_flat_one():
    cfg = PriorConfig()
    d = cfg.to_dict()
    assert list(d) == ["generator", "finetune_preset", *GROUPS]
    flat = cfg.flat_dict()
    dotted = {k for k in flat if "." in k}
    assert dotted == {f"{g}.{f.name}" for g, group in GROUPS.items() for f in dataclasses.fields(group)}
    assert len(dotted) == 40 and set(flat) - dotted == {"generator", "finetune_preset"}
    # the flat names of earlier records: one per setting of a group, and the recipes' height_activation
    assert set(FLAT_NAMES.values()) == dotted | {"generator.height_activation"}
    assert len(FLAT_NAMES) == len(set(FLAT_NAMES.values()))
    assert setting_name("lambda_render") == "losses.render" and setting_name("material_reuse") == "materials.reuse"
    assert setting_name("optim.lr") == "optim.lr"
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.optim.lr = 1.0  # a group is changed through override, never in place


@pytest.mark.parametrize("name", ["v1", "v2"])
def test_round_trips_nested_dotted_and_old_flat(name):
    cfg = prior_preset(name)
    nested = json.loads(json.dumps(cfg.to_dict()))
    dotted = json.loads(json.dumps(cfg.flat_dict()))
    old = json.loads(json.dumps(_old_flat(cfg)))
    assert all("." not in k and not isinstance(v, dict) or k in ("generator", "camera") for k, v in old.items())
    for form in (nested, dotted, old):
        assert PriorConfig.from_dict(form) == cfg
    assert PriorConfig.from_dict(old).to_dict() == nested and PriorConfig.from_dict(nested).flat_dict() == dotted
    # a mix, later entries over earlier ones
    assert PriorConfig.from_dict({**old, "optim.lr": 0.25, "photos": {"size": 64}}).flat_dict() == {
        **dotted, "optim.lr": 0.25, "photos.size": 64}


def test_the_packaged_checkpoint_records_flat_settings_and_loads_to_the_same_config():
    if not SHIPPED.exists():
        pytest.skip("no packaged checkpoint")
    recorded = ckpt_io.load_checkpoint(SHIPPED)["prior_config"]
    assert "lambda_slope" in recorded and "losses" not in recorded  # the flat form
    cfg = PriorConfig.from_dict(recorded)
    # every recorded value, read by its dotted name
    flat = cfg.flat_dict()
    for key, value in recorded.items():
        assert flat[setting_name(key)] == value, key
    # settings added since (not recorded) take their defaults, which leave the stream as it was
    assert (cfg.materials.coarse_share, cfg.materials.stream, cfg.materials.print_share, cfg.photos.block_mean) == (
        0.0, "host", 0.0, 1)
    assert (cfg.optim.iters, cfg.losses.slope, cfg.optim.ema, cfg.materials.reuse) == (20000, 1.0, 0.995, 5)
    assert PriorConfig.from_dict(json.loads(json.dumps(cfg.to_dict()))) == cfg
    learned = {k: v for k, v in cfg.flat_dict().items() if not k.startswith("monitor.")}
    assert learned == {k: v for k, v in RECIPES["v2"].config_at(20000).flat_dict().items()
                       if not k.startswith("monitor.")}


def test_override_takes_dotted_and_flat_names_a_group_or_the_generator():
    base = prior_preset("v1")
    cfg = override(base, parse_settings(["optim.lr=1e-3", "lambda_grad=0.5", "generator.width=0.5",
                                         "losses.amount_windows=[16]", "materials.families=null",
                                         "photos.fov_deg=[50, 60]"]))
    assert (cfg.optim.lr, cfg.losses.grad, cfg.generator.width, cfg.losses.amount_windows) == (1e-3, 0.5, 0.5, (16,))
    assert cfg.materials.families is None and cfg.photos.fov_deg == (50.0, 60.0)
    assert cfg.optim.batch == base.optim.batch and override(base, {}) == base
    assert override(base, {"lr": 1e-3}) == override(base, {"optim.lr": 1e-3})  # the same setting by either name
    assert override(base, {"optim": dataclasses.replace(base.optim, lr=2e-3)}).optim.lr == 2e-3
    assert override(base, {"optim": {"lr": 3e-3}}).optim == dataclasses.replace(base.optim, lr=3e-3)
    assert override(base, {"generator": {"width": 0.5}}).generator == dataclasses.replace(base.generator, width=0.5)
    assert base.optim.lr == 5e-4  # a new config; the old one unchanged


@pytest.mark.parametrize("settings, match", [
    ({"nope": 1}, "unknown prior settings: nope"),
    ({"optim.nope": 1}, "unknown prior settings: optim.nope"),
    ({"losses.lambda_render": 1}, "unknown prior settings: losses.lambda_render"),
    ({"generator.nope": 1}, "unknown"),
    ({"finetune_preset.x": 1}, "unknown prior settings: finetune_preset.x"),
    ({"optim": 3}, "optim must be a mapping of its settings"),
    ({"finetune_preset": "nope"}, "unknown preset 'nope'"),
])
def test_an_unknown_name_gives_a_clear_error(settings, match):
    with pytest.raises(ValueError, match=match):
        override(PriorConfig(), settings)
    if "." in next(iter(settings)) or next(iter(settings)) == "nope":
        with pytest.raises(ValueError, match=match):
            PriorConfig.from_dict(settings)


@pytest.mark.parametrize("settings, match", [
    ({"optim.lr": 0.0}, "optim.lr > 0"), ({"optim.ema": 1.0}, "optim.ema must be in"),
    ({"optim.batch": 0}, "optim.batch and optim.iters"), ({"photos.crop_share": 1.5}, "photos.crop_share"),
    ({"photos.block_mean": 3}, "photos.block_mean must be 1, 2 or 4"),
    ({"photos.camera": {"ev": (1.0, 0.0)}}, "photos.camera ranges need exactly"),
    ({"materials.reuse": 0}, "materials.reuse must be >= 1"), ({"materials.flat_share": 1.0}, "materials.flat_share"),
    ({"materials.stream": "device"}, "needs materials.batched"),
    ({"materials.print_share": 0.1}, "need materials.stream 'device'"),
    ({"losses.render": -1.0}, "losses.render must be >= 0"), ({"losses.slope": -1.0}, "losses.slope must be >= 0"),
    ({"losses.amount_maps": ["bumps"]}, "losses.amount_maps"), ({"losses.grazing_deg": [0, 10]}, "losses.grazing_deg"),
    ({"monitor.log_every": 0}, "monitor.log_every must be >= 1"), ({"monitor.eval_every": -1}, "monitor.eval_every"),
])
def test_validation_names_the_setting_by_its_dotted_name(settings, match):
    with pytest.raises(ValueError, match=match):
        override(PriorConfig(), settings)
