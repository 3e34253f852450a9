"""Checkpoints: self-describing, weights_only-loadable, clear errors, cleaning, exact resume."""

import pickle

import pytest
import torch

from svbrdf.runtime.errors import ModelError
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer.config import REFINE_RECIPES, resolve
from svbrdf.trainer.stage import make_trainer
from svbrdf.trainer.checkpoint import last_good_path
from svbrdf.trainer.train import Trainer


# threads=1: see tests/trainer/test_train.py.


def random_photo(h=48, w=64, seed=0):
    return torch.rand(1, 3, h, w, generator=torch.Generator().manual_seed(seed)) * 0.5


def state_tensors(trainer):
    """Every tensor of G, D and the three Adam states, in a fixed order."""
    out = list(trainer.generator.state_dict().values()) + list(trainer.discriminator.state_dict().values())
    for key in sorted(trainer.optimizers):
        for st in trainer.optimizers[key].state_dict()["state"].values():
            out += [st[k] for k in sorted(st)]
    if trainer.vignetting_logit is not None:
        out.append(trainer.vignetting_logit.detach())
    return out


@pytest.fixture
def trained(tmp_path):
    path = tmp_path / "run" / "checkpoint.pt"
    trainer = Trainer(random_photo(), resolve("tiny", iters_fit=2), checkpoint_path=path, threads=1)
    trainer.run()
    return trainer, path


def test_checkpoint_is_self_describing_and_weights_only(trained):
    trainer, path = trained
    ckpt = torch.load(path, weights_only=True)
    assert ckpt["format"] == ckpt_io.FORMAT and ckpt["format_version"] == ckpt_io.FORMAT_VERSION
    assert ckpt["stage"] == "fit" and ckpt["step"] == 2 and ckpt["iters"] == 2 and len(ckpt["history"]) == 2
    assert ckpt["train_config"] == trainer.config.to_dict()
    assert ckpt["generator_config"] == trainer.config.generator.to_dict()
    assert ckpt["photo"]["sha256"] == trainer.photo_info["sha256"] and ckpt["photo"]["width"] == 64
    assert set(ckpt["optimizers"]) == {"nr", "ds", "d"}
    assert isinstance(ckpt["rng"]["torch"], torch.Tensor) and isinstance(ckpt["rng"]["tiles"], torch.Tensor)
    assert {"torch", "numpy", "python", "svbrdf"} <= set(ckpt["versions"]) and ckpt["date"]
    assert ckpt["perceptual_backend"] == "pyramid"
    assert not list(path.parent.glob(".*.tmp*"))  # atomic write left no temp file


def test_load_generator_reproduces_the_trained_generator(trained):
    trainer, path = trained
    gen, meta = ckpt_io.load_generator(path)
    x = random_photo(32, 32, seed=7)
    with torch.no_grad():
        assert torch.equal(gen(x), trainer.generator(x))
    assert meta["step"] == 2 and "generator" not in meta and "optimizers" not in meta


def test_load_errors_are_model_errors(tmp_path, trained):
    _, good = trained
    with pytest.raises(ModelError, match="no such checkpoint"):
        ckpt_io.load_checkpoint(tmp_path / "missing.pt")
    corrupt = tmp_path / "corrupt.pt"
    corrupt.write_bytes(good.read_bytes()[:1000])
    with pytest.raises(ModelError, match="corrupt or unreadable"):
        ckpt_io.load_checkpoint(corrupt)
    foreign = tmp_path / "foreign.pt"
    torch.save({"state_dict": {"w": torch.zeros(2)}}, foreign)
    with pytest.raises(ModelError, match="not an svbrdf training checkpoint"):
        ckpt_io.load_checkpoint(foreign)
    pickled = tmp_path / "pickled.pt"
    with open(pickled, "wb") as f:
        pickle.dump({"format": ckpt_io.FORMAT, "obj": ModelError("x")}, f, protocol=2)
    with pytest.raises(ModelError, match="corrupt or unreadable"):  # refused by weights_only
        ckpt_io.load_checkpoint(pickled)
    newer = tmp_path / "newer.pt"
    ckpt = torch.load(good, weights_only=True)
    torch.save({**ckpt, "format_version": ckpt_io.FORMAT_VERSION + 1}, newer)
    with pytest.raises(ModelError, match="newer"):
        ckpt_io.load_checkpoint(newer)
    mismatched = tmp_path / "mismatched.pt"
    torch.save({**ckpt, "generator_config": {**ckpt["generator_config"], "width": 0.5}}, mismatched)
    with pytest.raises(ModelError, match="do not match"):
        ckpt_io.load_generator(mismatched)


def test_clean_checkpoint_drops_training_state(tmp_path, trained):
    _, path = trained
    dst = tmp_path / "clean.pt"
    ckpt_io.clean_checkpoint(path, dst)
    clean = torch.load(dst, weights_only=True)
    assert clean["optimizers"] is None and clean["rng"] is None and clean["discriminator"] is None
    assert dst.stat().st_size < path.stat().st_size
    gen, _ = ckpt_io.load_generator(dst)
    assert torch.equal(gen.state_dict()["decoder_nr.0.0.weight"],
                       torch.load(path, weights_only=True)["generator"]["decoder_nr.0.0.weight"])
    with pytest.raises(ModelError, match="exists"):
        ckpt_io.clean_checkpoint(path, dst)
    with pytest.raises(ModelError, match="cannot resume"):
        make_trainer(random_photo(), resume=dst, threads=1)


@pytest.mark.parametrize("key, value, record, bad, message", [
    ("network_input", "photo", {"mode": "photo", "even_lighting": 0.0}, "flat", "unknown network input 'flat'"),
    ("refine", "v2", REFINE_RECIPES["v2"], "v3", "unknown refine recipe 'v3'"),
])
def test_clean_checkpoint_records_what_a_stage_one_was_shipped_with(tmp_path, trained, key, value, record, bad, message):
    _, path = trained  # a fit: shown what it was trained on, no choice to record
    with pytest.raises(ModelError, match="for a stage one only"):
        ckpt_io.clean_checkpoint(path, tmp_path / "fit.pt", **{key: value})
    assert not (tmp_path / "fit.pt").exists()
    prior = torch.load(path, weights_only=True)
    prior["stage"] = "prior"
    ckpt_io.save_checkpoint(tmp_path / "prior.pt", prior)
    with pytest.raises(ValueError, match=message):
        ckpt_io.clean_checkpoint(tmp_path / "prior.pt", tmp_path / "a.pt", **{key: bad})
    assert not (tmp_path / "a.pt").exists()
    ckpt_io.clean_checkpoint(tmp_path / "prior.pt", tmp_path / "a.pt", **{key: value})
    assert ckpt_io.load_generator(tmp_path / "a.pt")[1][key] == record
    ckpt_io.clean_checkpoint(tmp_path / "a.pt", tmp_path / "b.pt")  # None keeps the record
    assert torch.load(tmp_path / "b.pt", weights_only=True)[key] == record


def test_clean_checkpoint_replaces_a_recorded_network_input(tmp_path, trained):
    prior = torch.load(trained[1], weights_only=True)
    prior["stage"] = "prior"
    ckpt_io.save_checkpoint(tmp_path / "prior.pt", prior)
    ckpt_io.clean_checkpoint(tmp_path / "prior.pt", tmp_path / "a.pt", network_input="photo")
    ckpt_io.clean_checkpoint(tmp_path / "a.pt", tmp_path / "b.pt", network_input="even")
    assert torch.load(tmp_path / "b.pt", weights_only=True)["network_input"] == {"mode": "even", "even_lighting": 0.25}


@pytest.mark.parametrize("extra", [{}, {"learn_vignetting": True, "learn_offsets": True, "lambda_render": 1.0,
                                        "saturate": True}],
                         ids=["paper-losses", "learned-camera"])
def test_resume_is_exact(tmp_path, extra):
    photo = random_photo()
    cfg = resolve("tiny", iters_fit=6, eval_every=2, checkpoint_every=0, **extra)
    straight = Trainer(photo, cfg, threads=1)
    straight.run()

    path = tmp_path / "checkpoint.pt"
    first = Trainer(photo, cfg, iters=3, checkpoint_path=path, threads=1)
    first.run()
    second = make_trainer(photo, resume=path, iters=6, threads=1)
    assert second.step == 3
    second.run()
    assert second.step == 6
    for a, b in zip(state_tensors(straight), state_tensors(second), strict=True):
        assert torch.allclose(a, b, rtol=0, atol=1e-6)
    strip = [{k: v for k, v in h.items() if k != "seconds"} for h in straight.history]
    assert strip == [{k: v for k, v in h.items() if k != "seconds"} for h in second.history]


def test_resume_refuses_another_photo(trained):
    _, path = trained
    with pytest.raises(ModelError, match="not on this photo"):
        make_trainer(random_photo(seed=1), resume=path, threads=1)


def test_last_good_copy_skips_checkpoints_after_nonfinite_steps(tmp_path):
    path = tmp_path / "checkpoint.pt"
    trainer = Trainer(random_photo(), resolve("tiny", iters_fit=3), checkpoint_path=path, threads=1)
    trainer.iteration()
    trainer.save()
    good = last_good_path(path)
    assert torch.load(good, weights_only=True)["step"] == 1
    trainer.iteration()
    trainer.counters["nonfinite_skips"] += 1  # as if a step had been skipped since the last save
    trainer.save()
    assert torch.load(path, weights_only=True)["step"] == 2
    assert torch.load(good, weights_only=True)["step"] == 1
    trainer.iteration()
    trainer.save()  # healthy again
    assert torch.load(good, weights_only=True)["step"] == 3


def test_save_refuses_non_checkpoints(tmp_path):
    with pytest.raises(ModelError, match="refusing"):
        ckpt_io.save_checkpoint(tmp_path / "x.pt", {"generator": {}})


@pytest.mark.parametrize("kind,name,off,on", [("train_config", "diffuse_weighting", "uniform", "explained"),
                                              ("train_config", "unexplained_ratio", 0.0, 2.0),
                                              ("train_config", "diffuse_robust", 0.0, 0.05),
                                              ("train_config", "locate_flash", False, True),
                                              ("refine", "locate_flash", False, True),
                                              ("prior_config", "crop_context", False, True)])
def test_a_retired_option_loads_at_its_off_value_and_fails_in_one_line_when_on(tmp_path, trained, kind, name, off,
                                                                              on):
    """Checkpoints from before the retired options were deleted record them; off they are dropped, on they fail."""
    _, path = trained
    ckpt = torch.load(path, weights_only=True)
    base = dict(ckpt.get(kind) or {})
    for value, ok in ((off, True), (on, False)):
        old = tmp_path / f"{kind}-{name}-{value}.pt"
        torch.save({**ckpt, kind: {**base, name: value}}, old)
        if ok:
            loaded = ckpt_io.load_checkpoint(old)
            assert name not in loaded[kind] and loaded[kind] == base
            if kind == "train_config":
                assert name not in make_trainer(random_photo(), resume=old, threads=1).config.to_dict()
        else:
            with pytest.raises(ModelError) as err:
                ckpt_io.load_checkpoint(old)
            msg = str(err.value)
            assert "\n" not in msg and f"retired option {name}={on!r}" in msg and str(old) in msg
