"""svbrdf-train through main(argv): outputs, exit codes, one-line errors, finetune, resume, Ctrl-C."""

import json
import os
import signal

import numpy as np
import pytest
import torch

from svbrdf.runtime.io.images import write_image
from svbrdf.trainer import cli
from svbrdf.trainer import train as train_mod

# --threads 1: see tests/trainer/test_train.py.
TINY = ["--preset", "tiny", "--threads", "1"]


@pytest.fixture
def photo(tmp_path):
    path = tmp_path / "tile photo.png"  # a space in the name, as users have
    rng = np.random.default_rng(0)
    write_image(path, (rng.random((48, 64, 3)) * 0.6).astype(np.float32), bits=8)
    return path


def error_lines(capsys):
    err = capsys.readouterr().err
    return [ln for ln in err.splitlines() if ln.strip()]


def test_fit_writes_checkpoint_log_and_maps(tmp_path, photo, capsys):
    out = tmp_path / "out"
    assert cli.main(["fit", str(photo), *TINY, "--iters", "3", "--out", str(out), "--maps-every", "2"]) == 0
    err = capsys.readouterr().err
    assert "perceptual loss: pyramid" in err and "done: 3 iterations" in err
    ckpt = torch.load(out / "checkpoint.pt", weights_only=True)
    assert ckpt["stage"] == "fit" and ckpt["step"] == 3 and ckpt["photo"]["name"] == photo.name
    assert (out / "checkpoint_last_good.pt").is_file()
    steps = [json.loads(line).get("step") for line in (out / "train_log.jsonl").read_text().splitlines()]
    assert steps[1:4] == [1, 2, 3]
    stem = photo.stem
    for suffix in ("_basecolor.png", "_normal.png", "_roughness.png", "_specular.png", ".json", "_relit.png"):
        assert (out / f"{stem}{suffix}").is_file(), suffix
    assert (out / "maps" / "step_000002" / f"{stem}_basecolor.png").is_file()  # --maps-every
    sidecar = json.loads((out / f"{stem}.json").read_text())
    assert sidecar["meta"]["stage"] == "fit" and sidecar["meta"]["step"] == 3
    burn = sidecar["meta"]["burn_in"]["burn_in"]  # the label-free burn-in, in the sidecar and the closing line
    assert burn >= 0 and f"burn-in {burn:.2f}" in err
    # the photo's own camera, as svbrdf-preview takes it (no EXIF, no fall-off: a phone's across a 4:3 photo)
    assert "camera: 67.3 deg across the photo (default" in err
    assert sidecar["brdf"]["render_config"]["fov_deg"] == pytest.approx(67.3, abs=0.01)


def test_fov_overrides_the_photos_camera(tmp_path, photo, capsys):
    out = tmp_path / "out"
    assert cli.main(["fit", str(photo), *TINY, "--iters", "1", "--out", str(out), "--fov", "30"]) == 0
    assert "camera:" not in capsys.readouterr().err
    assert json.loads((out / f"{photo.stem}.json").read_text())["brdf"]["render_config"]["fov_deg"] == 30.0


def test_progress_is_plain_lines_off_a_terminal(tmp_path, photo, capsys):
    assert cli.main(["fit", str(photo), *TINY, "--iters", "3", "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    progress = [ln for ln in err.splitlines() if ln.startswith(f"fit {photo.stem}: ")]
    # stderr is captured (not a terminal): plain lines (every iteration of so short a run) with the losses
    assert [ln.split(" [")[0] for ln in progress] == [f"fit {photo.stem}: {i}/3" for i in (1, 2, 3)]
    assert "nr " in progress[-1] and "ds " in progress[-1] and "\r" not in err


def test_default_out_dir_is_derived_from_the_photo(tmp_path, photo, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["pretrain", str(photo), *TINY, "--iters", "1", "--quiet"]) == 0
    assert (tmp_path / f"{photo.stem}-pretrain" / "checkpoint.pt").is_file()
    assert capsys.readouterr().err == ""  # --quiet


def test_bad_photo_is_one_line_error(tmp_path, capsys):
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not an image at all")
    assert cli.main(["fit", str(bad), *TINY, "--out", str(tmp_path / "o")]) == 1
    lines = error_lines(capsys)
    assert len(lines) == 1 and lines[0].startswith("svbrdf-train: error: ") and "bad.png" in lines[0]
    assert cli.main(["fit", str(tmp_path / "missing.png"), *TINY, "--out", str(tmp_path / "o")]) == 1
    assert len(error_lines(capsys)) == 1
    assert not (tmp_path / "o").exists()
    small = tmp_path / "small.png"  # readable, but below the 32 px the discriminator needs
    write_image(small, np.full((24, 24, 3), 0.5, np.float32), bits=8)
    assert cli.main(["fit", str(small), *TINY, "--out", str(tmp_path / "o")]) == 1
    lines = error_lines(capsys)
    assert len(lines) == 1 and "small.png" in lines[0] and "32 px" in lines[0]
    assert not (tmp_path / "o").exists()  # no empty folder left behind


def test_existing_output_needs_force(tmp_path, photo, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("user file")
    assert cli.main(["fit", str(photo), *TINY, "--iters", "1", "--out", str(out)]) == 1
    lines = error_lines(capsys)
    assert len(lines) == 1 and "--force" in lines[0]
    assert not (out / "checkpoint.pt").exists()
    assert cli.main(["fit", str(photo), *TINY, "--iters", "1", "--out", str(out), "--force"]) == 0
    assert (out / "checkpoint.pt").is_file() and (out / "keep.txt").read_text() == "user file"


def test_usage_errors_exit_2(tmp_path, photo, capsys):
    assert cli.main(["fit", str(photo), "--preset", "huge"]) == 2
    assert cli.main(["fit", str(photo), *TINY, "--tile", "4", "--out", str(tmp_path / "o")]) == 2
    assert cli.main([]) == 2
    assert "finetune" in capsys.readouterr().err


def test_finetune_without_init_starts_from_the_packaged_stage_one(tmp_path, photo, capsys, monkeypatch):
    from svbrdf.trainer.checkpoint import default_checkpoint

    packaged = default_checkpoint()
    if packaged is None:
        pytest.skip("no packaged model with a checkpoint")
    out = tmp_path / "o"
    assert cli.main(["finetune", str(photo), *TINY, "--iters", "1", "--out", str(out)]) == 0
    assert f"starting from the packaged stage one {packaged}" in capsys.readouterr().err
    assert torch.load(out / "checkpoint.pt", weights_only=True)["init"]["path"] == str(packaged)
    # A model without a checkpoint beside it: one line, exit 1.
    lone = tmp_path / "lone.onnx"
    lone.write_bytes(b"not really a model")
    monkeypatch.setenv("SVBRDF_MODEL", str(lone))
    assert cli.main(["finetune", str(photo), *TINY, "--out", str(tmp_path / "o2")]) == 1
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and "names no stage-one checkpoint" in err[0]


def test_finetune_from_a_pretrain_checkpoint(tmp_path, photo, capsys):
    pre = tmp_path / "pre"
    assert cli.main(["pretrain", str(photo), *TINY, "--iters", "2", "--out", str(pre)]) == 0
    tuned = tmp_path / "tuned"
    argv = ["finetune", str(photo), *TINY, "--iters", "2", "--out", str(tuned), "--init", str(pre / "checkpoint.pt")]
    assert cli.main(argv) == 0
    ckpt = torch.load(tuned / "checkpoint.pt", weights_only=True)
    assert ckpt["stage"] == "finetune" and ckpt["step"] == 2 and ckpt["init"]["step"] == 2
    assert ckpt["optimizers"]["nr"]["state"][0]["step"] == 4  # the pretrained Adam state went on
    capsys.readouterr()
    bad_init = tmp_path / "bad.pt"
    bad_init.write_bytes(b"garbage")
    argv[argv.index(str(pre / "checkpoint.pt"))] = str(bad_init)
    assert cli.main(argv + ["--force"]) == 1
    lines = error_lines(capsys)
    assert len(lines) == 1 and "bad.pt" in lines[0]


def test_resume_continues_and_checks_the_stage(tmp_path, photo, capsys):
    out = tmp_path / "out"
    assert cli.main(["fit", str(photo), *TINY, "--iters", "2", "--out", str(out)]) == 0
    assert cli.main(["fit", str(photo), "--threads", "1", "--iters", "4", "--out", str(out), "--resume"]) == 0
    ckpt = torch.load(out / "checkpoint.pt", weights_only=True)
    assert ckpt["step"] == 4 and [h["step"] for h in ckpt["history"]] == [1, 2, 3, 4]
    capsys.readouterr()
    assert cli.main(["pretrain", str(photo), "--iters", "5", "--out", str(out), "--resume"]) == 1
    assert "'fit' run" in error_lines(capsys)[0]


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_ctrl_c_or_sigterm_saves_and_exits_130(tmp_path, photo, monkeypatch, capsys, sig):
    real = train_mod.Trainer.iteration

    def interrupted_at_2(self):
        rec = real(self)
        if self.step == 2:
            os.kill(os.getpid(), getattr(signal, sig))  # handled by the CLI: finish this iteration, save, stop
        return rec

    monkeypatch.setattr(train_mod.Trainer, "iteration", interrupted_at_2)
    out = tmp_path / "out"
    before = signal.getsignal(signal.SIGINT)  # SIG_IGN when the suite runs in the background (nohup, CI)
    before_term = signal.getsignal(signal.SIGTERM)
    assert cli.main(["fit", str(photo), *TINY, "--iters", "10", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "--resume" in err and "interrupted at iteration 2/10" in err
    assert torch.load(out / "checkpoint.pt", weights_only=True)["step"] == 2
    assert signal.getsignal(signal.SIGINT) is before  # the caller's handlers are restored
    assert signal.getsignal(signal.SIGTERM) is before_term


def test_target_preset_for_the_final_texture_set(tmp_path, photo, capsys):
    out = tmp_path / "out"
    assert cli.main(["fit", str(photo), *TINY, "--iters", "1", "--out", str(out), "--target", "usd"]) == 0
    assert "usd texture set" in capsys.readouterr().err
    assert list(out.glob("*.usda")), sorted(p.name for p in out.iterdir())


def test_target_choices_are_the_runtime_targets():
    import argparse

    from svbrdf.runtime.outputs.choices import TARGETS

    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for stage in ("pretrain", "finetune", "fit"):
        action = next(a for a in sub.choices[stage]._actions if a.dest == "target")
        assert tuple(action.choices) == TARGETS
