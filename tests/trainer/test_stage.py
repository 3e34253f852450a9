"""One way to set up a stage (svbrdf.trainer.stage.make_trainer): fresh runs, fine-tunes from a checkpoint, resumes."""

import dataclasses

import pytest
import torch

from svbrdf.runtime.errors import ModelError
from svbrdf.runtime.inference.manifest import network_input_record
from svbrdf.runtime.core.maps import MAP_NAMES, SLICES
from svbrdf.trainer.config import REFINE_RECIPES, TrainConfig, resolve
from svbrdf.trainer.checkpoint import save_checkpoint
from svbrdf.trainer.stage import finetune_config, make_trainer
from svbrdf.trainer.train import Trainer, predict_full


def random_photo(h=48, w=64, seed=0):
    return torch.rand(1, 3, h, w, generator=torch.Generator().manual_seed(seed)) * 0.5


def params(module):
    return torch.cat([p.detach().flatten().clone() for p in module.parameters()])


def _trained(*args, **kw):
    """Set up a stage with :func:`make_trainer` and run it."""
    trainer = make_trainer(*args, **kw)
    trainer.run()
    return trainer


def test_fresh_stages_are_plain_trainers():
    cfg = resolve("tiny", iters_pretrain=3, iters_fit=5)
    assert make_trainer(random_photo(), "pretrain", cfg, threads=1).iters == 3
    fit = make_trainer(random_photo(), "fit", cfg, iters=2, threads=1)
    assert fit.stage == "fit" and fit.iters == 2 and fit.step == 0 and fit.init is None


def test_arguments_that_do_not_fit_the_stage_are_refused(tmp_path):
    cfg = resolve("tiny", iters_pretrain=1)
    path = tmp_path / "pre.pt"
    _trained(random_photo(), "pretrain", cfg, checkpoint_path=path, threads=1)
    with pytest.raises(ValueError, match="only a finetune"):
        make_trainer(random_photo(), "finetune", cfg, threads=1)
    with pytest.raises(ValueError, match="only a finetune"):
        make_trainer(random_photo(), "fit", cfg, init=path, threads=1)
    with pytest.raises(ValueError, match="stage and a config"):
        make_trainer(random_photo(), "fit", threads=1)
    with pytest.raises(ValueError, match="from its checkpoint"):
        make_trainer(random_photo(), "pretrain", cfg, resume=path, threads=1)
    with pytest.raises(ModelError, match="is a 'pretrain' run, not 'fit'"):
        make_trainer(random_photo(), "fit", resume=path, threads=1)
    ckpt = torch.load(path, weights_only=True)
    ckpt["train_config"]["bogus"] = 1
    with pytest.raises(ModelError, match="checkpoint: bad training settings"):
        make_trainer(random_photo(), resume=ckpt, threads=1)


def test_finetune_config_keeps_train_encoder():
    ckpt = {"generator_config": resolve("tiny").generator.to_dict(), "discriminator_config": None}
    cfg, notes = finetune_config(resolve("fast", train_encoder=True), ckpt)
    assert cfg.generator == dataclasses.replace(resolve("tiny").generator, train_encoder=True)
    assert notes == ["model architecture taken from the initial checkpoint"]
    assert finetune_config(cfg, ckpt)[1] == []


def test_a_fine_tune_shows_the_generator_what_the_stage_ones_record_says():
    ckpt = {"generator_config": resolve("tiny").generator.to_dict(), "discriminator_config": None}
    fast, paper = resolve("fast", train_encoder=True), resolve("paper")
    assert fast.even_lighting > 0 and paper.even_lighting == 0
    assert finetune_config(fast, ckpt)[0].even_lighting == fast.even_lighting  # no record: the preset's
    photo = {**ckpt, "network_input": network_input_record("photo", 0.25)}
    cfg, notes = finetune_config(fast, photo)
    assert cfg.even_lighting == 0.0 and "network input taken from the initial checkpoint: the photo as it is" in notes
    assert finetune_config(paper, {**ckpt, "network_input": network_input_record("even", 0.25)})[0].even_lighting == 0.0
    with pytest.raises(ModelError, match="invalid network_input"):
        finetune_config(fast, {**ckpt, "network_input": {"mode": "photo", "even_lighting": 0.3}})


def test_a_fine_tune_takes_the_stage_ones_refine_record_where_the_user_left_the_preset():
    ckpt = {"generator_config": resolve("tiny").generator.to_dict(), "discriminator_config": None,
            "refine": dict(REFINE_RECIPES["v2"])}
    fast = resolve("fast", train_encoder=True)
    assert fast.losses.specular_prior > 0 and fast.losses.anchor_maps == ("normal",)  # what the record changes
    cfg, notes = finetune_config(fast, ckpt)
    assert (cfg.losses.specular_prior, cfg.losses.anchor, cfg.losses.anchor_maps) == (0.0, 1.0, MAP_NAMES)
    assert any(n.startswith("fine-tune settings taken from the initial checkpoint: losses.specular_prior=0.0")
               for n in notes)
    plain = finetune_config(fast, {k: v for k, v in ckpt.items() if k != "refine"})[0]  # no record: the preset's
    assert (plain.losses.specular_prior, plain.losses.anchor, plain.losses.anchor_maps) == (
        fast.losses.specular_prior, fast.losses.anchor, fast.losses.anchor_maps)
    mine = resolve("fast", train_encoder=True, lambda_specular_prior=0.5)  # the user's own value wins
    cfg = finetune_config(mine, ckpt)[0]
    assert cfg.losses.specular_prior == 0.5 and cfg.losses.anchor_maps == MAP_NAMES
    same = resolve("fast", train_encoder=True, lambda_anchor=fast.losses.anchor)  # the preset's own value, given
    assert finetune_config(same, ckpt)[0].losses.anchor == 1.0  # not told: the record's
    cfg = finetune_config(same, ckpt, keep=("lambda_anchor",))[0]  # told it was the user's: it stays
    assert cfg.losses.anchor == fast.losses.anchor and cfg.losses.specular_prior == 0.0
    paper = resolve("paper")  # the published method keeps its settings
    assert finetune_config(paper, ckpt)[0].losses.anchor == paper.losses.anchor
    for bad in ({"no_such_setting": 1}, {"lambda_anchor": -1.0}, ["lambda_anchor"]):
        with pytest.raises(ModelError, match="invalid refine record"):
            finetune_config(fast, {**ckpt, "refine": bad})


def test_a_refine_record_names_post_settings_as_it_likes_and_keep_protects_them():
    ckpt = {"generator_config": resolve("tiny").generator.to_dict(), "discriminator_config": None}
    fast = resolve("fast", train_encoder=True)
    for record in ({"flash_trend": False}, {"post.flash_trend": False}, {"post": {"flash_trend": False}}):
        cfg, notes = finetune_config(fast, {**ckpt, "refine": record})
        assert cfg.post == fast.post.replace(flash_trend=False), record
        assert any(n.endswith("initial checkpoint: post.flash_trend=False") for n in notes), record
        for keep in (("flash_trend",), ("post.flash_trend",)):  # the user gave it (--set, in either name)
            assert finetune_config(fast, {**ckpt, "refine": record}, keep=keep)[0].post == fast.post
    with pytest.raises(ModelError, match="invalid refine record"):
        finetune_config(fast, {**ckpt, "refine": {"post": {"sharpen": True}}})


def test_finetune_starts_from_the_pretrained_state(tmp_path):
    photo_a, photo_b = random_photo(seed=1), random_photo(seed=2)
    ckpt = tmp_path / "pre.pt"
    pre = _trained(photo_a, "pretrain", resolve("tiny", iters_pretrain=3), checkpoint_path=ckpt, threads=1)
    start = Trainer(photo_b, resolve("tiny", seed=99), stage="finetune", threads=1)
    start.load_init(torch.load(ckpt, weights_only=True), ckpt)
    assert torch.equal(params(start.generator), params(pre.generator))
    assert start.optimizers["nr"].state_dict()["state"][0]["step"] == 3
    tuned = _trained(photo_b, "finetune", init=ckpt, config=resolve("tiny", iters_finetune=2, lr=5e-4), threads=1)
    assert tuned.step == 2 and tuned.init["step"] == 3 and tuned.init["path"] == str(ckpt)
    assert tuned.optimizers["nr"].param_groups[0]["lr"] == 5e-4
    assert tuned.optimizers["nr"].state_dict()["state"][0]["step"] == 5
    reset = _trained(photo_b, "finetune", init=ckpt, config=resolve("tiny", iters_finetune=1, reset_optimizers=True),
                     threads=1)
    assert reset.optimizers["nr"].state_dict()["state"][0]["step"] == 1


@pytest.fixture
def anchored_start(tmp_path):
    """``(stage-one checkpoint, a second photo, the checkpoint's maps of it)``: 48 px, tiles = the whole photo, so
    an anchor is exactly the generator's starting output on every tile."""
    photo_a, photo_b = random_photo(48, 48, seed=1), random_photo(48, 48, seed=2)
    ckpt = tmp_path / "pre.pt"
    pre = _trained(photo_a, "pretrain", resolve("tiny", iters_pretrain=3, tile=48), checkpoint_path=ckpt, threads=1)
    with torch.no_grad():
        return ckpt, photo_b, predict_full(pre.generator, photo_b)


def test_a_fine_tune_from_a_stage_one_with_a_refine_record_runs_its_recipe(tmp_path, anchored_start):
    ckpt, photo_b, start = anchored_start
    recorded = torch.load(ckpt, weights_only=True)
    recorded["refine"] = dict(REFINE_RECIPES["v2"])
    save_checkpoint(tmp_path / "recorded.pt", recorded)
    cfg = resolve("tiny", iters_finetune=1, tile=48, even_lighting=0.25)  # a preset of the fast family: no anchor
    assert cfg.losses.anchor == 0
    plain = _trained(photo_b, "finetune", init=ckpt, config=cfg, threads=1)
    tuned = _trained(photo_b, "finetune", init=tmp_path / "recorded.pt", config=cfg, threads=1)
    assert plain.anchor is None and plain.config.losses.anchor == 0
    assert (tuned.config.losses.anchor, tuned.config.losses.anchor_maps) == (1.0, MAP_NAMES)
    assert tuned.anchor is not None and tuned.history[0].get("ds/anchor") is not None
    assert any(n.startswith("fine-tune settings taken from the initial checkpoint") for n in tuned.notes)


@pytest.mark.integration
def test_anchor_holds_a_finetune_near_its_starting_maps_and_survives_resume(tmp_path, anchored_start):
    ckpt, photo_b, start = anchored_start
    drift = {}
    for w in (0.0, 50.0):
        cfg = resolve("tiny", iters_finetune=20, lr=2e-3, lambda_anchor=w, tile=48)
        tuned = _trained(photo_b, "finetune", init=ckpt, config=cfg, threads=1)
        if w:
            assert torch.allclose(tuned.anchor, start, atol=1e-5)
            assert all(h.get("ds/anchor") is not None for h in tuned.history)
        else:
            assert tuned.anchor is None and "ds/anchor" not in tuned.history[0]
        drift[w] = float((tuned.predict() - start).abs().mean())
    assert drift[50.0] < 0.7 * drift[0.0]
    # The anchor is stored with the checkpoint, so a resumed fine-tune pulls to the same maps.
    cfg = resolve("tiny", iters_finetune=4, lambda_anchor=1.0, tile=48)
    path = tmp_path / "ft.pt"
    _trained(photo_b, "finetune", init=ckpt, config=TrainConfig.from_dict({**cfg.to_dict(), "optim.iters_finetune": 2}), threads=1,
             checkpoint_path=path)
    stored = torch.load(path, weights_only=True)["anchor"]
    assert stored.dtype == torch.float16 and stored.shape == start.shape
    resumed = _trained(photo_b, resume=path, iters=4, threads=1)
    assert resumed.step == 4 and torch.allclose(resumed.anchor, start, atol=2e-3)


@pytest.mark.integration
def test_anchor_maps_pull_only_the_named_maps(anchored_start):
    ckpt, photo_b, start = anchored_start
    drift = {}
    for maps in (("normal",), ("diffuse",)):
        cfg = resolve("tiny", iters_finetune=20, lr=2e-3, lambda_anchor=50.0, anchor_maps=maps, tile=48)
        moved = (_trained(photo_b, "finetune", init=ckpt, config=cfg, threads=1).predict() - start).abs()
        drift[maps[0]] = {name: float(moved[:, sl].mean()) for name, sl in SLICES.items()}
    # Each run holds its own map closer to the start than the run that leaves that map free.
    assert drift["normal"]["normal"] < 0.7 * drift["diffuse"]["normal"]
    assert drift["diffuse"]["diffuse"] < 0.7 * drift["normal"]["diffuse"]
    with pytest.raises(ValueError, match="anchor_maps"):
        resolve("tiny", anchor_maps=("height",))
    assert resolve("tiny", anchor_maps=["normal"]).to_dict()["losses"]["anchor_maps"] == ["normal"]


def test_finetune_takes_the_architecture_of_the_checkpoint(tmp_path):
    ckpt = tmp_path / "pre.pt"
    _trained(random_photo(), "pretrain", resolve("tiny", iters_pretrain=1), checkpoint_path=ckpt, threads=1)
    cfg = resolve("fast", tile=32, iters_finetune=1, lambda_perceptual=0)
    tuned = _trained(random_photo(seed=4), "finetune", init=ckpt, config=cfg, threads=1)
    assert tuned.config.generator == resolve("tiny").generator
    assert any("architecture" in n for n in tuned.notes)
