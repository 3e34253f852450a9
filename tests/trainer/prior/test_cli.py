"""``svbrdf-train prior`` (trainer/cli.py): start, resume, time limit, signals, the flags that change a run on a
resume, ``--set``."""

import os
import signal

import pytest

from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer import cli
from svbrdf.trainer.prior import PriorTrainer

pytestmark = pytest.mark.usefixtures("one_thread")


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
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"]["monitor"]["checkpoint_every"] == 2


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


def test_cli_slope_weight_starts_a_run_with_the_term_and_changes_it_on_a_resume(tmp_path, capsys):
    out = tmp_path / "v2"
    args = ["--size", "32", "--photo-size", "64", "--batch", "1", "--threads", "1", "--log-every", "1",
            "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(["prior", "--preset", "v2", "--out", str(out), "--iters", "1", "--slope-weight", "0.5", *args]) == 0
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"]["losses"]["slope"] == 0.5
    capsys.readouterr()
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "2", "--slope-weight", "1", "--threads", "1"]) == 0
    assert "slope term's weight 0.5 -> 1 from here on" in capsys.readouterr().err
    ckpt = ckpt_io.load_checkpoint(out / "checkpoint.pt")
    assert ckpt["prior_config"]["losses"]["slope"] == 1.0 and ckpt["history"][-1]["slope"] >= 0
    assert cli.main(["prior", "--out", str(tmp_path / "bad"), "--slope-weight", "-1"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("svbrdf-train: error:")


@pytest.mark.parametrize("key, note", [("flat_share", "flat normals 0 -> 0.1 from here on"),
                                       ("black_share", "near-black dielectric materials 0 -> 0.1 from here on"),
                                       ("coarse_share", "materials with a coarse relief 0 -> 0.1 from here on")])
def test_cli_material_shares_start_a_run_with_them_and_change_them_on_a_resume(tmp_path, capsys, key, note):
    flag = "--" + key.replace("_", "-")
    out = tmp_path / "v2"
    args = ["--size", "32", "--photo-size", "64", "--batch", "1", "--threads", "1", "--log-every", "1",
            "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(["prior", "--preset", "v2", "--out", str(out), "--iters", "1", *args]) == 0
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"]["materials"][key] == 0.0
    capsys.readouterr()
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "2", flag, "0.1", "--threads", "1"]) == 0
    assert note in capsys.readouterr().err
    assert ckpt_io.load_checkpoint(out / "checkpoint.pt")["prior_config"]["materials"][key] == 0.1
    assert cli.main(["prior", "--preset", "v2", "--out", str(tmp_path / "f"), "--iters", "1", flag, "0.2",
                     *args]) == 0
    assert ckpt_io.load_checkpoint(tmp_path / "f" / "checkpoint.pt")["prior_config"]["materials"][key] == 0.2
    assert cli.main(["prior", "--out", str(tmp_path / "bad"), flag, "1.5"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("svbrdf-train: error:")


def test_cli_ema_starts_a_run_with_an_average_and_turns_it_on_at_a_resume(tmp_path, capsys):
    out = tmp_path / "v2"
    args = ["--size", "32", "--photo-size", "64", "--batch", "1", "--threads", "1", "--log-every", "1",
            "--eval-every", "0", "--material-reuse", "1"]
    assert cli.main(["prior", "--preset", "v2", "--out", str(out), "--iters", "1", *args]) == 0
    ckpt = ckpt_io.load_checkpoint(out / "checkpoint.pt")
    assert ckpt["prior_config"]["optim"]["ema"] == 0.0 and "generator_ema" not in ckpt
    capsys.readouterr()
    assert cli.main(["prior", "--out", str(out), "--resume", "--iters", "2", "--ema", "0.9", "--threads", "1"]) == 0
    assert "moving average (decay 0 -> 0.9) from here on" in capsys.readouterr().err
    ckpt = ckpt_io.load_checkpoint(out / "checkpoint.pt")
    assert ckpt["prior_config"]["optim"]["ema"] == 0.9 and ckpt["ema_updates"] == 1
    assert cli.main(["prior", "--preset", "v2", "--out", str(tmp_path / "e"), "--iters", "1", "--ema", "0.5",
                     *args]) == 0
    assert ckpt_io.load_checkpoint(tmp_path / "e" / "checkpoint.pt")["ema_updates"] == 1
    assert cli.main(["prior", "--out", str(tmp_path / "bad"), "--ema", "1"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("svbrdf-train: error:")


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


def test_cli_set_takes_dotted_and_flat_names_and_refuses_an_unknown_one(tmp_path, capsys):
    """``--set`` on a new --preset run: a setting by its dotted name or by the flat name of earlier records (the same
    setting), after the flags; an unknown name or a bad value is one ``svbrdf-train: error:`` line."""
    base = ["prior", "--size", "32", "--photo-size", "64", "--batch", "1", "--width", "0.125", "--threads", "1",
            "--iters", "1", "--eval-every", "0"]
    runs = {"dotted": ["--set", "optim.lr=1e-3", "--set", "losses.grad=0.5", "--set", "generator.height_scale=16"],
            "flat": ["--set", "lr=1e-3", "--set", "lambda_grad=0.5", "--set", "generator.height_scale=16"]}
    got = {}
    for name, sets in runs.items():
        assert cli.main([*base, "--out", str(tmp_path / name), *sets]) == 0
        got[name] = ckpt_io.load_checkpoint(tmp_path / name / "checkpoint.pt")["prior_config"]
    assert got["dotted"] == got["flat"]
    assert (got["flat"]["optim"]["lr"], got["flat"]["losses"]["grad"], got["flat"]["generator"]["height_scale"],
            got["flat"]["photos"]["size"]) == (1e-3, 0.5, 16.0, 32)
    assert cli.main([*base, "--out", str(tmp_path / "over"), "--set", "photos.size=64", "--set",
                     "photos.photo_size=128"]) == 0  # --set after the flags
    assert ckpt_io.load_checkpoint(tmp_path / "over" / "checkpoint.pt")["prior_config"]["photos"]["size"] == 64
    capsys.readouterr()
    for bad, says in ((["--set", "optim.nope=1"], "unknown prior settings: optim.nope"),
                      (["--set", "nope=1"], "unknown prior settings: nope"),
                      (["--set", "optim.lr=-1"], "optim.lr > 0"), (["--set", "lr"], "expected KEY=VALUE")):
        assert cli.main([*base, "--out", str(tmp_path / "bad"), *bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert "Traceback" not in "\n".join(err) and err[-1].startswith("svbrdf-train: error:") and says in err[-1]
    assert cli.main(["prior", "--recipe", "v2", "--out", str(tmp_path / "r"), "--set", "optim.lr=1"]) == 2
