"""The one training loop (svbrdf.trainer.loop.TrainingLoop): its rules on a counting trainer, and both trainers on it."""

import json
from types import SimpleNamespace

import pytest

from svbrdf.trainer.loop import TrainingLoop


class Counting(TrainingLoop):
    """A trainer whose iteration adds one to ``step``; it records what the loop asked of it."""

    def __init__(self, iters=6, checkpoint_every=2, log_path=None, callback=None, stop_at=None, window=1,
                 stop_every=1, clock=None):
        self.step, self.iters, self.history = 0, iters, []
        self.config = SimpleNamespace(monitor=SimpleNamespace(checkpoint_every=checkpoint_every))
        self.checkpoint_path, self.log_path, self.callback = "ckpt", log_path, callback
        self.saves, self.calls, self.stop_at, self.window, self.stop_every = [], [], stop_at, window, stop_every
        self._init_loop()

    def save(self):
        self.saves.append(self.step)

    def _on_start(self):
        self.calls.append("start")
        return {"event": "start", "step": self.step}

    def _before_iteration(self):
        self.calls.append(f"before {self.step}")

    def _next_record(self):
        self.step += 1
        if self.step % self.window and self.step < self.iters:
            return None
        return {"step": self.step, "loss": float("nan") if self.step == 1 else 0.5}

    def _stop_early(self, record):
        return self.stop_at is not None and record["step"] >= self.stop_at

    def _can_stop_in_time(self):
        return self.step % self.stop_every == 0

    def _on_end(self):
        return {"event": "stop", "step": self.step}


def test_a_run_saves_on_its_cadence_and_once_at_the_end(tmp_path):
    t = Counting(iters=5, checkpoint_every=2, log_path=tmp_path / "log" / "run.jsonl")
    assert t.run() == t.history and [h["step"] for h in t.history] == [1, 2, 3, 4, 5]
    assert t.saves == [2, 4, 5] and not (t.interrupted or t.timed_out or t.stopped_early)
    assert t.calls[0] == "start" and t.calls[-1] == "before 5"  # the hook runs once more at the end
    lines = [json.loads(x) for x in (tmp_path / "log" / "run.jsonl").read_text().splitlines()]
    assert lines[0] == {"event": "start", "step": 0} and lines[-1] == {"event": "stop", "step": 5}
    assert lines[1] == {"step": 1, "loss": None}  # a non-finite value is logged as null: the log stays JSON
    t.saves.clear()
    t.run()  # nothing left to do: the state is saved as it is
    assert t.saves == [5] and t.step == 5


def test_a_window_logs_only_its_records_and_the_cadence_follows_them():
    t = Counting(iters=7, checkpoint_every=4, window=2)
    t.run()
    assert [h["step"] for h in t.history] == [2, 4, 6, 7] and t.saves == [4, 7]


@pytest.mark.parametrize("how", ["callback", "stop_requested"])
def test_a_stop_request_saves_the_state_it_stops_in(how):
    def callback(trainer, record):
        if how == "stop_requested" and record["step"] == 3:
            trainer.stop_requested = True
        return how == "callback" and record["step"] == 3

    t = Counting(iters=10, checkpoint_every=0, callback=callback)
    t.run()
    assert t.step == 3 and t.interrupted and t.saves == [3] and not t.timed_out


def test_the_trainers_rule_stops_early_and_saves_once():
    t = Counting(iters=10, checkpoint_every=2, stop_at=4)
    t.run()
    assert t.step == 4 and t.stopped_early and not t.interrupted and t.saves == [2, 4]  # 4: once, not twice


def test_the_time_limit_stops_only_where_the_trainer_may_stop():
    t = Counting(iters=10, checkpoint_every=0, stop_every=3)
    t.run(max_seconds=0.0)
    assert t.step == 3 and t.timed_out and t.saves == [3] and not t.interrupted
    t.run(max_seconds=None)  # a later run goes on and clears the flag
    assert t.step == 10 and not t.timed_out and t.saves == [3, 10]
    at_end = Counting(iters=3, checkpoint_every=0, stop_every=3)
    at_end.run(max_seconds=0.0)  # reaching the end is not a time-out
    assert at_end.step == 3 and not at_end.timed_out


def test_both_trainers_run_this_loop():
    torch = pytest.importorskip("torch")
    from svbrdf.trainer.prior.trainer import PriorTrainer
    from svbrdf.trainer.train import Trainer

    assert issubclass(Trainer, TrainingLoop) and issubclass(PriorTrainer, TrainingLoop)
    assert Trainer.run is TrainingLoop.run and torch is not None  # PriorTrainer.run documents its limit, then super()
    for cls in (Trainer, PriorTrainer):
        assert {"_on_start", "_next_record", "_on_record"} <= set(vars(cls)), cls


def test_the_per_photo_trainer_stops_at_a_time_limit_and_resumes_to_the_same_weights(tmp_path):
    torch = pytest.importorskip("torch")
    from svbrdf.trainer.checkpoint import load_checkpoint
    from svbrdf.trainer.config import resolve
    from svbrdf.trainer.stage import make_trainer

    photo = torch.rand(1, 3, 40, 40, generator=torch.Generator().manual_seed(0))
    cfg = resolve("tiny", iters_fit=3, checkpoint_every=0, eval_every=0)
    whole = make_trainer(photo, "fit", cfg, threads=1)
    whole.run()
    part = make_trainer(photo, "fit", cfg, threads=1, checkpoint_path=tmp_path / "c.pt", log_path=tmp_path / "l.jsonl")
    part.run(max_seconds=0.0)
    assert part.timed_out and part.step == 1 and load_checkpoint(tmp_path / "c.pt")["step"] == 1
    stop = json.loads((tmp_path / "l.jsonl").read_text().splitlines()[-1])
    assert stop["event"] == "stop" and stop["timed_out"] is True
    rest = make_trainer(photo, resume=tmp_path / "c.pt", threads=1)
    rest.run()
    assert rest.step == 3 and not rest.timed_out
    for (k, a), b in zip(whole.generator.state_dict().items(), rest.generator.state_dict().values()):
        assert torch.equal(a, b), k
