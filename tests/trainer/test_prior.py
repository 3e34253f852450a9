"""The procedural stage one (svbrdf.trainer.prior): photo simulation, losses, training, resume, fine-tune, CLI."""

import dataclasses
import json

import numpy as np
import pytest
import torch

from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.maps import SLICES
from svbrdf.trainer import cli
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer import train as train_mod
from svbrdf.trainer.stage import make_trainer
from svbrdf.trainer.config import resolve
from svbrdf.trainer.models import GeneratorConfig
from svbrdf.trainer.prior import (
    STAGE, PriorConfig, PriorTrainer, map_errors, prior_loss, resume_prior, sample_batch, simulate_photos,
)
from svbrdf.trainer.procedural import sample_materials


def tiny(**kw) -> PriorConfig:
    base = dict(generator=GeneratorConfig(width=0.125, train_encoder=True), size=32, photo_size=64, batch=2,
                iters=4, checkpoint_every=2, eval_every=2, eval_batch=2, render_lights=1)
    base.update(kw)
    return PriorConfig(**base)


@pytest.fixture(autouse=True)
def one_thread():
    old = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(old)


def test_config_round_trip_and_validation():
    c = tiny(families=None)
    assert PriorConfig.from_dict(json.loads(json.dumps(c.to_dict()))) == c
    with pytest.raises(ValueError, match="photo_size"):
        tiny(photo_size=16)
    with pytest.raises(ValueError, match="multiple"):
        tiny(size=34)
    with pytest.raises(ValueError, match="unknown families"):
        tiny(families=("marshmallow",))
    with pytest.raises(ValueError, match="unknown PriorConfig keys"):
        PriorConfig.from_dict({"nonsense": 1})


def test_simulated_photos_are_8bit_clipped_and_reproducible():
    cfg = tiny()
    maps, _ = sample_materials(3, 64, torch.Generator().manual_seed(1))
    a, ma, draws = simulate_photos(maps, cfg, torch.Generator().manual_seed(2))
    b, mb, _ = simulate_photos(maps, cfg, torch.Generator().manual_seed(2))
    assert a.shape == (3, 3, 64, 64) and torch.equal(a, b) and torch.equal(ma, maps)
    assert a.min() >= 0 and a.max() <= 1
    codes = linear_to_srgb(a.numpy()) * 255.0
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-2)  # stored as 8-bit sRGB (float32 round trip)
    for d in draws:
        assert cfg.fov_deg[0] <= d["fov_deg"] <= cfg.fov_deg[1]
        assert abs(d["light"][0]) <= cfg.light_offset and abs(d["light"][1]) <= cfg.light_offset
        assert cfg.camera["ev"][0] <= d["camera"]["ev"] <= cfg.camera["ev"][1]
    c, mc, _ = simulate_photos(maps, cfg, torch.Generator().manual_seed(3), crop=32)
    assert c.shape == (3, 3, 32, 32) and mc.shape == (3, 8, 32, 32)
    assert not torch.equal(c, a[..., :32, :32]) or not torch.equal(mc, maps[..., :32, :32])


def test_flash_photo_is_brightest_near_the_centre_on_a_flat_glossy_material():
    maps = torch.zeros(1, 8, 64, 64)
    maps[:, SLICES["diffuse"]] = 0.2
    maps[:, SLICES["specular"]] = 0.04
    maps[:, SLICES["roughness"]] = 0.3
    maps[:, SLICES["normal"]] = torch.tensor([0.0, 0.0, 1.0]).view(1, 3, 1, 1)
    photo, _, draws = simulate_photos(maps, tiny(camera={"ev": (0, 0), "vignetting": (0, 0), "shot": (0, 0),
                                                          "read": (0, 0)}), torch.Generator().manual_seed(0))
    lum = photo[0].mean(0)
    centre, corner = lum[24:40, 24:40].mean(), lum[:8, :8].mean()
    assert centre > 2 * corner  # highlight and inverse-square fall-off


def test_sample_batch_mixes_crops_and_whole_photos():
    cfg = tiny(batch=2, crop_share=0.5)
    rng = torch.Generator().manual_seed(0)
    kinds = set()
    for _ in range(8):
        photos, maps, info = sample_batch(cfg, rng)
        assert photos.shape == (2, 3, 32, 32) and maps.shape == (2, 8, 32, 32)
        kinds.add(info["crop"])
    assert kinds == {True, False}


def test_prior_loss_is_zero_on_the_truth_and_has_every_term():
    cfg = tiny()
    maps, _ = sample_materials(2, 32, torch.Generator().manual_seed(0))
    same = prior_loss(maps, maps, cfg, torch.Generator().manual_seed(0))
    assert set(same) == {"maps/diffuse", "maps/specular", "maps/roughness", "maps/normal", "render", "total"}
    assert float(same["total"]) == pytest.approx(0.0, abs=1e-6)
    other = maps.flip(0)
    assert float(prior_loss(other, maps, cfg, torch.Generator().manual_seed(0))["total"]) > 0.05
    errs = map_errors(maps, maps)
    assert errs["diffuse"] == 0 and errs["normal_deg"] < 0.1


def test_training_lowers_the_loss_on_a_repeated_batch():
    cfg = tiny(lr=2e-3, lr_min=2e-3, iters=40)
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


def test_interrupted_and_resumed_run_equals_an_uninterrupted_one(tmp_path):
    full = PriorTrainer(tiny(iters=4), threads=1)
    full.run()
    first = PriorTrainer(tiny(iters=4, checkpoint_every=0), threads=1, checkpoint_path=tmp_path / "c.pt",
                         log_path=tmp_path / "log.jsonl", callback=lambda tr, rec: rec["step"] == 2)  # Ctrl-C at 2
    first.run()
    assert first.interrupted
    ckpt = ckpt_io.load_checkpoint(tmp_path / "c.pt")
    assert ckpt["stage"] == STAGE and ckpt["step"] == 2 and ckpt["discriminator"] is None
    assert ckpt["train_config"]["preset"] == "fast" and ckpt["prior_config"]["iters"] == 4
    resumed = resume_prior(tmp_path / "c.pt", threads=1)
    assert resumed.step == 4
    for (k, a), (_, b) in zip(full.generator.state_dict().items(), resumed.generator.state_dict().items()):
        assert torch.equal(a, b), k
    assert [h["total"] for h in resumed.history] == [h["total"] for h in full.history]
    assert len(resumed.evals) == 2 and resumed.evals[-1]["step"] == 4
    lines = (tmp_path / "log.jsonl").read_text().splitlines()
    assert [json.loads(x)["step"] for x in lines] == [1, 2]


def test_learning_rate_decays_on_a_cosine():
    t = PriorTrainer(tiny(lr=1e-3, lr_min=1e-5, iters=100), threads=1)
    assert t.lr_at(0) == pytest.approx(1e-3) and t.lr_at(100) == pytest.approx(1e-5)
    assert t.lr_at(50) == pytest.approx(0.5 * (1e-3 + 1e-5))


def test_finetune_starts_from_a_prior_checkpoint(tmp_path):
    PriorTrainer(tiny(iters=1), threads=1, checkpoint_path=tmp_path / "p.pt").run()
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


def test_cli_trains_refuses_a_used_folder_and_resumes(tmp_path, capsys):
    out = tmp_path / "prior"
    args = ["prior", "--out", str(out), "--size", "32", "--photo-size", "64", "--batch", "1", "--width", "0.125",
            "--threads", "1", "--checkpoint-every", "1"]
    assert cli.main([*args, "--iters", "2"]) == 0
    err = capsys.readouterr().err
    assert "done: 2 iterations" in err and "prior: 2/2 [" in err and "loss " in err  # the plain progress line
    assert cli.main([*args, "--iters", "2"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not empty" in err[0] and "Traceback" not in err[0]
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "3", "--threads", "1"]) == 0
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["step"] == 3
    assert cli.main(["prior", "--out", str(tmp_path / "none"), "--resume"]) == 1
    assert "no checkpoint to resume from" in capsys.readouterr().err
    assert cli.main(["prior", "--out", str(tmp_path / "x"), "--size", "30"]) == 2
