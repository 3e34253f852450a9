"""Training loop: configuration, learning on a synthetic photo, determinism, the non-finite guard, inference."""

import dataclasses
import json
import math

import pytest
import torch
import torch.nn.functional as F

from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.core.maps import SLICES
from svbrdf.runtime.core.render import ZHAO
from svbrdf.trainer import train as train_mod
from svbrdf.trainer.config import TRAIN_PRESETS, TrainConfig, resolve
from svbrdf.trainer.render import FlashGeometry
from svbrdf.trainer.train import Trainer, predict_full


# Every run uses threads=1: with toy models thread synchronisation dominates, and one thread stays fast on a
# busy machine (two spinning OpenMP threads on two shared cores can be 20x slower).


def synthetic_scene(size=64, seed=3):
    """A photo rendered from smooth random diffuse, constant specular/roughness and flat normals."""
    g = torch.Generator().manual_seed(seed)
    low = torch.rand(1, 3, 8, 8, generator=g) * 0.6 + 0.2
    diffuse = F.interpolate(low, size=(size, size), mode="bicubic", align_corners=False).clamp(0.05, 0.95)
    flat = torch.zeros(1, 3, size, size)
    flat[:, 2] = 1.0
    maps = torch.cat([diffuse, torch.full((1, 1, size, size), 0.04), torch.full((1, 1, size, size), 0.4), flat], 1)
    photo = FlashGeometry(size, size, ZHAO).render(maps).clamp(0.0, 1.0)
    return photo, maps


def random_photo(h=48, w=64, seed=0):
    return torch.rand(1, 3, h, w, generator=torch.Generator().manual_seed(seed)) * 0.5


def params(module):
    return torch.cat([p.detach().flatten().clone() for p in module.parameters()])


def window_mean(history, key, start, stop):
    vals = [h[key] for h in history[start:stop] if h.get(key) is not None]
    return sum(vals) / len(vals)


# ------------------------------------------------------------------ configuration
def test_presets_round_trip_through_json():
    for name in TRAIN_PRESETS:
        cfg = resolve(name)
        again = TrainConfig.from_dict(json.loads(json.dumps(cfg.to_dict())))
        assert again == cfg
        assert again.preset == name


def test_paper_and_zhao_presets_are_the_published_schedule():
    p = resolve("paper")
    assert (p.optim.tile, p.optim.nr_updates, p.optim.ds_updates, p.optim.d_updates) == (256, 5, 1, 1)
    assert (p.optim.lr, p.optim.betas, p.optim.seed) == (2e-5, (0.0, 0.9), 24)
    assert (p.losses.gan, p.losses.fourier, p.losses.perceptual) == (0.1, 0.1, 0.2)
    assert (p.optim.iters_pretrain, p.optim.iters_finetune, p.optim.iters_fit) == (10000, 3000, 20000)
    assert not p.train_encoder and p.render_config == ZHAO
    z = resolve("zhao")
    assert z.losses.fourier == 0 and z.losses.perceptual == 0 and z.generator == p.generator
    f = resolve("fast")
    assert (f.optim.tile, f.optim.nr_updates, f.optim.ds_updates, f.optim.d_updates) == (128, 1, 1, 1) and f.generator.width < 1
    assert p.optim.schedule == z.optim.schedule == "alternating" and f.optim.schedule == "joint"
    alt = resolve("fast-alternating")
    assert alt.optim.schedule == "alternating" and dataclasses.replace(alt, preset="fast", optim=dataclasses.replace(alt.optim, schedule="joint")) == f
    # The highlight-free flash model is in fast only; paper, zhao and fast-v1 keep the published losses.
    for name in ("paper", "zhao", "fast-v1"):
        c = resolve(name)
        assert (c.losses.render, c.losses.flash, c.photo.saturate, c.losses.diffuse_target) == (0.0, 0.0, False, "absolute")
        assert not c.render_config.falloff
    assert f.losses.render > 0 and f.losses.flash > 0 and f.losses.specular_prior > 0 and f.photo.saturate
    assert f.photo.learn_vignetting and f.photo.learn_offsets and f.losses.diffuse_target == "normalized" and f.render_config.falloff
    assert f.losses.fourier == 0  # no longer needed once the flash term is in (docs/decisions/021-fast-highlight-free.md)
    new = ("render", "photo.saturate", "photo.learn_vignetting", "photo.learn_offsets", "losses.render",
           "losses.flash", "losses.specular_prior", "losses.fourier", "losses.diffuse_target", "optim.iters_finetune",
           "losses.anchor", "losses.anchor_maps", "optim.gan_steps")
    assert f.even_lighting == 0.25 and p.even_lighting == z.even_lighting == 0  # refine-detail/flat-input
    assert f.optim.gan_steps == f.optim.iters_finetune and p.optim.gan_steps == z.optim.gan_steps == 0  # refine-detail: the GAN drifts
    assert f.losses.anchor > 0 and f.losses.anchor_maps == ("normal",)  # docs/decisions/021-fast-highlight-free.md
    assert f.optim.iters_finetune == 150 and resolve("fast-v1").optim.iters_finetune == 600  # docs/decisions/023-stage-one-v2.md
    fast = f.flat_dict()
    assert TrainConfig.from_dict({**resolve("fast-v1").flat_dict(), "preset": "fast", "post": f.post,
                                  **{k: fast[k] for k in new}}) == f
    assert resolve("fast-zhao").losses.perceptual == 0 and resolve("fast-zhao").losses.flash == 0


def test_resolve_overrides_and_errors():
    cfg = resolve("paper", tile=128, fov_deg=45.0, train_encoder=True, lr=None)
    assert cfg.optim.tile == 128 and cfg.render_config.fov_deg == 45.0 and cfg.train_encoder and cfg.optim.lr == 2e-5
    assert resolve("paper").train_encoder is False  # presets are not mutated
    with pytest.raises(ValueError, match="unknown preset"):
        resolve("nope")
    with pytest.raises(ValueError, match="unknown training settings"):
        resolve("paper", tiles=3)
    with pytest.raises(ValueError, match="tile"):
        resolve("paper", tile=4)
    with pytest.raises(ValueError, match="perceptual"):
        resolve("paper", perceptual="lpips")
    with pytest.raises(ValueError, match="fov"):
        resolve("paper", fov_deg=0.0)
    with pytest.raises(ValueError, match="schedule 'joint' needs"):
        resolve("paper", schedule="joint")  # 5:1:1
    with pytest.raises(ValueError, match="schedule must be"):
        resolve("fast", schedule="both")


# ------------------------------------------------------------------ learning
@pytest.mark.integration
@pytest.mark.parametrize("schedule", ["alternating", "joint"])
def test_tiny_run_losses_finite_and_decreasing(schedule):
    # A structured photo: on white noise the guessed diffuse is noise too, and L_d need not fall in 30 iterations
    # (it did not on one of the two CPU families this suite runs on).
    photo, _ = synthetic_scene(size=48)
    trainer = Trainer(photo, resolve("tiny", iters_fit=30, eval_every=5, schedule=schedule), threads=1)
    history = trainer.run()
    assert len(history) == 30 and trainer.step == 30
    for rec in history:
        for key in ("nr/gan", "ds/gan", "ds/diffuse", "d/loss", "nr/fourier", "ds/perceptual"):
            assert rec[key] is not None and math.isfinite(rec[key]), (rec["step"], key)
    assert window_mean(history, "ds/diffuse", 20, 30) < 0.85 * window_mean(history, "ds/diffuse", 0, 10)
    evals = [h["eval/render_l1"] for h in history if "eval/render_l1" in h]
    assert len(evals) == 6 and history[4]["eval/map_change"] is None and history[9]["eval/map_change"] > 0


@pytest.mark.slow
def test_tiny_run_learns_synthetic_scene():
    photo, maps = synthetic_scene()
    trainer = Trainer(photo, resolve("tiny", iters_fit=200, eval_every=10), threads=1)
    first = trainer.evaluate()["eval/render_l1"]
    history = trainer.run()
    assert window_mean(history, "ds/diffuse", 180, 200) < 0.75 * window_mean(history, "ds/diffuse", 0, 20)
    assert history[-1]["eval/render_l1"] < 0.75 * first
    pred = trainer.predict()
    rerender = (trainer.geometry.render(pred) - photo).abs().mean()
    untrained = Trainer(photo, resolve("tiny"), threads=1)
    assert rerender < 0.75 * (untrained.geometry.render(untrained.predict()) - photo).abs().mean()


def test_joint_schedule_trains_both_decoders_and_the_discriminator():
    photo = random_photo()
    trainer = Trainer(photo, resolve("tiny", iters_fit=3, schedule="joint"), threads=1)
    nets = {"nr": trainer.generator.decoder_nr, "ds": trainer.generator.decoder_ds, "d": trainer.discriminator,
            "enc": trainer.generator.encoder}
    before = {k: params(m) for k, m in nets.items()}
    history = trainer.run()
    for key in ("nr", "ds", "d"):
        assert not torch.equal(before[key], params(nets[key])), key
    assert torch.equal(before["enc"], params(nets["enc"]))  # frozen, as in the alternating schedule
    for rec in history:
        assert rec["nr/gan"] == rec["ds/gan"] and rec["ds/total"] - rec["nr/total"] == pytest.approx(rec["ds/diffuse"])
        assert all(math.isfinite(rec[k]) for k in ("nr/fourier", "ds/perceptual", "d/loss"))


@pytest.mark.parametrize("schedule", ["alternating", "joint"])
def test_gan_steps_stops_the_gan_after_n_iterations(schedule):
    photo = random_photo()
    trainer = Trainer(photo, resolve("tiny", iters_fit=3, schedule=schedule, gan_steps=1, eval_every=0), threads=1)
    trainer.run()
    d_after_first = params(trainer.discriminator)
    first, *later = trainer.history
    assert first["d/loss"] is not None and first["nr/gan"] is not None
    for rec in later:  # no GAN term, no discriminator update, the other terms as before
        assert "d/loss" not in rec and "nr/gan" not in rec and "ds/gan" not in rec
        assert math.isfinite(rec["ds/diffuse"]) and math.isfinite(rec["nr/total"])
    trainer.iters = 5
    trainer.run()
    assert torch.equal(d_after_first, params(trainer.discriminator))
    with pytest.raises(ValueError, match="gan_steps"):
        resolve("tiny", gan_steps=-1)
    with pytest.raises(ValueError, match="losses.diffuse must be"):
        resolve("tiny", lambda_diffuse=-1)


HIGHLIGHT_FREE = dict(lambda_render=1.0, lambda_flash=10.0, saturate=True, diffuse_target="normalized",
                      render={**ZHAO.to_dict(), "falloff": True})


@pytest.mark.parametrize("extra", [{}, HIGHLIGHT_FREE, {**HIGHLIGHT_FREE, "lambda_diffuse": 0.5},
                                   {**HIGHLIGHT_FREE, "lambda_diffuse": 0.0}],
                         ids=["paper-losses", "highlight-free", "half-L_d", "no-L_d"])
def test_joint_step_gives_each_decoder_the_gradient_of_its_own_loss(monkeypatch, extra):
    """One backward pass of the summed loss = the per-decoder losses on the same tile (L_d at its weight)."""
    photo = random_photo()
    trainer = Trainer(photo, resolve("tiny", schedule="joint", **extra), threads=1)
    grads = {}

    def capture(keys, loss):
        params_ = [p for k in keys for p in trainer.params[k]]
        grads["joint"] = torch.autograd.grad(loss, params_, retain_graph=True, allow_unused=True)
        return True

    monkeypatch.setattr(trainer, "_apply", capture)
    monkeypatch.setattr(trainer, "_d_step", lambda *a, **k: None)
    rng_state = trainer.tile_rng.get_state()
    trainer.iteration()
    # Recompute the two losses on the same tile, written out term by term.
    trainer.tile_rng.set_state(rng_state)
    y0, x0 = trainer._draw_tile(trainer.tile_rng)
    x, guess = trainer._crop(trainer.photo, y0, x0), trainer._crop(trainer.guess, y0, x0)
    maps = trainer.generator(x).float()
    radiance = trainer.geometry.render(maps, y0, x0)
    cfg = trainer.config
    seen = radiance.clamp(0, 1) if cfg.photo.saturate else radiance
    shared = (cfg.losses.gan * train_mod.gan_generator_loss(trainer.discriminator(seen))
              + cfg.losses.fourier * train_mod.fourier_loss(maps, guess, mode=cfg.losses.fourier_mode)
              + cfg.losses.perceptual * trainer.perceptual(x, seen))
    if cfg.losses.render:
        shared = shared + cfg.losses.render * train_mod.render_loss(radiance, x)
    if cfg.losses.flash:
        basis = train_mod.flash_basis(trainer.geometry.light)[..., y0:y0 + x.shape[-2], x0:x0 + x.shape[-1]]
        shared = shared + cfg.losses.flash * train_mod.flash_correlation_loss(maps, basis)
    nr = torch.autograd.grad(shared, trainer.params["nr"], retain_graph=True, allow_unused=True)
    ld = train_mod.diffuse_loss(maps[:, SLICES["diffuse"]], guess, cfg.losses.diffuse_target)
    ds = torch.autograd.grad(shared + cfg.losses.diffuse * ld, trainer.params["ds"], allow_unused=True)
    for got, want in zip(grads["joint"], nr + ds):
        assert (got is None) == (want is None)
        if got is not None:
            torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-7)


@pytest.mark.integration
def test_learned_vignetting_follows_a_darkened_border():
    """With the networks held still, the learned camera darkens its border for a photo with a known vignetting
    and lightens it for the same photo without; the strength is saved; a fine-tune starts it anew (0.05).

    With the networks training too, one photo does not tell a darker border from a darker base colour: at this
    test's scale a fit of 60 iterations ended at 0.08 for a 0.4 vignetting and at 0.22 for none (Intel Xeon,
    AVX-512; an EPYC passed the former ``> 0.1`` check), so the mechanism is what is tested here."""
    from svbrdf.trainer.camera_model import vignette

    photo, _ = synthetic_scene(size=48)
    cfg = resolve("tiny", iters_fit=30, learn_vignetting=True, lambda_render=1.0, camera_lr=2e-2, eval_every=0,
                  lr=1e-12)  # the generator held still: only the camera learns
    final = {}
    for strength in (0.0, 0.4):
        seen = photo * torch.from_numpy(vignette(48, 48, strength)).permute(2, 0, 1)[None]
        trainer = Trainer(seen, cfg, threads=1)
        trainer.run()
        final[strength] = trainer.history[-1]["camera/vignetting"]
    assert final[0.4] > 0.055 and final[0.0] < 0.045, final  # from the start, 0.05, each its own way
    ckpt = trainer.checkpoint()
    assert float(ckpt["camera"]["vignetting"]) == pytest.approx(final[0.4])
    again = Trainer(photo, cfg, stage="finetune", iters=1, threads=1)
    again.load_init(ckpt)
    assert float(again.vignetting().detach()) == pytest.approx(0.05)  # per photo: not inherited


@pytest.mark.integration
def test_learned_offsets_move_a_saturated_output():
    """A specular output pinned near 0 by its pre-tanh value: with learned offsets a fine-tune lifts its level,
    without them it stays (the saturated tanh passes ~1 % of the gradient)."""
    photo, _ = synthetic_scene(size=48)
    base = resolve("tiny", iters_fit=40, lambda_render=1.0, eval_every=0, lambda_gan=0.0, lambda_fourier=0.0,
                   lambda_perceptual=0.0)
    levels = {}
    for learn in (False, True):
        trainer = Trainer(photo, TrainConfig.from_dict({**base.to_dict(), "photo.learn_offsets": learn, "optim.camera_lr": 5e-2}), threads=1)
        with torch.no_grad():
            trainer.generator.out_offset[5] = -4.0  # specular (tanh(-4) + 1) / 2 = 3e-4
        before = float(trainer.predict()[:, SLICES["specular"]].mean())
        trainer.run()
        levels[learn] = (before, float(trainer.predict()[:, SLICES["specular"]].mean()),
                         float(trainer.generator.out_offset[5].detach()))
    assert levels[True][2] > -3.5 and levels[True][1] > 3 * levels[True][0]
    assert levels[False][2] == -4.0  # not trained without learn_offsets


@pytest.mark.integration
def test_highlight_free_terms_are_logged_finite_and_the_render_term_falls():
    photo, _ = synthetic_scene(size=48)
    trainer = Trainer(photo, resolve("tiny", iters_fit=40, eval_every=5, **HIGHLIGHT_FREE), threads=1)
    history = trainer.run()
    for rec in history:
        for key in ("nr/render", "ds/render", "nr/flash", "ds/flash", "ds/diffuse"):
            assert rec[key] is not None and math.isfinite(rec[key]), (rec["step"], key)
    assert window_mean(history, "ds/render", 30, 40) < 0.85 * window_mean(history, "ds/render", 0, 10)
    off = Trainer(photo, resolve("tiny", iters_fit=1), threads=1)
    off.run()
    assert "nr/render" not in off.history[0] and "nr/flash" not in off.history[0]


@pytest.mark.integration
def test_seeded_runs_are_deterministic():
    photo = random_photo()
    runs = [Trainer(photo, resolve("tiny", iters_fit=3, seed=s), threads=1) for s in (5, 5, 6)]
    for t in runs:
        t.run()
    assert torch.equal(params(runs[0].generator), params(runs[1].generator))
    assert torch.equal(params(runs[0].discriminator), params(runs[1].discriminator))
    assert not torch.equal(params(runs[0].generator), params(runs[2].generator))


def test_encoder_frozen_unless_trained():
    photo = random_photo()
    frozen = Trainer(photo, resolve("tiny", iters_fit=2), threads=1)
    before = params(frozen.generator.encoder)
    frozen.run()
    assert torch.equal(before, params(frozen.generator.encoder))
    trained = Trainer(photo, resolve("tiny", iters_fit=2, train_encoder=True), threads=1)
    before = params(trained.generator.encoder)
    trained.run()
    assert not torch.equal(before, params(trained.generator.encoder))


@pytest.mark.parametrize("value", [0.0, 1.0])
def test_black_and_white_photos_stay_finite(value):
    photo = torch.full((1, 3, 32, 40), value)
    trainer = Trainer(photo, resolve("tiny", iters_fit=4, eval_every=2), threads=1)
    history = trainer.run()
    assert trainer.counters["nonfinite_skips"] == 0
    for rec in history:  # None marks a non-finite value; the first evaluation has no map change yet
        assert all(v is not None for k, v in rec.items() if not (k == "eval/map_change" and rec["step"] == 2))
    assert torch.isfinite(trainer.predict()).all()


def test_photo_checks():
    with pytest.raises(ImageError, match="at least"):
        Trainer(torch.rand(1, 3, 12, 64), resolve("tiny"), threads=1)
    with pytest.raises(ImageError, match="NaN"):
        Trainer(torch.full((1, 3, 32, 32), float("nan")), resolve("tiny"), threads=1)
    with pytest.raises(ImageError, match=r"\(1, 3, H, W\)"):
        Trainer(torch.rand(3, 32, 32), resolve("tiny"), threads=1)
    small = Trainer(torch.rand(1, 3, 40, 48), resolve("tiny", tile=64), threads=1)
    assert small.tile == 40 and any("clipped" in n for n in small.notes)


# ------------------------------------------------------------------ numerical guard
def test_nonfinite_loss_skips_the_step(monkeypatch):
    trainer = Trainer(random_photo(), resolve("tiny", iters_fit=1), threads=1)
    real = train_mod.fourier_loss
    calls = []

    def nan_once(*a, **k):
        calls.append(1)
        out = real(*a, **k)
        return out * float("nan") if len(calls) == 1 else out

    monkeypatch.setattr(train_mod, "fourier_loss", nan_once)
    nr, ds = params(trainer.generator.decoder_nr), params(trainer.generator.decoder_ds)
    rec = trainer.iteration()  # 1 NR step (NaN, skipped), 1 DS step, 1 D step
    assert rec["skipped"] == 1 and trainer.counters["nonfinite_skips"] == 1
    assert rec["nr/total"] is None and rec["ds/total"] is not None
    assert torch.equal(nr, params(trainer.generator.decoder_nr))
    assert not torch.equal(ds, params(trainer.generator.decoder_ds))


def test_nonfinite_gradient_skips_the_step(monkeypatch):
    trainer = Trainer(random_photo(), resolve("tiny", iters_fit=1), threads=1)
    real = train_mod.gan_discriminator_loss

    def infinite_grad(real_logits, fake_logits):
        zero = (real_logits - real_logits.detach()).sum()
        return real(real_logits, fake_logits) + zero.sqrt()  # value finite, d sqrt/dx at 0 is inf

    monkeypatch.setattr(train_mod, "gan_discriminator_loss", infinite_grad)
    d = params(trainer.discriminator)
    rec = trainer.iteration()
    assert rec["skipped"] == 1 and rec["d/loss"] is not None
    assert torch.equal(d, params(trainer.discriminator))
    assert all(p.grad is None for p in trainer.discriminator.parameters())


def test_repeated_nonfinite_steps_roll_back(monkeypatch):
    trainer = Trainer(random_photo(), resolve("tiny", iters_fit=2, guard_rollback_after=3), threads=1)
    trainer.iteration()
    trainer.guard.take_snapshot()
    good_g, good_d = params(trainer.generator), params(trainer.discriminator)
    trainer.iteration()  # moves away from the snapshot
    assert not torch.equal(good_g, params(trainer.generator))
    monkeypatch.setattr(train_mod, "gan_generator_loss", lambda logits: logits.sum() * float("nan"))
    monkeypatch.setattr(train_mod, "gan_discriminator_loss", lambda r, f: r.sum() * float("inf"))
    trainer.iteration()  # 3 non-finite steps in a row -> rollback
    assert trainer.counters == {"nonfinite_skips": 3, "rollbacks": 1}
    assert torch.equal(good_g, params(trainer.generator)) and torch.equal(good_d, params(trainer.discriminator))


# ------------------------------------------------------------------ stopping, stages, inference
def test_plateau_rule():
    trainer = Trainer(random_photo(), resolve("tiny", plateau_window=2, plateau_render_tol=0.05), threads=1)
    evals = lambda *v: [{"eval/render_l1": x, "eval/map_change": 0.01} for x in v]  # noqa: E731
    trainer.history = evals(0.10, 0.12, 0.099)
    assert trainer.plateaued()  # best of the last 2 (0.099) is not 5 % below the best before (0.10)
    trainer.history = evals(0.10, 0.12)
    assert not trainer.plateaued()  # not enough evaluations yet
    trainer.history = evals(0.20, 0.15, 0.10)
    assert not trainer.plateaued()  # still improving
    trainer.history = evals(0.10, 0.2, 0.2, 0.094)
    assert not trainer.plateaued()  # one good evaluation in the window is enough to go on
    trainer.history = [{"step": 1}] + evals(0.10) + [{"step": 2}] + evals(0.11, 0.10)
    assert trainer.plateaued()  # records without an evaluation are ignored


def test_quality_auto_stops_early():
    cfg = resolve("tiny", iters_fit=100, eval_every=2, plateau_window=2, quality="auto", plateau_render_tol=10.0)
    trainer = Trainer(random_photo(), cfg, threads=1)
    trainer.run()
    assert trainer.stopped_early and trainer.step == 6  # evaluations at 2, 4, 6: window of 2 after the first


def test_retired_settings_of_old_checkpoints_are_ignored():
    d = resolve("tiny").to_dict()
    assert TrainConfig.from_dict({**d, "plateau_change_tol": 0.002}) == TrainConfig.from_dict(d)
    with pytest.raises(ValueError, match="unknown training settings: bogus"):
        TrainConfig.from_dict({**d, "bogus": 1})


class _Pointwise(torch.nn.Module):
    """A per-pixel 'generator': tiling must not change its output."""

    def forward(self, x):
        n = torch.cat([x[:, :2] - 0.25, torch.ones_like(x[:, :1])], 1)
        return torch.cat([x, x[:, :1], x[:, 1:2], n / n.norm(dim=1, keepdim=True)], 1)


def test_predict_full_tiles_blend_seamlessly():
    photo = random_photo(50, 70)
    whole = predict_full(_Pointwise(), photo, max_side=128)
    tiled = predict_full(_Pointwise(), photo, max_side=32, overlap=8)
    assert tiled.shape == (1, 8, 50, 70)
    assert torch.allclose(whole, tiled, atol=1e-6)


def test_predict_full_real_generator_tiles():
    trainer = Trainer(random_photo(40, 72), resolve("tiny", predict_max_side=32, predict_overlap=8), threads=1)
    out = trainer.predict()
    assert out.shape == (1, 8, 40, 72) and torch.isfinite(out).all()
    assert torch.allclose(out[:, SLICES["normal"]].norm(dim=1), torch.ones(1, 40, 72), atol=1e-5)
    maps = train_mod.to_maps(out)
    assert maps.shape == (40, 72) and maps.diffuse.min() >= 0 and maps.diffuse.max() <= 1


def test_predict_maps_removes_the_flash_trend_only_where_the_preset_asks():
    from svbrdf.runtime.post.flash_trend import remove_flash_trend

    from svbrdf.runtime.quality.burn_in import photo_burn_in
    from svbrdf.runtime.post.flash_trend import uniform_specular

    for key in ("flash_trend", "uniform_specular", "highlight_fill"):
        assert getattr(resolve("fast").post, key) and not getattr(resolve("paper").post, key)
        assert not getattr(resolve("fast-v1").post, key)
    assert not resolve("fast").post.colour_from_photo  # the refine keeps the generator's base colour
    photo = random_photo(40, 56)
    for trend, uniform in ((False, False), (True, False), (False, True), (True, True)):
        trainer = Trainer(photo, resolve("tiny", post={"flash_trend": trend, "uniform_specular": uniform}), threads=1)
        raw = train_mod.to_maps(trainer.predict())
        maps = trainer.predict_maps({"x": 1})
        assert maps.meta["x"] == 1 and ("flash_trend" in maps.meta) == trend
        assert ("uniform_specular" in maps.meta) == uniform and ("burn_in_model" in maps.meta) == (trend or uniform)
        want = remove_flash_trend(raw, photo=photo[0].permute(1, 2, 0).numpy()) if trend else raw
        want = uniform_specular(want) if uniform else want
        for name in ("diffuse", "specular", "roughness", "normal"):
            assert (abs(getattr(maps, name) - getattr(want, name)).max()) < 1e-6, name
        # The burn-in of the maps returned, whatever ran (callers read it instead of scoring again).
        assert maps.meta["burn_in"] == photo_burn_in(maps, photo[0].permute(1, 2, 0).numpy())


def test_predict_maps_fills_a_clipped_highlight_where_the_preset_asks():
    from svbrdf.runtime.post.highlight_fill import fill_highlight

    photo = random_photo(64, 128)
    photo[:, :, 28:34, 30:36] = 1.0  # a clipped highlight
    for fill in (False, True):
        trainer = Trainer(photo, resolve("tiny", **{"post.highlight_fill": fill}), threads=1)
        raw = train_mod.to_maps(trainer.predict())
        maps = trainer.predict_maps()
        assert ("highlight_fill" in maps.meta) == fill
        want = fill_highlight(raw, photo[0].permute(1, 2, 0).numpy()) if fill else raw
        if fill:
            assert want.meta["highlight_fill"]["filled"] and maps.meta["highlight_fill"]["filled"]
            assert abs(maps.diffuse - raw.diffuse).max() > 1e-3  # something was filled
        for name in ("diffuse", "specular", "roughness", "normal"):
            assert (abs(getattr(maps, name) - getattr(want, name)).max()) < 1e-6, name


def test_bf16_switch_runs_or_falls_back():
    trainer = Trainer(random_photo(), resolve("tiny", iters_fit=2, bf16=True), threads=1)
    supported, _ = train_mod.bf16_support(trainer.device)
    assert trainer.bf16 == supported and (supported or any("bf16" in n for n in trainer.notes))
    history = trainer.run()
    assert all(h["ds/total"] is not None for h in history)


def test_log_file_has_one_json_line_per_iteration(tmp_path):
    log = tmp_path / "log.jsonl"
    Trainer(random_photo(), resolve("tiny", iters_fit=3), log_path=log, threads=1).run()
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert [l.get("event") for l in (lines[0], lines[-1])] == ["start", "stop"]
    assert [l["step"] for l in lines[1:-1]] == [1, 2, 3]


def test_perceptual_term_skipped_on_photos_without_a_clipped_highlight():
    cfg = resolve("tiny", perceptual_min_clipped=1e-3)
    dull = Trainer(random_photo(), cfg, threads=1)  # values in [0, 0.5]: nothing clipped
    assert dull.perceptual is None and any("perceptual loss skipped" in n for n in dull.notes)
    rec = dull.iteration()
    assert not any("perceptual" in k for k in rec) and "nr/fourier" in rec  # the Fourier term stays
    flash = random_photo()
    flash[..., 20:28, 28:36] = 1.0  # a saturated 8x8 highlight: 2 % of the photo
    lit = Trainer(flash, cfg, threads=1)
    assert lit.perceptual is not None and lit.clipped_fraction == pytest.approx(64 / (48 * 64))
    assert "nr/perceptual" in lit.iteration()
    assert Trainer(random_photo(), resolve("tiny"), threads=1).perceptual is not None  # 0 = never skipped


# ------------------------------------------------------------------------- the photo's context for U-Net tiles

def _unet_trainer(**kw):
    gen = {**resolve("tiny").generator.to_dict(), "arch": "unet", "decoder_blocks": 3}
    cfg = resolve("tiny", generator=gen, tile=32, schedule="joint", eval_every=0, **kw)
    return Trainer(random_photo(64, 96), cfg, threads=1)


def test_unet_tiles_train_with_the_whole_photo_context_refreshed_on_schedule():
    trainer = _unet_trainer(context_every=2)
    ctx = trainer._context()
    assert ctx is not None and ctx.size == (64, 96)
    torch.testing.assert_close(ctx.centre, trainer.generator.photo_context(trainer.photo).centre)
    trainer.iteration()
    assert trainer._context() is ctx  # step 1: the same block of two iterations
    trainer.iteration()
    assert trainer._context() is not ctx  # step 2: recomputed from the updated weights
    assert all(not g.requires_grad for gs in trainer._context().tracks.values() for g in gs)


def test_without_photo_context_unet_tiles_see_themselves_alone():
    trainer = _unet_trainer(photo_context=False)
    assert trainer._context() is None
    trainer.iteration()  # and still trains
    assert trainer.step == 1


def test_predict_full_unet_tiles_with_the_photo_context_agree_with_one_pass():
    from svbrdf.trainer.models import Generator, GeneratorConfig
    with torch.random.fork_rng():
        torch.manual_seed(0)
        g = Generator(GeneratorConfig(width=0.125, decoder_blocks=3, arch="unet")).eval()
    photo = random_photo(96, 128)
    whole = predict_full(g, photo, max_side=256)
    errs = {c: (predict_full(g, photo, max_side=64, overlap=16, context=c) - whole).abs().mean() for c in (True, False)}
    assert errs[True] < 0.05 * errs[False]


# ----------------------------------------------------------------------------- where the flash is over the photo

def test_flash_position_moves_the_camera_and_the_flash_over_the_photo():
    trainer = Trainer(random_photo(48, 64), resolve("tiny", flash_position=(0.5, -0.25)), threads=1)
    assert trainer.flash_xy == (0.5, -0.25)
    # the pixel under the flash (x = 0.5 -> column 48, y = -0.25 -> row 24 + 0.25 * 64 / 2 = 32) sees it head-on
    v = trainer.geometry.view[0, :, 32, 48]
    assert v[2] > 0.999 and torch.allclose(trainer.geometry.view, trainer.geometry.light)
    centred = Trainer(random_photo(48, 64), resolve("tiny"), threads=1)
    assert centred.flash_xy == (0.0, 0.0) and centred.geometry.view[0, 2, 24, 32] > 0.999
    with pytest.raises(ValueError, match="flash_position"):
        resolve("tiny", flash_position=[0.1])


def test_even_lighting_feeds_the_generator_the_evenly_lit_photo_and_the_losses_the_photo(monkeypatch):
    from svbrdf.runtime.post.flash_trend import even_lighting

    photo = random_photo(64, 96)
    cfg = resolve("tiny", tile=32, schedule="joint", eval_every=0, lambda_render=1.0, even_lighting=0.25)
    trainer = Trainer(photo, cfg, threads=1)
    want = even_lighting(photo[0].permute(1, 2, 0).numpy(), 0.25)
    torch.testing.assert_close(trainer.net_input[0].permute(1, 2, 0), torch.from_numpy(want))
    torch.testing.assert_close(trainer.photo, photo)  # the photo itself is kept for the losses
    seen, targets = [], []
    forward = trainer.generator.forward_features
    monkeypatch.setattr(trainer.generator, "forward_features", lambda x, *a, **k: seen.append(x) or forward(x, *a, **k))
    render_loss = train_mod.render_loss
    monkeypatch.setattr(train_mod, "render_loss", lambda r, x, *a: targets.append(x) or render_loss(r, x, *a))
    trainer.iteration()
    crops = lambda t: [t[..., y:y + 32, x:x + 32] for y in range(33) for x in range(65)]  # noqa: E731
    assert seen and all(any(torch.equal(s, c) for c in crops(trainer.net_input)) for s in seen)
    assert targets and all(any(torch.equal(t, c) for c in crops(trainer.photo)) for t in targets)
    # The final maps are the generator's on the evenly lit photo too.
    torch.testing.assert_close(trainer.predict(), predict_full(trainer.generator, trainer.net_input,
                                                                max_side=cfg.predict.max_side,
                                                                overlap=cfg.predict.overlap))
    # Off (0) in the paper's presets, and where a run sets it to 0: the generator sees the photo.
    for off in (resolve("tiny", tile=32, eval_every=0), resolve("fast", tile=32, eval_every=0, even_lighting=0)):
        t = Trainer(photo, off, threads=1)
        assert off.even_lighting == 0 and t.net_input is t.photo
