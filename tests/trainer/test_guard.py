"""The numerical guard (svbrdf.trainer.guard): finite steps only, rollback to the snapshot after repeated skips."""

import torch

from svbrdf.trainer.guard import NumericalGuard


def _setup(rollback_after=2):
    w = torch.nn.Parameter(torch.ones(3))
    opt = torch.optim.SGD([w], lr=0.1)
    counters = {"nonfinite_skips": 0, "rollbacks": 0}
    guard = NumericalGuard(lambda: {"w": w.detach()}, lambda s: w.data.copy_(s["w"]), rollback_after, counters)
    return w, opt, guard, counters


def test_finite_steps_update_and_nonfinite_ones_are_skipped():
    w, opt, guard, counters = _setup()
    assert guard.step([opt], [w], (w ** 2).sum())
    assert torch.allclose(w.detach(), torch.full((3,), 0.8))
    assert not guard.step([opt], [w], (w * float("nan")).sum())  # non-finite loss
    assert not guard.step([opt], [w], (w * torch.tensor([1.0, float("inf"), 1.0])).sum() * 0)  # non-finite grad
    assert counters == {"nonfinite_skips": 2, "rollbacks": 0}  # no snapshot yet: nothing to roll back to
    assert torch.allclose(w.detach(), torch.full((3,), 0.8)) and w.grad is None


def test_rollback_after_consecutive_skips_restores_the_snapshot():
    w, opt, guard, counters = _setup(rollback_after=2)
    guard.take_snapshot()
    guard.step([opt], [w], (w ** 2).sum())
    moved = w.detach().clone()
    assert not guard.step([opt], [w], (w * float("nan")).sum())
    assert torch.equal(w.detach(), moved)
    guard.step([opt], [w], (w ** 2).sum())  # a good step in between resets the count
    assert not guard.step([opt], [w], (w * float("nan")).sum())
    assert counters["rollbacks"] == 0
    assert not guard.step([opt], [w], (w * float("nan")).sum())
    assert counters == {"nonfinite_skips": 3, "rollbacks": 1} and torch.equal(w.detach(), torch.ones(3))
    guard.step([opt], [w], (w ** 2).sum())
    assert torch.equal(guard.snapshot["w"], torch.ones(3))  # the snapshot is not updated in place by later steps
