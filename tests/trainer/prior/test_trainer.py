"""Training the stage one (trainer/prior/trainer.py): the loop, resume, time limit, checkpoints, the weights'
average, the fine-tune from a prior checkpoint."""

import json

import numpy as np
import pytest
import torch

from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer.config import resolve
from svbrdf.trainer.prior import STAGE, PriorTrainer, map_errors, prior_loss, resume_prior, sample_batch
from svbrdf.trainer.stage import make_trainer

pytestmark = pytest.mark.usefixtures("one_thread")


@pytest.mark.integration
def test_training_lowers_the_loss_on_a_repeated_batch(tiny):
    cfg = tiny({"optim.lr": 2e-3, "optim.lr_min": 2e-3, "optim.iters": 40})
    trainer = PriorTrainer(cfg, threads=1)
    photos, maps, _ = sample_batch(cfg, torch.Generator().manual_seed(5))
    losses = []
    for _ in range(40):
        pred = trainer.generator(photos)
        loss = prior_loss(pred, maps, cfg, torch.Generator().manual_seed(0))["total"]
        trainer.optimizer.zero_grad()
        loss.backward()
        trainer.optimizer.step()
        losses.append(float(loss.detach()))
    assert np.mean(losses[-5:]) < 0.7 * np.mean(losses[:5])


def test_interrupted_and_resumed_run_equals_an_uninterrupted_one(tmp_path, tiny):
    full = PriorTrainer(tiny({"optim.iters": 4}), threads=1)
    full.run()
    first = PriorTrainer(tiny({"optim.iters": 4, "monitor.checkpoint_every": 0}), threads=1,
                         checkpoint_path=tmp_path / "c.pt",
                         log_path=tmp_path / "log.jsonl", callback=lambda tr, rec: rec["step"] == 2)  # Ctrl-C at 2
    first.run()
    assert first.interrupted
    ckpt = ckpt_io.load_checkpoint(tmp_path / "c.pt")
    assert ckpt["stage"] == STAGE and ckpt["step"] == 2 and ckpt["discriminator"] is None
    assert ckpt["train_config"]["preset"] == "fast" and ckpt["prior_config"]["optim"]["iters"] == 4
    resumed = resume_prior(tmp_path / "c.pt", threads=1)
    assert resumed.step == 4
    for (k, a), (_, b) in zip(full.generator.state_dict().items(), resumed.generator.state_dict().items()):
        assert torch.equal(a, b), k
    assert [h["total"] for h in resumed.history] == [h["total"] for h in full.history]
    assert len(resumed.evals) == 2 and resumed.evals[-1]["step"] == 4
    lines = (tmp_path / "log.jsonl").read_text().splitlines()
    assert [json.loads(x)["step"] for x in lines] == [1, 2]


def test_learning_rate_decays_on_a_cosine(tiny):
    t = PriorTrainer(tiny({"optim.lr": 1e-3, "optim.lr_min": 1e-5, "optim.iters": 100}), threads=1)
    assert t.lr_at(0) == pytest.approx(1e-3) and t.lr_at(100) == pytest.approx(1e-5)
    assert t.lr_at(50) == pytest.approx(0.5 * (1e-3 + 1e-5))


@pytest.mark.integration
@pytest.mark.parametrize("compact_ckpt", [False, True])
def test_time_limited_and_resumed_run_reaches_the_same_step_and_schedule(tmp_path, compact_ckpt, tiny_v2):
    cfg = tiny_v2({"monitor.compact_checkpoint": compact_ckpt})
    full = PriorTrainer(cfg, threads=1)
    full.run()
    first = PriorTrainer(cfg, threads=1, checkpoint_path=tmp_path / "c.pt", log_path=tmp_path / "log.jsonl")
    first.run(max_seconds=0.0)  # stops after its first iteration, inside a log window (log_every = 2): a short record
    assert first.timed_out and not first.interrupted and first.step == 1
    ckpt = ckpt_io.load_checkpoint(tmp_path / "c.pt")
    assert ckpt["step"] == 1
    resumed = resume_prior(tmp_path / "c.pt", threads=1)
    assert resumed.step == full.step == cfg.optim.iters and not resumed.timed_out
    assert [h["step"] for h in resumed.history] == [1, 2, 4, 6]  # the records realign on multiples of log_every
    assert [h["lr"] for h in resumed.history[2:]] == [h["lr"] for h in full.history[1:]]  # the cosine goes on
    assert resumed.history[-1]["samples"] == 6 * cfg.optim.batch
    worst = max(float((a - b).abs().max()) for a, b in zip(full.generator.state_dict().values(),
                                                           resumed.generator.state_dict().values()))
    if compact_ckpt:
        assert 0 < worst < 1e-2  # float16 weights and bfloat16 moments: near, not equal
    else:
        assert worst == 0.0


def test_time_limit_stops_only_where_a_new_draw_of_materials_starts(tmp_path, tiny_v2):
    cfg = tiny_v2({"materials.reuse": 3, "monitor.log_every": 6, "monitor.compact_checkpoint": False})
    first = PriorTrainer(cfg, threads=1, checkpoint_path=tmp_path / "c.pt")
    first.run(max_seconds=0.0)
    assert first.timed_out and first.step == 3  # not 1: a resume would draw the reused materials anew
    full = PriorTrainer(cfg, threads=1)
    full.run()
    resumed = resume_prior(tmp_path / "c.pt", threads=1)
    assert resumed.step == full.step == cfg.optim.iters
    worst = max(float((a - b).abs().max()) for a, b in zip(full.generator.state_dict().values(),
                                                           resumed.generator.state_dict().values()))
    assert worst == 0.0


def test_material_reuse_photographs_the_same_materials_anew(monkeypatch, tiny_v2, tiny):
    from svbrdf.trainer.prior import trainer as prior_mod  # the module whose names PriorTrainer uses

    drawn = []
    real = prior_mod.draw_materials
    monkeypatch.setattr(prior_mod, "draw_materials", lambda *a, **k: drawn.append(1) or real(*a, **k))
    t = PriorTrainer(tiny_v2({"optim.iters": 6, "materials.reuse": 3, "monitor.log_every": 3,
                              "losses.render_views": 0}), threads=1)
    t.run()
    assert t.step == 6 and len(drawn) == 2
    with pytest.raises(ValueError, match="materials.reuse"):
        tiny({"materials.reuse": 0})


def test_a_non_finite_loss_in_the_batched_stream_leaves_the_weights_finite_and_is_counted(monkeypatch, tiny_v2):
    from svbrdf.trainer.prior import trainer as prior_mod  # the module whose names PriorTrainer uses

    real, calls = prior_mod.prior_loss, []

    def sometimes_nan(*a, **k):
        out = real(*a, **k)
        calls.append(1)
        if len(calls) == 2:
            out["total"] = out["total"] * float("nan")
        return out

    monkeypatch.setattr(prior_mod, "prior_loss", sometimes_nan)
    t = PriorTrainer(tiny_v2({"optim.iters": 4, "monitor.log_every": 4, "losses.render_views": 0}), threads=1)
    t.run()
    assert t.history[-1]["skipped"] == 1 and t.history[-1]["total"] is not None
    assert all(torch.isfinite(p).all() for p in t.generator.parameters())


def _recording_grads(trainer):
    """Make ``trainer`` keep a copy of every gradient its optimiser steps on (one dict per step)."""
    seen, step = [], trainer.optimizer.step

    def recorded(*a, **k):
        seen.append({n: p.grad.detach().clone() for n, p in trainer.generator.named_parameters() if p.grad is not None})
        return step(*a, **k)

    trainer.optimizer.step = recorded
    return seen


def test_on_a_cpu_the_generator_trains_channels_last_with_the_same_result(tiny):
    """Channels-last and the plain layout sum in other orders, so they agree to float32 rounding, not bit for bit.

    What is stable across CPUs is compared tightly: the losses, and the first step's gradients (same weights, same
    batch) to 1e-4 of each tensor's largest gradient. Adam's first step is ``lr * g / (|g| + eps)``, about
    ``lr * sign(g)``: where a gradient is within rounding of zero its sign, and so a whole ``lr`` step, may differ
    between the layouts (on some CPUs of our kind it does). So the weights after one step must agree to rounding
    where the gradient is clear of that noise, and everywhere within twice the two steps' size (each Adam step moves
    an element at most about ``lr``, one way in one layout and the other way in the other)."""
    cfg = tiny({"optim.iters": 2, "monitor.checkpoint_every": 0, "monitor.eval_every": 0})
    fast = PriorTrainer(cfg, threads=1, device="cpu")
    assert fast.memory_format == torch.channels_last
    conv = next(p for p in fast.generator.parameters() if p.dim() == 4 and p.shape[-1] > 1)
    assert conv.is_contiguous(memory_format=torch.channels_last) and not conv.is_contiguous()
    plain = PriorTrainer(cfg, threads=1, device="cpu")
    plain.memory_format = torch.contiguous_format
    plain.generator.to(memory_format=torch.contiguous_format)
    grads = {"fast": _recording_grads(fast), "plain": _recording_grads(plain)}
    start = {k: v.clone() for k, v in fast.generator.state_dict().items()}
    assert all(torch.equal(start[k], v) for k, v in plain.generator.state_dict().items())
    fast.iteration(), plain.iteration()
    after_one = {"fast": {k: v.clone() for k, v in fast.generator.state_dict().items()},
                 "plain": {k: v.clone() for k, v in plain.generator.state_dict().items()}}
    fast.run()
    plain.run()
    assert fast.step == plain.step == 2
    assert [h["total"] for h in fast.history] == pytest.approx([h["total"] for h in plain.history], rel=1e-4)
    g_fast, g_plain = grads["fast"][0], grads["plain"][0]
    assert g_fast.keys() == g_plain.keys() and g_fast
    stable = 0
    for k, a in g_fast.items():
        b = g_plain[k]
        noise = 1e-4 * float(b.abs().max()) + 1e-12
        torch.testing.assert_close(a, b, rtol=1e-3, atol=noise, msg=k)
        clear = b.abs() > 10 * noise
        w_fast, w_plain = after_one["fast"][k], after_one["plain"][k]
        torch.testing.assert_close(w_fast[clear], w_plain[clear], rtol=1e-5, atol=1e-6, msg=k)
        stable += int(clear.sum())
    total = sum(g.numel() for g in g_plain.values())
    assert stable > 0.5 * total, (stable, total)  # most of the weights are compared tightly
    bound = 2 * 1.01 * (fast.lr_at(0) + fast.lr_at(1))
    for (k, a), (_, b) in zip(fast.generator.state_dict().items(), plain.generator.state_dict().items()):
        assert float((a - b).abs().max()) <= bound, k
        assert float((a - start[k]).abs().max()) > 0 or k not in g_plain, k  # every trained tensor moved


def test_compact_checkpoint_of_the_v2_generator_is_under_16_mib(tmp_path, tiny_v2):
    sizes = {}
    for compact_ckpt in (False, True):
        t = PriorTrainer(tiny_v2({"optim.iters": 1, "monitor.log_every": 1, "losses.render_views": 0,
                                  "monitor.compact_checkpoint": compact_ckpt}),
                         threads=1, checkpoint_path=tmp_path / f"{compact_ckpt}.pt")
        t.run()
        sizes[compact_ckpt] = (tmp_path / f"{compact_ckpt}.pt").stat().st_size
        assert t.checkpoint()["generator_config"]["arch"] == "unet"
    assert sizes[True] < 16 * 2 ** 20
    assert sizes[True] < 0.6 * sizes[False]
    gen = ckpt_io.load_generator(tmp_path / "True.pt")[0]  # a compact checkpoint still rebuilds the generator
    assert gen.cfg.arch == "unet" and next(gen.parameters()).dtype == torch.float32


def test_finetune_starts_from_a_prior_checkpoint(tmp_path, tiny):
    PriorTrainer(tiny({"optim.iters": 1}), threads=1, checkpoint_path=tmp_path / "p.pt").run()
    rng = np.random.default_rng(0)
    photo = torch.from_numpy(rng.random((1, 3, 48, 48), dtype=np.float32) * 0.5)
    cfg = resolve("tiny", iters_finetune=2)
    trainer = make_trainer(photo, "finetune", cfg, init=tmp_path / "p.pt", threads=1)
    trainer.run()
    assert trainer.step == 2
    prior = ckpt_io.load_checkpoint(tmp_path / "p.pt")
    assert trainer.generator.cfg.width == prior["generator_config"]["width"]
    assert any("no discriminator" in n for n in trainer.notes)
    assert trainer.init["stage"] == STAGE


def test_finetune_starts_from_a_unet_prior(tmp_path, tiny_v2):
    PriorTrainer(tiny_v2({"optim.iters": 1, "monitor.log_every": 1}), threads=1,
                 checkpoint_path=tmp_path / "p.pt").run()
    photo = torch.from_numpy(np.random.default_rng(0).random((1, 3, 48, 48), dtype=np.float32) * 0.5)
    trainer = make_trainer(photo, "finetune", resolve("tiny", iters_finetune=1), init=tmp_path / "p.pt", threads=1)
    trainer.run()
    assert trainer.step == 1 and trainer.generator.cfg.arch == "unet"


def _floats(module) -> dict:
    return {k: v.detach().clone() for k, v in module.state_dict().items() if v.is_floating_point()}


def test_the_moving_average_is_the_ema_of_the_trained_weights_and_what_the_checkpoint_gives(tmp_path, tiny_v2):
    """``optim.ema``: after every step average = decay * average + (1 - decay) * weights (the first step copies); it is
    :attr:`PriorTrainer.model`, the checkpoint's ``generator_ema`` and what every consumer of the checkpoint loads."""
    tr = PriorTrainer(tiny_v2({"optim.ema": 0.75, "optim.iters": 3}), threads=1)
    assert tr.model is tr.generator  # nothing averaged yet
    want = None
    for _ in range(3):
        tr.iteration()
        w = _floats(tr.generator)
        want = w if want is None else {k: 0.75 * want[k] + 0.25 * w[k] for k in w}
    got = _floats(tr.model)
    assert tr.model is tr.averaged.module
    for k in want:
        torch.testing.assert_close(got[k], want[k], rtol=1e-5, atol=1e-6)
    assert max(float((got[k] - w[k]).abs().max()) for k in w) > 0  # not the trained weights
    path = tr.save(tmp_path / "c.pt")
    ckpt = ckpt_io.load_checkpoint(path)
    assert ckpt["ema_updates"] == 3
    loaded = _floats(ckpt_io.generator_from_checkpoint(ckpt))
    for k in want:  # (v2 checkpoints are compact: float16 weights)
        torch.testing.assert_close(loaded[k], got[k], rtol=2e-3, atol=1e-4)
    clean = ckpt_io.load_checkpoint(ckpt_io.clean_checkpoint(path, tmp_path / "clean.pt"))
    assert "generator_ema" not in clean
    k = next(iter(want))
    torch.testing.assert_close(clean["generator"][k].float(), got[k], rtol=2e-3, atol=1e-4)
    with torch.no_grad():
        assert tr.evaluate() == map_errors(tr.model(tr.eval_set()[0]), tr.eval_set()[1])
    plain = PriorTrainer(tiny_v2({"optim.iters": 1}), threads=1)
    plain.iteration()
    assert plain.averaged is None and plain.model is plain.generator and "generator_ema" not in plain.checkpoint()


@pytest.mark.integration
def test_a_resume_keeps_the_average_and_a_resume_that_turns_it_on_starts_it_at_the_resumed_weights(tmp_path, tiny_v2):
    cfg = tiny_v2({"optim.ema": 0.75, "optim.iters": 4,
                   "monitor.compact_checkpoint": False})  # (compact: float16 weights, not exact)
    whole = PriorTrainer(cfg, threads=1)
    whole.run()
    first = PriorTrainer(cfg, threads=1, checkpoint_path=tmp_path / "a.pt")
    for _ in range(2):
        first.iteration()
    first.save()
    resumed = resume_prior(tmp_path / "a.pt", threads=1)
    a, b = _floats(whole.model), _floats(resumed.model)
    assert resumed.step == 4 and max(float((a[k] - b[k]).abs().max()) for k in a) < 1e-5
    off = PriorTrainer(tiny_v2({"optim.iters": 4}), threads=1, checkpoint_path=tmp_path / "b.pt")
    off.iteration()
    off.save()
    ckpt = ckpt_io.load_checkpoint(tmp_path / "b.pt")
    on = PriorTrainer(tiny_v2({"optim.ema": 0.75, "optim.iters": 4}), threads=1)
    on.load_resume(ckpt, tmp_path / "b.pt")
    assert on.model is on.generator  # until its first update
    on.iteration()
    w, m = _floats(on.generator), _floats(on.model)
    assert all(torch.equal(w[k], m[k]) for k in w)  # the first update copies the weights it resumed and trained
