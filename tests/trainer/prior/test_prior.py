"""The procedural stage one (svbrdf.trainer.prior): photo simulation, losses, training, resume, fine-tune, CLI."""

import contextlib
import dataclasses
import json
import math
import os
import shutil
import signal
import traceback

import numpy as np
import pytest
import torch
from torch.utils._python_dispatch import TorchDispatchMode

from svbrdf.runtime.core.colour import linear_to_srgb
from svbrdf.runtime.core.maps import SLICES
from svbrdf.trainer import cli
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer import train as train_mod
from svbrdf.trainer.stage import make_trainer
from svbrdf.trainer.config import resolve
from svbrdf.trainer.models import Generator, GeneratorConfig
from svbrdf.trainer.prior import (
    STAGE, PriorConfig, PriorTrainer, map_errors, prior_loss, prior_preset, resume_prior, sample_batch,
    simulate_photos, view_light_directions,
)
from svbrdf.trainer.device import to_device
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


@pytest.mark.integration
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


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_cli_stops_after_the_current_iteration_on_ctrl_c_or_sigterm(tmp_path, capsys, monkeypatch, sig):
    """With a log record every 50 iterations, a signal at iteration 3 still stops at 3: checkpoint, exit 130,
    the caller's handlers back; resuming continues from 3."""
    real = PriorTrainer._step

    def signalled_at_3(self):
        rec = real(self)
        if self.step == 3:
            os.kill(os.getpid(), getattr(signal, sig))
        return rec

    monkeypatch.setattr(PriorTrainer, "_step", signalled_at_3)
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    out = tmp_path / "v2"
    args = ["prior", "--preset", "v2", "--out", str(out), "--size", "32", "--photo-size", "64", "--batch", "1",
            "--threads", "1", "--iters", "100", "--log-every", "50", "--eval-every", "0"]
    assert cli.main(args) == 130
    assert "interrupted at iteration 3/100" in capsys.readouterr().err
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["step"] == 3
    assert {s: signal.getsignal(s) for s in before} == before
    monkeypatch.setattr(PriorTrainer, "_step", real)
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "4", "--threads", "1"]) == 0
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["step"] == 4


# ------------------------------------------------------------------------------------------- GPU scale (issue 26)

def tiny_v2(**kw) -> PriorConfig:
    """The v2 recipe (U-Net, batched stream, bf16, views, detail term, averaged log) at test size."""
    base = dict(size=32, photo_size=64, batch=2, iters=6, checkpoint_every=0, eval_every=0, eval_batch=2,
                log_every=2, render_views=2, bf16=False)
    base.update(kw)
    return dataclasses.replace(prior_preset("v2"), **base)


def test_v1_preset_is_the_default_and_v2_changes_only_what_it_names():
    assert prior_preset("v1") == PriorConfig()
    v1, v2 = PriorConfig(), prior_preset("v2")
    assert (v1.render_views, v1.lambda_grad, v1.batched, v1.bf16, v1.log_every, v1.compact_checkpoint) == \
        (0, 0.0, False, False, 1, False)
    assert v2.generator.arch == "unet" and v2.batched and v2.compact_checkpoint and v2.render_views > 0
    assert PriorConfig.from_dict(json.loads(json.dumps(v2.to_dict()))) == v2
    with pytest.raises(ValueError, match="unknown prior preset"):
        prior_preset("v3")
    with pytest.raises(ValueError, match="grazing_deg"):
        tiny(grazing_deg=(70.0, 95.0))


def test_view_light_directions_honour_the_grazing_range_and_mirror_every_other_pair():
    rng = torch.Generator().manual_seed(3)
    deg = lambda d: torch.rad2deg(torch.acos(d[..., 2]))  # noqa: E731
    graze = view_light_directions(20, tiny(grazing_share=1.0), rng)
    assert graze.shape == (20, 2, 3) and torch.allclose(graze.norm(dim=-1), torch.ones(20, 2))
    assert deg(graze).min() >= 60.0 - 1e-4 and deg(graze).max() <= 75.0 + 1e-4
    steep = view_light_directions(20, tiny(grazing_share=0.0), rng)
    assert deg(steep).max() < 60.0
    mirrored = graze[1::2]
    assert torch.allclose(mirrored[:, 1, :2], -mirrored[:, 0, :2]) and torch.allclose(mirrored[:, 1, 2],
                                                                                      mirrored[:, 0, 2])


def test_v2_loss_has_the_detail_term_and_more_renderings():
    cfg = tiny_v2()
    photos, maps, _ = sample_batch(cfg, torch.Generator().manual_seed(0))
    same = prior_loss(maps, maps, cfg, torch.Generator().manual_seed(1))
    assert set(same) >= {"render", "grad", "total"} and float(same["total"]) == pytest.approx(0.0, abs=1e-6)
    other = maps.flip(-1)
    v1_terms = prior_loss(other, maps, dataclasses.replace(cfg, render_views=0, lambda_grad=0.0),
                          torch.Generator().manual_seed(1))
    assert "grad" not in v1_terms
    terms = prior_loss(other, maps, cfg, torch.Generator().manual_seed(1))
    assert float(terms["grad"]) > 0 and float(terms["total"]) > float(v1_terms["total"])
    assert cfg.lambda_amount == 2.0 and cfg.amount_maps == ("roughness",) and cfg.amount_windows == (32,)
    cfg = dataclasses.replace(cfg, lambda_amount=0.0, amount_maps=("normal", "roughness"), amount_windows=(16, 64))
    terms = prior_loss(other, maps, cfg, torch.Generator().manual_seed(1))
    assert "amount" not in terms  # off at weight 0 (v1, the first v2)
    amount = prior_loss(other, maps, dataclasses.replace(cfg, lambda_amount=2.0), torch.Generator().manual_seed(1))
    assert float(amount["amount"]) >= 0
    assert float(amount["total"]) == pytest.approx(float(terms["total"]) + 2.0 * float(amount["amount"]), rel=1e-5)
    rough = prior_loss(other, maps, dataclasses.replace(cfg, lambda_amount=2.0, amount_maps=("roughness",)),
                       torch.Generator().manual_seed(1))
    assert float(rough["amount"]) != pytest.approx(float(amount["amount"]))  # its own maps only
    with pytest.raises(ValueError, match="lambda_amount"):
        tiny_v2(lambda_amount=-1.0)
    with pytest.raises(ValueError, match="amount_maps"):
        tiny_v2(amount_maps=("bumps",))
    small = prior_loss(other, maps, dataclasses.replace(cfg, lambda_amount=2.0, amount_windows=(4,)),
                       torch.Generator().manual_seed(1))
    assert float(small["amount"]) != pytest.approx(float(amount["amount"]))  # its own windows
    with pytest.raises(ValueError, match="amount_windows"):
        tiny_v2(amount_windows=(1,))
    v2 = tiny_v2(lambda_amount=1.0, amount_maps=["roughness"], amount_windows=[16])
    assert v2.amount_maps == ("roughness",) and v2.amount_windows == (16,)
    assert PriorConfig.from_dict(json.loads(json.dumps(v2.to_dict()))) == v2


def test_batched_photos_follow_the_same_photo_model():
    cfg = tiny_v2(crop_share=0.0)
    photos, maps, info = sample_batch(cfg, torch.Generator().manual_seed(4))
    assert photos.shape == (2, 3, 32, 32) and maps.shape == (2, 8, 32, 32)
    assert photos.min() >= 0 and photos.max() <= 1 and len(info["draws"]) == 2
    codes = linear_to_srgb(photos.numpy()) * 255.0
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-2)  # 8-bit sRGB like the numpy camera
    again, _, _ = sample_batch(cfg, torch.Generator().manual_seed(4))
    assert torch.equal(photos, again)
    crops, cmaps, _ = sample_batch(tiny_v2(crop_share=1.0), torch.Generator().manual_seed(4))
    assert crops.shape == (2, 3, 32, 32) and cmaps.shape == (2, 8, 32, 32)


@pytest.mark.integration
@pytest.mark.parametrize("compact_ckpt", [False, True])
def test_time_limited_and_resumed_run_reaches_the_same_step_and_schedule(tmp_path, compact_ckpt):
    cfg = tiny_v2(compact_checkpoint=compact_ckpt)
    full = PriorTrainer(cfg, threads=1)
    full.run()
    first = PriorTrainer(cfg, threads=1, checkpoint_path=tmp_path / "c.pt", log_path=tmp_path / "log.jsonl")
    first.run(max_seconds=0.0)  # stops after its first iteration, inside a log window (log_every = 2): a short record
    assert first.timed_out and not first.interrupted and first.step == 1
    ckpt = ckpt_io.load_checkpoint(tmp_path / "c.pt")
    assert ckpt["step"] == 1
    resumed = resume_prior(tmp_path / "c.pt", threads=1)
    assert resumed.step == full.step == cfg.iters and not resumed.timed_out
    assert [h["step"] for h in resumed.history] == [1, 2, 4, 6]  # the records realign on multiples of log_every
    assert [h["lr"] for h in resumed.history[2:]] == [h["lr"] for h in full.history[1:]]  # the cosine goes on
    assert resumed.history[-1]["samples"] == 6 * cfg.batch
    worst = max(float((a - b).abs().max()) for a, b in zip(full.generator.state_dict().values(),
                                                           resumed.generator.state_dict().values()))
    if compact_ckpt:
        assert 0 < worst < 1e-2  # float16 weights and bfloat16 moments: near, not equal
    else:
        assert worst == 0.0


def test_time_limit_stops_only_where_a_new_draw_of_materials_starts(tmp_path):
    cfg = tiny_v2(material_reuse=3, log_every=6, compact_checkpoint=False)
    first = PriorTrainer(cfg, threads=1, checkpoint_path=tmp_path / "c.pt")
    first.run(max_seconds=0.0)
    assert first.timed_out and first.step == 3  # not 1: a resume would draw the reused materials anew
    full = PriorTrainer(cfg, threads=1)
    full.run()
    resumed = resume_prior(tmp_path / "c.pt", threads=1)
    assert resumed.step == full.step == cfg.iters
    worst = max(float((a - b).abs().max()) for a, b in zip(full.generator.state_dict().values(),
                                                           resumed.generator.state_dict().values()))
    assert worst == 0.0


def test_compact_checkpoint_of_the_v2_generator_is_under_16_mib(tmp_path):
    sizes = {}
    for compact_ckpt in (False, True):
        t = PriorTrainer(tiny_v2(iters=1, log_every=1, render_views=0, compact_checkpoint=compact_ckpt),
                         threads=1, checkpoint_path=tmp_path / f"{compact_ckpt}.pt")
        t.run()
        sizes[compact_ckpt] = (tmp_path / f"{compact_ckpt}.pt").stat().st_size
        assert t.checkpoint()["generator_config"]["arch"] == "unet"
    assert sizes[True] < 16 * 2 ** 20
    assert sizes[True] < 0.6 * sizes[False]
    gen = ckpt_io.load_generator(tmp_path / "True.pt")[0]  # a compact checkpoint still rebuilds the generator
    assert gen.cfg.arch == "unet" and next(gen.parameters()).dtype == torch.float32


def test_finetune_starts_from_a_unet_prior(tmp_path):
    PriorTrainer(tiny_v2(iters=1, log_every=1), threads=1, checkpoint_path=tmp_path / "p.pt").run()
    photo = torch.from_numpy(np.random.default_rng(0).random((1, 3, 48, 48), dtype=np.float32) * 0.5)
    trainer = make_trainer(photo, "finetune", resolve("tiny", iters_finetune=1), init=tmp_path / "p.pt", threads=1)
    trainer.run()
    assert trainer.step == 1 and trainer.generator.cfg.arch == "unet"


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_cuda_stream_stays_on_the_device_and_trains():
    cfg = tiny_v2(bf16=True)
    rng = torch.Generator().manual_seed(0)
    sample_batch(cfg, rng, device="cuda")
    torch.cuda.set_sync_debug_mode("error")  # any read-back from the GPU raises
    try:
        photos, maps, _ = sample_batch(cfg, rng, device="cuda")
    finally:
        torch.cuda.set_sync_debug_mode("default")
    assert photos.is_cuda and maps.is_cuda
    cpu_maps, _ = sample_materials(2, 64, torch.Generator().manual_seed(5))
    gpu_maps, _ = sample_materials(2, 64, torch.Generator().manual_seed(5), device="cuda")
    torch.testing.assert_close(gpu_maps.cpu(), cpu_maps, atol=1e-3, rtol=0)  # one stream on every device
    trainer = PriorTrainer(cfg, device="cuda")
    trainer.run()
    assert trainer.step == cfg.iters and trainer.bf16


class _HostReads(TorchDispatchMode):
    """Records, on the meta device (a device with no data, standing in for a GPU), every operation that would make
    the host wait for a GPU: a device value read on the host (``item``, ``int``, ``bool``...), an output whose
    shape depends on device values (``nonzero``, boolean masks), a Python scalar written into a device tensor
    (on CUDA an unpinned host-to-device copy) and any host-to-device copy not staged by ``to_device``."""

    def __init__(self):
        super().__init__()
        self.found = []

    def _note(self, what):
        stack = [f for f in traceback.extract_stack()
                 if ("svbrdf" in f.filename or "/trainer/" in f.filename) and "/tests/" not in f.filename]
        self.found.append(f"{what} at {stack[-1].filename.rsplit('/', 1)[-1]}:{stack[-1].lineno}" if stack else what)

    def __enter__(self):  # `x[i] = 0.5` on a CUDA tensor builds 0.5 on the host and copies it (a wait for a 0-d x[i])
        setitem = self._setitem = torch.Tensor.__setitem__
        probe = self

        def checked(tensor, index, value):
            if tensor.device.type == "meta" and isinstance(value, (bool, int, float)):
                probe._note("a Python scalar written into a device tensor")
            return setitem(tensor, index, value)

        torch.Tensor.__setitem__ = checked
        return super().__enter__()

    def __exit__(self, *exc):
        torch.Tensor.__setitem__ = self._setitem
        return super().__exit__(*exc)

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        name = func.overloadpacket.__name__
        meta = lambda t: isinstance(t, torch.Tensor) and t.device.type == "meta"  # noqa: E731
        if name in ("_local_scalar_dense", "nonzero", "masked_select", "_unique2", "unique_dim") and meta(args[0]):
            self._note(name)
        elif name in ("index", "index_put_") and any(meta(i) and i.dtype == torch.bool for i in args[1] if i is not None):
            self._note(f"{name} with a boolean mask")
        elif name in ("_to_copy", "copy_") and any(isinstance(a, torch.Tensor) and a.device.type == "cpu"
                                                  for a in args[:2]) and (
                str(kwargs.get("device")) == "meta" or meta(args[0])):
            if not any(f.name == "to_device" for f in traceback.extract_stack()):
                self._note("a host-to-device copy outside to_device")
        if name == "_local_scalar_dense" and meta(args[0]):  # a meta tensor has no value: go on with a plausible one
            return True if args[0].dtype == torch.bool else 1 if not args[0].dtype.is_floating_point else 0.5
        if name == "nonzero" and meta(args[0]):  # no data-independent shape: say nothing is non-zero
            return torch.empty(0, args[0].dim(), dtype=torch.long, device="meta")
        return func(*args, **kwargs)


def _meta_training_steps(monkeypatch, cfg, steps: int = 3) -> list:
    """``steps`` training steps as PriorTrainer takes them (batch, network, loss, backward, Adam) on the meta device,
    each under :class:`_HostReads`: asserts that none reads a value back to the host; returns the batches' infos."""
    generator = torch.Generator

    class OnTheHostForMeta:  # torch.Generator(device="meta") does not exist; its draws are the host's
        def __new__(cls, device=None):
            return generator() if device is None or str(device) == "meta" else generator(device=device)

    monkeypatch.setattr(torch, "Generator", OnTheHostForMeta)
    autocast = torch.autocast
    monkeypatch.setattr(torch, "autocast", lambda device_type=None, *a, **k: contextlib.nullcontext()
                        if device_type == "meta" else autocast(device_type, *a, **k))
    net = Generator(cfg.generator).to("meta")
    adam = torch.optim.Adam(net.parameters(), lr=1e-3)
    rng = generator().manual_seed(2)
    infos = []
    for _ in range(steps):
        with _HostReads() as probe:
            photos, maps, info = sample_batch(cfg, rng, device="meta")
            terms = prior_loss(net(photos).float(), maps, cfg, rng)
            adam.zero_grad(set_to_none=True)
            terms["total"].backward()
            adam.step()
        assert photos.device.type == "meta" and photos.shape == (cfg.batch, 3, cfg.size, cfg.size)
        assert maps.shape == (cfg.batch, 8, cfg.size, cfg.size)
        assert probe.found == [], probe.found[:5]
        infos.append(info)
    return infos


@pytest.mark.integration
def test_the_v2_batch_and_loss_never_make_a_gpu_wait(monkeypatch):
    # The GPU chunks counted 73 host synchronisations per batch (git show bc3896e:./docs/benchmarks/prior-v2/README.md):
    # each one stops the host until the GPU has run everything queued, so the batch cannot be built while the network
    # trains. Checked on the CPU by taking training steps on the meta device.
    infos = _meta_training_steps(monkeypatch, dataclasses.replace(prior_preset("v2"), flat_share=0.5))  # flat too
    assert {i["crop"] for i in infos} == {True, False}  # crops of larger photos and whole photos


@pytest.mark.integration
def test_the_device_stream_batch_and_loss_never_make_a_gpu_wait(monkeypatch):
    # The device stream (issue 64): every family, share and camera draw on the device, nothing read back.
    cfg = dataclasses.replace(prior_preset("v2"), stream="device", flat_share=0.3, black_share=0.3, coarse_share=0.3,
                              camera={**prior_preset("v2").camera, "white": (1.0, 4.0)})
    infos = _meta_training_steps(monkeypatch, cfg)
    assert {i["crop"] for i in infos} == {True, False}
    assert len({f for i in infos for f in i["families"]}) >= 10


def test_the_host_read_probe_sees_what_it_looks_for():
    x = torch.zeros(4, 4, device="meta")
    with _HostReads() as probe:
        x.sum().item()
        x[0, 0] = 1.0
        x.nonzero()
        torch.ones(2).to("meta")
        to_device(torch.ones(2), "meta")
    assert [f.split(" at ")[0] for f in probe.found] == [
        "_local_scalar_dense", "a Python scalar written into a device tensor", "nonzero",
        "a host-to-device copy outside to_device"], probe.found


def test_cli_time_limit_resume_from_a_file_and_bad_input(tmp_path, capsys):
    out = tmp_path / "v2"
    args = ["prior", "--preset", "v2", "--out", str(out), "--size", "32", "--photo-size", "64", "--batch", "1",
            "--threads", "1", "--iters", "50", "--log-every", "2", "--eval-every", "0"]
    assert cli.main([*args, "--minutes", "0.0001"]) == 0
    err = capsys.readouterr().err
    assert "time limit: stopped at iteration 1/50" in err and "generator unet" in err
    other = tmp_path / "next"
    assert cli.main(["prior", "--out", str(other), "--resume", str(out / "checkpoint.pt"), "--iters", "4",
                     "--threads", "1"]) == 0
    assert ckpt_io.load_checkpoint(other / "checkpoint.pt")["step"] == 4
    for bad in (["--minutes", "0"], ["--log-every", "0"], ["--eval-every", "-1"]):
        assert cli.main(["prior", "--out", str(tmp_path / "bad"), *bad]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert "Traceback" not in "\n".join(lines) and lines[-1].startswith("svbrdf-train: error:")
    assert cli.main(["prior", "--out", str(tmp_path / "r"), "--resume", str(tmp_path / "missing.pt")]) == 1
    assert "no checkpoint to resume from" in capsys.readouterr().err


def test_a_resume_takes_a_new_checkpoint_interval(tmp_path, monkeypatch):
    # A background run on a CPU resumes a GPU chunk's checkpoint (v2: every 2000 iterations) and must save often
    # enough to lose little when the session ends.
    out = tmp_path / "v2"
    args = ["prior", "--preset", "v2", "--out", str(out), "--size", "32", "--photo-size", "64", "--batch", "1",
            "--threads", "1", "--iters", "1", "--log-every", "1", "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(args) == 0
    saved = []
    real = PriorTrainer.save
    monkeypatch.setattr(PriorTrainer, "save", lambda self, *a, **k: saved.append(self.step) or real(self, *a, **k))
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "5", "--checkpoint-every", "2",
                     "--threads", "1"]) == 0
    assert saved == [2, 4, 5]
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"]["checkpoint_every"] == 2


def test_material_reuse_photographs_the_same_materials_anew(monkeypatch):
    from svbrdf.trainer.prior import trainer as prior_mod  # the module whose names PriorTrainer uses

    drawn = []
    real = prior_mod.draw_materials
    monkeypatch.setattr(prior_mod, "draw_materials", lambda *a, **k: drawn.append(1) or real(*a, **k))
    t = PriorTrainer(tiny_v2(iters=6, material_reuse=3, log_every=3, render_views=0), threads=1)
    t.run()
    assert t.step == 6 and len(drawn) == 2
    with pytest.raises(ValueError, match="material_reuse"):
        tiny(material_reuse=0)


def test_a_non_finite_loss_in_the_batched_stream_leaves_the_weights_finite_and_is_counted(monkeypatch):
    from svbrdf.trainer.prior import trainer as prior_mod  # the module whose names PriorTrainer uses

    real, calls = prior_mod.prior_loss, []

    def sometimes_nan(*a, **k):
        out = real(*a, **k)
        calls.append(1)
        if len(calls) == 2:
            out["total"] = out["total"] * float("nan")
        return out

    monkeypatch.setattr(prior_mod, "prior_loss", sometimes_nan)
    t = PriorTrainer(tiny_v2(iters=4, log_every=4, render_views=0), threads=1)
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


def test_on_a_cpu_the_generator_trains_channels_last_with_the_same_result():
    """Channels-last and the plain layout sum in other orders, so they agree to float32 rounding, not bit for bit.

    What is stable across CPUs is compared tightly: the losses, and the first step's gradients (same weights, same
    batch) to 1e-4 of each tensor's largest gradient. Adam's first step is ``lr * g / (|g| + eps)``, about
    ``lr * sign(g)``: where a gradient is within rounding of zero its sign, and so a whole ``lr`` step, may differ
    between the layouts (on some CPUs of our kind it does). So the weights after one step must agree to rounding
    where the gradient is clear of that noise, and everywhere within twice the two steps' size (each Adam step moves
    an element at most about ``lr``, one way in one layout and the other way in the other)."""
    cfg = tiny(iters=2, checkpoint_every=0, eval_every=0)
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


def _relit_inputs(requires_grad=True):
    from svbrdf.trainer.render import plane_grid, point_light_vectors

    g = torch.Generator().manual_seed(3)
    pred = torch.rand(2, 8, 16, 16, generator=g)
    pred[:, SLICES["normal"]] = torch.nn.functional.normalize(pred[:, SLICES["normal"]] + torch.tensor(
        [-0.5, -0.5, 1.0])[None, :, None, None], dim=1)
    target = torch.rand(2, 8, 16, 16, generator=g)
    cam = torch.tensor([[0.0, 0.0, 2.0], [0.1, -0.1, 1.8]])
    v, l, d2 = point_light_vectors(plane_grid(16, 16), cam, cam)
    rc = resolve("fast").render_config.replace(falloff=True)
    return pred.requires_grad_(requires_grad), target, v, l, rc, d2


@pytest.mark.skipif(not any(shutil.which(c) for c in ("g++", "c++", "clang++")),
                    reason="torch.compile on a CPU needs a C++ compiler")
@pytest.mark.integration
def test_the_compiled_relighting_equals_the_plain_one_with_its_gradient():
    from svbrdf.trainer.prior import CompiledRelit, relit_pair

    pred, target, v, l, rc, d2 = _relit_inputs()
    plain = relit_pair(pred, target, v, l, rc, d2)
    (g_plain,) = torch.autograd.grad(plain, pred)
    compiled = CompiledRelit()
    fused = compiled(pred, target, v, l, rc, d2)
    (g_fused,) = torch.autograd.grad(fused, pred)
    assert compiled.note is None and compiled.compiled is not None  # it compiled, it did not fall back
    torch.testing.assert_close(fused, plain, rtol=1e-5, atol=1e-7)
    torch.testing.assert_close(g_fused, g_plain, rtol=1e-3, atol=1e-7)


def test_a_failed_compile_falls_back_to_the_plain_relighting_with_a_note():
    from svbrdf.trainer.prior import CompiledRelit, relit_pair

    def broken(*a, **k):
        raise RuntimeError("no C++ compiler\nmore lines")

    compiled = CompiledRelit()
    compiled.compiled = broken
    args = _relit_inputs(requires_grad=False)
    assert torch.equal(compiled(*args), relit_pair(*args))
    assert compiled.compiled is None and compiled.note.startswith("torch.compile failed (RuntimeError: no C++ compiler)")
    with pytest.raises(Exception):  # an error of the inputs themselves still surfaces
        compiled(torch.zeros(2, 3), *args[1:])


def test_cli_compile_flag_compiles_the_relighting_and_says_when_it_falls_back(tmp_path, capsys, monkeypatch):
    from svbrdf.trainer.prior import trainer as prior_mod  # the module whose names PriorTrainer uses

    made = []

    class Failing(prior_mod.CompiledRelit):  # compiling fails at once: the note, then eager training
        def __init__(self):
            made.append(self)
            self.compiled, self.note = (lambda *a, **k: (_ for _ in ()).throw(RuntimeError("no compiler"))), None

    monkeypatch.setattr(prior_mod, "CompiledRelit", Failing)
    args = ["prior", "--size", "32", "--photo-size", "64", "--batch", "1", "--width", "0.125", "--threads", "1",
            "--iters", "2"]
    assert cli.main([*args, "--out", str(tmp_path / "a")]) == 0
    assert not made and "torch.compile" not in capsys.readouterr().err
    assert cli.main([*args, "--out", str(tmp_path / "b"), "--compile"]) == 0
    err = capsys.readouterr().err
    assert len(made) == 1 and err.count("note: torch.compile failed (RuntimeError: no compiler); running eager") == 1
    assert ckpt_io.load_checkpoint(tmp_path / "b" / "checkpoint.pt")["step"] == 2


def test_batched_crops_are_photographed_alone_and_equal_crops_of_the_whole_photos():
    """A crop batch renders only its windows, with their positions in the whole photo (flash geometry) and in the
    frame (vignetting): without noise, each crop equals the same window of the whole photograph."""
    from svbrdf.trainer.prior import draw_materials, simulate_photos_batched

    quiet = {k: (v if k in ("ev", "vignetting", "white") else (0.0, 0.0)) for k, v in prior_preset("v2").camera.items()}
    cfg = tiny_v2(crop_share=1.0, camera=quiet, batch=3)
    maps, _, crop = draw_materials(cfg, torch.Generator().manual_seed(8))
    assert crop and maps.shape[-1] == 64
    crops, cmaps, draws = simulate_photos_batched(maps, cfg, torch.Generator().manual_seed(9), crop=32)
    whole, _, wdraws = simulate_photos_batched(maps, cfg, torch.Generator().manual_seed(9))
    assert crops.shape == (3, 3, 32, 32) and cmaps.shape == (3, 8, 32, 32) and draws == wdraws
    assert any(d["camera"]["vignetting"] > 0 for d in draws)
    for i in range(3):  # where the window is: the maps are gathered exactly
        hits = [(y, x) for y in range(33) for x in range(33) if torch.equal(maps[i, :, y:y + 32, x:x + 32], cmaps[i])]
        assert len(hits) == 1
        y, x = hits[0]
        ref = whole[i, :, y:y + 32, x:x + 32]
        assert (crops[i] - ref).abs().max() < 1e-2 and (crops[i] - ref).abs().mean() < 1e-4  # (8-bit rounding)


@pytest.mark.integration
def test_v2_trains_a_linear_height_and_a_resume_converts_a_tanh_checkpoint_once(tmp_path, capsys):
    # The v2 run at 4745 iterations had its tanh height at a pre-activation of -2.5 (3 % of the normals' gradient
    # left); a resume with --height-activation linear switches it where it stands and the checkpoints keep it.
    fresh = tmp_path / "fresh"
    args = ["--size", "32", "--photo-size", "64", "--batch", "1", "--threads", "1", "--log-every", "1",
            "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(["prior", "--preset", "v2", "--out", str(fresh), "--iters", "1", *args]) == 0
    assert ckpt_io.load_checkpoint(fresh / "checkpoint.pt")["generator_config"]["height_activation"] == "linear"
    old = tmp_path / "old"
    assert cli.main(["prior", "--preset", "v2", "--height-activation", "tanh", "--out", str(old), "--iters", "1",
                     *args]) == 0
    ckpt = ckpt_io.load_checkpoint(old / "checkpoint.pt")
    assert ckpt["generator_config"]["height_activation"] == "tanh"
    capsys.readouterr()
    assert cli.main(["prior", "--out", str(old), "--resume", "--iters", "2", "--height-activation", "linear",
                     "--threads", "1"]) == 0
    assert "height: tanh -> linear at iteration 1" in capsys.readouterr().err
    after = ckpt_io.load_checkpoint(old / "checkpoint.pt")
    assert after["step"] == 2
    assert after["generator_config"]["height_activation"] == "linear"
    assert after["prior_config"]["generator"]["height_activation"] == "linear"
    # the next resume stays linear without the flag and refuses to go back
    assert cli.main(["prior", "--out", str(old), "--resume", "--iters", "3", "--threads", "1"]) == 0
    assert "tanh -> linear" not in capsys.readouterr().err
    assert cli.main(["prior", "--out", str(old), "--resume", "--iters", "4", "--height-activation", "tanh",
                     "--threads", "1"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert "Traceback" not in "\n".join(err) and "cannot be turned back into a tanh" in err[-1]


def test_the_slope_term_joins_the_prior_loss_at_its_weight():
    cfg = tiny_v2()
    maps, _ = sample_materials(2, 32, torch.Generator().manual_seed(3))
    other = maps.flip(-1)
    base = prior_loss(other, maps, cfg, torch.Generator().manual_seed(1))
    assert "slope" not in base and cfg.lambda_slope == 0.0
    with_term = prior_loss(other, maps, dataclasses.replace(cfg, lambda_slope=0.5), torch.Generator().manual_seed(1))
    assert float(with_term["slope"]) > 0.1
    assert float(with_term["total"]) == pytest.approx(float(base["total"]) + 0.5 * float(with_term["slope"]), rel=1e-5)
    assert float(prior_loss(maps, maps, dataclasses.replace(cfg, lambda_slope=0.5),
                            torch.Generator().manual_seed(1))["slope"]) == pytest.approx(0.0, abs=1e-5)
    with pytest.raises(ValueError, match="lambda_slope"):
        tiny(lambda_slope=-1.0)


def test_cli_slope_weight_starts_a_run_with_the_term_and_changes_it_on_a_resume(tmp_path, capsys):
    out = tmp_path / "v2"
    args = ["--size", "32", "--photo-size", "64", "--batch", "1", "--threads", "1", "--log-every", "1",
            "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(["prior", "--preset", "v2", "--out", str(out), "--iters", "1", "--slope-weight", "0.5", *args]) == 0
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"]["lambda_slope"] == 0.5
    capsys.readouterr()
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "2", "--slope-weight", "1", "--threads", "1"]) == 0
    assert "slope term's weight 0.5 -> 1 from here on" in capsys.readouterr().err
    ckpt = ckpt_io.load_checkpoint(out / "checkpoint.pt")
    assert ckpt["prior_config"]["lambda_slope"] == 1.0 and ckpt["history"][-1]["slope"] >= 0
    assert cli.main(["prior", "--out", str(tmp_path / "bad"), "--slope-weight", "-1"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("svbrdf-train: error:")


def test_a_roll_off_range_is_drawn_per_photo_alike_in_both_streams_and_none_leaves_the_stream_as_it_was():
    """``camera["white"]`` (the highlight roll-off): left out or (1, 1), nothing is drawn for it (a run's stream as
    before it existed); a range draws it last per photo, the same in the photo-by-photo and the batched stream."""
    from svbrdf.trainer.prior import draw_materials, simulate_photos, simulate_photos_batched

    old = prior_preset("v2").to_dict()
    old["camera"].pop("white")
    assert PriorConfig.from_dict(old).camera["white"] == (1.0, 1.0)  # a checkpoint from before
    quiet = {k: (v if k in ("ev", "vignetting") else (0.0, 0.0)) for k, v in prior_preset("v2").camera.items()}
    lin = tiny_v2(crop_share=0.0, camera={**quiet, "white": (1.0, 1.0)}, batch=3)
    rolled = dataclasses.replace(lin, camera={**quiet, "white": (2.0, 4.0)})
    maps, _, _ = draw_materials(lin, torch.Generator().manual_seed(3))
    maps = maps.clone()
    maps[:, 0:3] = 1.0  # a bright white material under the flash: the centre clips
    a, _, da = simulate_photos_batched(maps, lin, torch.Generator().manual_seed(5))
    b, _, db = simulate_photos_batched(maps, rolled, torch.Generator().manual_seed(5))
    _, _, d1 = simulate_photos_batched(maps[:1], rolled, torch.Generator().manual_seed(5))
    s, _, ds = simulate_photos(maps[:1], rolled, torch.Generator().manual_seed(5))  # (its later draws interleave)
    assert [d["camera"]["white"] for d in da] == [1.0] * 3
    assert all(2.0 <= d["camera"]["white"] <= 4.0 for d in db) and d1 == ds
    assert da[0]["camera"]["ev"] == db[0]["camera"]["ev"]  # white is drawn after the others
    assert float((a >= 1.0).float().mean()) > float((b >= 1.0).float().mean())  # fewer clipped pixels
    s_lin, _, _ = simulate_photos(maps[:1], lin, torch.Generator().manual_seed(5))
    assert float((s_lin >= 1.0).float().mean()) > float((s >= 1.0).float().mean())  # the numpy camera's roll-off
    with pytest.raises(ValueError):
        tiny_v2(camera={**quiet, "white": (0.5, 2.0)})


def test_flat_share_makes_the_chosen_materials_flat_and_none_leaves_the_stream_as_it_was():
    """``flat_share`` (materials without relief): the chosen materials' normals are (0, 0, 1), everything else of
    theirs and the other materials as drawn; at 0 nothing is drawn for it; the validation batch never has them."""
    from svbrdf.trainer.prior import draw_materials, flatten_normals

    cfg = tiny_v2(crop_share=0.0, batch=12)
    flat = dataclasses.replace(cfg, flat_share=0.5)
    a, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    g = torch.Generator().manual_seed(7)
    b, _, _ = draw_materials(flat, g)
    after_flat = torch.rand(3, generator=g)
    g0 = torch.Generator().manual_seed(7)
    draw_materials(cfg, g0)
    torch.rand(12, generator=g0)  # the flat share's one draw per material, made after the materials
    assert torch.equal(after_flat, torch.rand(3, generator=g0))
    sl = SLICES["normal"]
    up = torch.tensor([0.0, 0.0, 1.0])[None, :, None, None]
    is_flat = (b[:, sl] == up).flatten(1).all(1)
    was_flat = (a[:, sl] == up).flatten(1).all(1)
    assert not was_flat.any() and 0 < int(is_flat.sum()) < 12  # seed 7: some of the 12, not all
    assert torch.equal(b[~is_flat], a[~is_flat]) and torch.equal(b[:, :sl.start], a[:, :sl.start])
    a2, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    assert torch.equal(a, a2)  # share 0: the stream of a run before it existed
    chosen = torch.tensor([True, False] * 6)
    c = flatten_normals(a, chosen)
    assert (c[chosen][:, sl] == up).all() and torch.equal(c[~chosen], a[~chosen])
    assert flatten_normals(a, torch.zeros(12, dtype=torch.bool)) is a
    t1 = PriorTrainer(cfg, device="cpu", threads=1)
    t2 = PriorTrainer(dataclasses.replace(cfg, flat_share=0.9), device="cpu", threads=1)
    assert all(torch.equal(x, y) for x, y in zip(t1.eval_set(), t2.eval_set()))
    with pytest.raises(ValueError):
        tiny_v2(flat_share=1.0)


def test_coarse_share_adds_a_smooth_relief_to_the_chosen_materials_and_none_leaves_the_stream_as_it_was():
    """``coarse_share`` (a coarse relief on top of a material's own): the chosen materials' normals change and get
    a coarse band (their slopes blurred keep more of their variance than before, on average), every other channel and material
    as drawn; at 0 nothing is drawn for it; the validation batch never has them."""
    from svbrdf.trainer.bench.metrics import gaussian_blur
    from svbrdf.trainer.prior import add_coarse_relief, draw_materials
    from svbrdf.trainer.procedural import PARAMS

    cfg = tiny_v2(crop_share=0.0, batch=12, size=64)
    a, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    b, _, _ = draw_materials(dataclasses.replace(cfg, coarse_share=0.5), torch.Generator().manual_seed(7))
    sl = SLICES["normal"]
    changed = (b[:, sl] != a[:, sl]).flatten(1).any(1)
    assert 0 < int(changed.sum()) < 12  # seed 7: some of the 12, not all
    assert torch.equal(b[~changed], a[~changed]) and torch.equal(b[:, :sl.start], a[:, :sl.start])
    assert torch.allclose(b[:, sl].norm(dim=1), torch.ones(()), atol=1e-5) and bool((b[:, sl][:, 2] > 0).all())

    def coarse_fraction(n):  # share of the slope variance left after a blur of sigma 4 px
        s = (-n[:2] / n[2:]).double().numpy()
        s = s - s.mean(axis=(1, 2), keepdims=True)
        return sum(float(np.var(gaussian_blur(c, 4.0))) for c in s) / sum(float(np.var(c)) for c in s)

    rise = [coarse_fraction(b[i, sl]) - coarse_fraction(a[i, sl]) for i in torch.nonzero(changed).flatten().tolist()]
    assert float(np.mean(rise)) > 0.05 and min(rise) > -0.01
    # the added relief alone (on flat normals) has a mean tilt within the drawn range
    flat = a.clone()
    flat[:, sl] = torch.tensor([0.0, 0.0, 1.0])[None, :, None, None]
    c = add_coarse_relief(flat, torch.ones(12, dtype=torch.bool), torch.Generator().manual_seed(3))
    tilt = torch.rad2deg(torch.acos(c[:, sl][:, 2].clamp(-1, 1))).flatten(1).mean(1)
    lo, hi = PARAMS["coarse_tilt_deg"]
    assert bool((tilt > 0.5 * lo).all()) and bool((tilt < 1.5 * hi).all())
    assert add_coarse_relief(a, torch.zeros(12, dtype=torch.bool), torch.Generator()) is a
    g, g0 = torch.Generator().manual_seed(7), torch.Generator().manual_seed(7)
    draw_materials(dataclasses.replace(cfg, coarse_share=0.0), g)
    draw_materials(cfg, g0)
    assert torch.equal(torch.rand(3, generator=g), torch.rand(3, generator=g0))  # share 0: no draw
    t1 = PriorTrainer(cfg, device="cpu", threads=1)
    t2 = PriorTrainer(dataclasses.replace(cfg, coarse_share=0.9), device="cpu", threads=1)
    assert all(torch.equal(x, y) for x, y in zip(t1.eval_set(), t2.eval_set()))
    with pytest.raises(ValueError):
        tiny_v2(coarse_share=1.5)


@pytest.mark.parametrize("key, note", [("flat_share", "flat normals 0 -> 0.1 from here on"),
                                       ("black_share", "near-black dielectric materials 0 -> 0.1 from here on"),
                                       ("coarse_share", "materials with a coarse relief 0 -> 0.1 from here on")])
def test_cli_material_shares_start_a_run_with_them_and_change_them_on_a_resume(tmp_path, capsys, key, note):
    flag = "--" + key.replace("_", "-")
    out = tmp_path / "v2"
    args = ["--size", "32", "--photo-size", "64", "--batch", "1", "--threads", "1", "--log-every", "1",
            "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(["prior", "--preset", "v2", "--out", str(out), "--iters", "1", *args]) == 0
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"][key] == 0.0
    capsys.readouterr()
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "2", flag, "0.1", "--threads", "1"]) == 0
    assert note in capsys.readouterr().err
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"][key] == 0.1
    assert cli.main(["prior", "--preset", "v2", "--out", str(tmp_path / "f"), "--iters", "1", flag, "0.2",
                     *args]) == 0
    assert ckpt_io.load_checkpoint(tmp_path / "f" / "checkpoint.pt")["prior_config"][key] == 0.2
    assert cli.main(["prior", "--out", str(tmp_path / "bad"), flag, "1.5"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("svbrdf-train: error:")


def test_black_share_darkens_chosen_dielectrics_only_and_none_leaves_the_stream_as_it_was():
    """``black_share`` (near-black dielectrics): a chosen dielectric's base colour is scaled to a mean within
    :data:`BLACK_LEVEL`, its other maps and every other material as drawn, a metal never; at 0 nothing is drawn
    for it; the validation batch never has them."""
    from svbrdf.trainer.prior import BLACK_LEVEL, blacken_dielectrics, draw_materials

    cfg = tiny_v2(crop_share=0.0, batch=12)
    a, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    g = torch.Generator().manual_seed(7)
    b, _, _ = draw_materials(dataclasses.replace(cfg, black_share=0.5), g)
    after = torch.rand(3, generator=g)
    g0 = torch.Generator().manual_seed(7)
    draw_materials(cfg, g0)
    torch.rand(12, generator=g0), torch.rand(12, generator=g0)  # the choice and the level, after the materials
    assert torch.equal(after, torch.rand(3, generator=g0))
    d = SLICES["diffuse"]
    changed = ~(b[:, d] == a[:, d]).flatten(1).all(1)
    assert 0 < int(changed.sum()) < 12  # seed 7: some of the 12
    assert torch.equal(b[:, d.stop:], a[:, d.stop:]) and torch.equal(b[~changed], a[~changed])
    means = b[changed][:, d].mean((1, 2, 3))
    assert (means <= BLACK_LEVEL[1] * 1.0001).all()
    a2, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    assert torch.equal(a, a2)  # share 0: the stream of a run before it existed
    metal = a.clone()
    metal[:, SLICES["specular"]] = 0.8  # every material a metal: none is darkened
    every = torch.ones(12, dtype=torch.bool)
    assert torch.equal(blacken_dielectrics(metal, every, torch.full((12,), 0.001)), metal)
    dielectric = a.clone()
    dielectric[:, SLICES["specular"]] = 0.04
    dark = blacken_dielectrics(dielectric, every, torch.full((12,), 0.005))
    torch.testing.assert_close(dark[:, d].mean((1, 2, 3)),
                               torch.minimum(torch.full((12,), 0.005), dielectric[:, d].mean((1, 2, 3))))
    assert blacken_dielectrics(a, torch.zeros(12, dtype=torch.bool), torch.ones(12)) is a
    t1 = PriorTrainer(cfg, device="cpu", threads=1)
    t2 = PriorTrainer(dataclasses.replace(cfg, black_share=0.9), device="cpu", threads=1)
    assert all(torch.equal(x, y) for x, y in zip(t1.eval_set(), t2.eval_set()))
    with pytest.raises(ValueError):
        tiny_v2(black_share=1.0)


def _floats(module) -> dict:
    return {k: v.detach().clone() for k, v in module.state_dict().items() if v.is_floating_point()}


def test_the_moving_average_is_the_ema_of_the_trained_weights_and_what_the_checkpoint_gives(tmp_path):
    """``ema``: after every step average = decay * average + (1 - decay) * weights (the first step copies); it is
    :attr:`PriorTrainer.model`, the checkpoint's ``generator_ema`` and what every consumer of the checkpoint loads."""
    tr = PriorTrainer(tiny_v2(ema=0.75, iters=3), threads=1)
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
    plain = PriorTrainer(tiny_v2(iters=1), threads=1)
    plain.iteration()
    assert plain.averaged is None and plain.model is plain.generator and "generator_ema" not in plain.checkpoint()


@pytest.mark.integration
def test_a_resume_keeps_the_average_and_a_resume_that_turns_it_on_starts_it_at_the_resumed_weights(tmp_path):
    cfg = tiny_v2(ema=0.75, iters=4, compact_checkpoint=False)  # (compact: float16 weights, not exact)
    whole = PriorTrainer(cfg, threads=1)
    whole.run()
    first = PriorTrainer(cfg, threads=1, checkpoint_path=tmp_path / "a.pt")
    for _ in range(2):
        first.iteration()
    first.save()
    resumed = resume_prior(tmp_path / "a.pt", threads=1)
    a, b = _floats(whole.model), _floats(resumed.model)
    assert resumed.step == 4 and max(float((a[k] - b[k]).abs().max()) for k in a) < 1e-5
    off = PriorTrainer(tiny_v2(iters=4), threads=1, checkpoint_path=tmp_path / "b.pt")
    off.iteration()
    off.save()
    ckpt = ckpt_io.load_checkpoint(tmp_path / "b.pt")
    on = PriorTrainer(tiny_v2(ema=0.75, iters=4), threads=1)
    on.load_resume(ckpt, tmp_path / "b.pt")
    assert on.model is on.generator  # until its first update
    on.iteration()
    w, m = _floats(on.generator), _floats(on.model)
    assert all(torch.equal(w[k], m[k]) for k in w)  # the first update copies the weights it resumed and trained


def test_cli_ema_starts_a_run_with_an_average_and_turns_it_on_at_a_resume(tmp_path, capsys):
    out = tmp_path / "v2"
    args = ["--size", "32", "--photo-size", "64", "--batch", "1", "--threads", "1", "--log-every", "1",
            "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(["prior", "--preset", "v2", "--out", str(out), "--iters", "1", *args]) == 0
    ckpt = ckpt_io.load_checkpoint(out / "checkpoint.pt")
    assert ckpt["prior_config"]["ema"] == 0.0 and "generator_ema" not in ckpt
    capsys.readouterr()
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "2", "--ema", "0.9", "--threads", "1"]) == 0
    assert "moving average (decay 0 -> 0.9) from here on" in capsys.readouterr().err
    ckpt = ckpt_io.load_checkpoint(out / "checkpoint.pt")
    assert ckpt["prior_config"]["ema"] == 0.9 and ckpt["ema_updates"] == 1
    assert cli.main(["prior", "--preset", "v2", "--out", str(tmp_path / "e"), "--iters", "1", "--ema", "0.5",
                     *args]) == 0
    assert ckpt_io.load_checkpoint(tmp_path / "e" / "checkpoint.pt")["ema_updates"] == 1
    assert cli.main(["prior", "--out", str(tmp_path / "bad"), "--ema", "1"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("svbrdf-train: error:")
