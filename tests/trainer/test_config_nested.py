"""TrainConfig as nested groups (issue 65, item 2): the presets' values, lossless flat <-> nested forms, the flat
records of earlier checkpoints, dotted ``--set`` on svbrdf-train, svbrdf-bench and the prior's commands."""

import json
from pathlib import Path

import pytest

from svbrdf.trainer.config import (FLAT_NAMES, GROUPS, TRAIN_PRESETS, TrainConfig, flat_settings, parse_settings,
                                   resolve, setting_name)

MODELS = Path(__file__).resolve().parents[2] / "models"

#: ``resolve("tiny").to_dict()`` as the flat TrainConfig wrote it into checkpoints before the groups (literal).
OLD_TINY = {'anchor_maps': ['diffuse', 'specular', 'roughness', 'normal'],
     'betas': [0.0, 0.9],
     'bf16': False,
     'camera_lr': 0.005,
     'checkpoint_every': 10,
     'context_every': 5,
     'd_updates': 1,
     'diffuse_target': 'absolute',
     'discriminator': {'n_layers': 4, 'width': 0.125},
     'ds_updates': 1,
     'eval_every': 5,
     'eval_tiles': 2,
     'flash_position': None,
     'fourier_mode': 'complex',
     'gan_steps': 0,
     'generator': {'arch': 'wen',
                   'decoder_blocks': 2,
                   'height_activation': 'tanh',
                   'height_scale': 32.0,
                   'train_encoder': False,
                   'width': 0.125},
     'guard_rollback_after': 5,
     'guard_snapshot_every': 5,
     'iters_finetune': 10,
     'iters_fit': 20,
     'iters_pretrain': 20,
     'lambda_anchor': 0.0,
     'lambda_diffuse': 1.0,
     'lambda_flash': 0.0,
     'lambda_fourier': 0.1,
     'lambda_gan': 0.1,
     'lambda_perceptual': 0.2,
     'lambda_render': 0.0,
     'lambda_specular_prior': 0.0,
     'learn_offsets': False,
     'learn_vignetting': False,
     'lr': 0.001,
     'maps_every': 0,
     'nr_updates': 1,
     'perceptual': 'pyramid',
     'perceptual_min_clipped': 0.0,
     'photo_context': True,
     'plateau_render_tol': 0.05,
     'plateau_window': 3,
     'post': {'colour_from_photo': False,
              'even_lighting': 0.0,
              'fill_patches': True,
              'flash_trend': False,
              'highlight_fill': False,
              'uniform_specular': False},
     'predict_max_side': 64,
     'predict_overlap': 8,
     'preset': 'tiny',
     'quality': 'fixed',
     'render': {'diffuse_conservation': False,
                'falloff': False,
                'fov_deg': 66.0,
                'fresnel': 'schlick',
                'geometry': 'schlick',
                'intensity': 3.141592653589793},
     'reset_optimizers': False,
     'saturate': False,
     'schedule': 'alternating',
     'seed': 24,
     'tile': 32,
     'vgg_weights': None}


def test_presets_keep_their_values_under_the_dotted_names():
    paper, fast, tiny = resolve("paper"), resolve("fast"), resolve("tiny")
    assert (paper.optim.tile, paper.optim.nr_updates, paper.optim.lr, paper.optim.iters_finetune) == (256, 5, 2e-5, 3000)
    assert (paper.losses.gan, paper.losses.fourier, paper.losses.perceptual) == (0.1, 0.1, 0.2)
    assert (paper.losses.perceptual_backend, paper.monitor.eval_every, paper.guard.rollback_after) == ("auto", 100, 5)
    assert (fast.optim.schedule, fast.optim.lr, fast.optim.gan_steps, fast.optim.iters_finetune) == (
        "joint", 1e-4, 150, 150)
    assert (fast.losses.fourier, fast.losses.render, fast.losses.flash, fast.losses.anchor) == (0.0, 1.0, 1.0, 3.0)
    assert fast.losses.anchor_maps == ("normal",) and fast.losses.perceptual_min_clipped == 5e-5
    assert fast.photo.saturate and fast.photo.learn_vignetting and fast.render_config.falloff
    assert fast.post.highlight_fill and fast.even_lighting == 0.25
    assert (tiny.predict.max_side, tiny.predict.overlap, tiny.guard.snapshot_every) == (64, 8, 5)
    assert resolve("zhao").losses.fourier == resolve("zhao").losses.perceptual == 0.0


@pytest.mark.parametrize("name", sorted(TRAIN_PRESETS))
def test_flat_and_nested_forms_round_trip_losslessly(name):
    cfg = resolve(name)
    nested = cfg.to_dict()
    assert set(nested) == {"preset", "generator", "discriminator", "render", *GROUPS}
    assert TrainConfig.from_dict(json.loads(json.dumps(nested))) == cfg
    flat = cfg.flat_dict()
    assert all("." in k for k in flat if k not in ("preset", "generator", "discriminator", "render"))
    assert TrainConfig.from_dict(json.loads(json.dumps(flat))) == cfg
    assert flat_settings(nested) == flat
    # The layout of earlier checkpoints: every group field under its old flat name, post as a dict.
    old = {old: flat[new] for old, new in FLAT_NAMES.items() if new in flat and not new.startswith("post.")}
    old.update(preset=name, generator=nested["generator"], discriminator=nested["discriminator"],
               render=nested["render"], post=nested["post"])
    assert TrainConfig.from_dict(old) == cfg


def test_an_old_flat_record_loads_to_the_same_settings():
    assert TrainConfig.from_dict(OLD_TINY) == resolve("tiny")
    # ... and with a retired setting, bare post fields (the records before ``post``) and a dotted name mixed in.
    record = {k: v for k, v in OLD_TINY.items() if k != "post"}
    cfg = TrainConfig.from_dict({**record, "plateau_change_tol": 0.01, "flash_trend": True, "losses.fourier": 0.5})
    assert cfg.post.flash_trend and cfg.losses.fourier == 0.5 and cfg.optim.tile == 32
    with pytest.raises(ValueError, match="unknown training settings: bogus"):
        TrainConfig.from_dict({**OLD_TINY, "bogus": 1})
    with pytest.raises(ValueError, match="unknown training settings: losses.nope"):
        TrainConfig.from_dict({"losses": {"nope": 1}})


def test_the_names_map_one_to_one():
    new = list(FLAT_NAMES.values())
    assert len(new) == len(set(new))
    fields = set(resolve("paper").flat_dict())
    assert all(n in fields or n.startswith(("generator.", "render.")) for n in new)
    assert setting_name("lambda_fourier") == "losses.fourier" and setting_name("perceptual") == "losses.perceptual_backend"
    assert setting_name("losses.fourier") == "losses.fourier"


def test_resolve_takes_dotted_and_flat_names_and_checks_them():
    a = resolve("fast", **parse_settings(["losses.fourier=0.5", "optim.lr=0.001", "post.even_lighting=0",
                                          "render.fov_deg=50", "generator.train_encoder=true"]))
    b = resolve("fast", lambda_fourier=0.5, lr=1e-3, even_lighting=0, fov_deg=50, train_encoder=True)
    assert a == b and a.losses.fourier == 0.5 and a.render_config.fov_deg == 50 and a.train_encoder
    assert a.losses.anchor == 3.0  # the rest is the preset's
    for bad, match in ((["losses.nope=1"], "unknown training settings"), (["nope=1"], "unknown training settings"),
                       (["losses.fourier=-1"], "losses.fourier must be >= 0"),
                       (["optim.schedule=joint", "optim.nr_updates=2"], "needs nr_updates")):
        with pytest.raises(ValueError, match=match):
            resolve("fast", **parse_settings(bad))


def test_the_packaged_stage_one_loads_and_its_fine_tune_resolves_as_before():
    pytest.importorskip("torch")
    from svbrdf.trainer.checkpoint import load_checkpoint
    from svbrdf.trainer.prior.config import PriorConfig
    from svbrdf.trainer.stage import finetune_config

    path = MODELS / "svbrdf_prior_v2.pt"
    if not path.exists():
        pytest.skip("no packaged checkpoint")
    ckpt = load_checkpoint(path)
    assert "lambda_anchor" in ckpt["train_config"] and "losses" not in ckpt["train_config"]  # the flat form
    assert TrainConfig.from_dict(ckpt["train_config"]) == resolve("fast")
    prior = PriorConfig.from_dict(ckpt["prior_config"])
    assert prior.generator.arch == "unet" and prior.optim.iters == 20000
    cfg, notes = finetune_config(resolve("fast"), ckpt)
    # The values the fine-tune resolved to before the groups (snapshot of the flat config, 2026-11-29).
    assert (cfg.losses.specular_prior, cfg.losses.anchor) == (0.0, 1.0)
    assert cfg.losses.anchor_maps == ("diffuse", "specular", "roughness", "normal")
    assert cfg.even_lighting == 0.0 and cfg.generator.arch == "unet" and cfg.generator.train_encoder is False
    assert (cfg.optim.iters_finetune, cfg.optim.gan_steps, cfg.losses.flash, cfg.post.highlight_fill) == (
        150, 150, 1.0, True)
    assert notes[-1].startswith("fine-tune settings taken from the initial checkpoint: losses.specular_prior=0.0")
    rest = {k: v for k, v in cfg.flat_dict().items() if k not in (
        "generator", "discriminator", "post.even_lighting", "losses.specular_prior", "losses.anchor",
        "losses.anchor_maps")}
    fast = resolve("fast").flat_dict()
    assert rest == {k: fast[k] for k in rest}


def test_svbrdf_train_set_takes_dotted_names(tmp_path):
    pytest.importorskip("torch")
    import numpy as np

    from svbrdf.runtime.io.images import write_image
    from svbrdf.trainer import checkpoint as ckpt_io
    from svbrdf.trainer import cli

    photo = tmp_path / "p.png"
    write_image(photo, np.random.default_rng(0).random((40, 48, 3)).astype(np.float32))
    out = tmp_path / "o"
    assert cli.main(["fit", str(photo), "--preset", "tiny", "--threads", "1", "--iters", "2", "--quiet",
                     "--out", str(out), "--set", "losses.fourier=0.5", "--set", "guard.snapshot_every=3"]) == 0
    saved = TrainConfig.from_dict(ckpt_io.load_checkpoint(out / "checkpoint.pt")["train_config"])
    assert saved.losses.fourier == 0.5 and saved.guard.snapshot_every == 3 and saved.optim.iters_fit == 2
    assert cli.main(["fit", str(photo), "--preset", "tiny", "--out", str(tmp_path / "b"), "--quiet",
                     "--set", "losses.nope=1"]) == 2
    assert cli.main(["fit", str(photo), "--preset", "tiny", "--out", str(tmp_path / "b"), "--quiet",
                     "--set", "losses"]) != 0


def test_svbrdf_bench_set_takes_dotted_and_flat_names():
    pytest.importorskip("torch")
    from svbrdf.runtime.errors import SvbrdfError
    from svbrdf.trainer.bench.cli import _settings

    assert _settings(["losses.fourier=0.5", "lambda_gan=0.2", "flash_trend=false"]) == {
        "losses.fourier": 0.5, "losses.gan": 0.2, "post.flash_trend": False}
    with pytest.raises(SvbrdfError, match="unknown training settings"):
        _settings(["losses.nope=1"])


def test_prior_set_overrides_a_field_or_the_generator():
    pytest.importorskip("torch")
    from svbrdf.trainer.prior.config import override
    from svbrdf.trainer.prior.presets import prior_preset

    base = prior_preset("v1")
    cfg = override(base, parse_settings(["lambda_grad=0.5", "generator.width=0.5", "losses.amount_windows=[16]"]))
    assert cfg.losses.grad == 0.5 and cfg.generator.width == 0.5 and cfg.losses.amount_windows == (16,)
    assert cfg.optim.batch == base.optim.batch and override(base, {}) == base
    for bad, match in (({"nope": 1}, "unknown prior settings"), ({"generator.nope": 1}, "unknown"),
                       ({"ema": 1.0}, "optim.ema must be")):
        with pytest.raises(ValueError, match=match):
            override(base, bad)
