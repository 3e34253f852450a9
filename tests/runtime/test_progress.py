"""runtime/progress.py: plain lines off a terminal, a tqdm bar on one, nothing when quiet."""

import io

from svbrdf.runtime.progress import Progress, default_every, loss_postfix


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_plain_lines_every_n_steps_with_the_postfix():
    out = io.StringIO()
    with Progress(100, "refine a.png", file=out) as bar:
        for i in range(1, 101):
            bar.update(i, loss=f"{1 / i:.3f}")
    lines = out.getvalue().splitlines()
    assert bar.every == default_every(100) == 5
    # the first step, then every 5th (5, 10, ... 100)
    assert [ln.split(" [")[0] for ln in lines] == ["refine a.png: 1/100"] + [f"refine a.png: {i}/100"
                                                                            for i in range(5, 101, 5)]
    assert lines[-1].endswith(", loss 0.010]") and "<00:00" in lines[-1]


def test_an_early_stop_prints_its_last_step_and_a_resume_starts_after_initial():
    out = io.StringIO()
    with Progress(100, "fit", file=out, initial=40) as bar:
        bar.update(41)
        bar.update(43)
    assert [ln.split(" [")[0] for ln in out.getvalue().splitlines()] == ["fit: 41/100", "fit: 43/100"]


def test_quiet_prints_nothing():
    out = _Terminal()
    with Progress(10, "x", file=out, quiet=True) as bar:
        for i in range(10):
            bar.update()
    assert out.getvalue() == ""


def test_a_terminal_gets_a_bar_not_lines():
    out = _Terminal()
    with Progress(10, "x", file=out) as bar:
        for i in range(1, 11):
            bar.update(i, loss="0.5")
    text = out.getvalue()
    assert bar.mode == "bar" and "\r" in text and "10/10" in text and "loss 0.5" in text


def test_loss_postfix_picks_the_group_totals():
    rec = {"step": 3, "nr/total": 0.51234, "nr/render": 0.2, "ds/total": 0.25, "d/loss": 1.0, "skipped": 0,
           "seconds": 0.1}
    assert loss_postfix(rec) == {"nr": "0.5123", "ds": "0.25", "d": "1"}
    assert loss_postfix({"total": 0.125, "skipped": True}) == {"loss": "0.125", "skipped": "True"}
