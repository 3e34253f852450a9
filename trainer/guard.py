"""The numerical guard of a training run: skip a step whose loss or gradient is not finite, and after
``rollback_after`` such steps in a row return to the last good in-memory snapshot.

The guard knows nothing of networks: the trainer gives it two functions, ``capture`` (the state a rollback
restores: weights, optimiser states, camera) and ``restore`` (put such a state back).
"""

from __future__ import annotations

import copy
from typing import Any, Callable, Dict, MutableMapping, Optional, Sequence

import torch


class NumericalGuard:
    """Finite-only optimiser steps with snapshot and rollback.

    Args:
        capture: ``() -> state``: what a rollback restores (deep-copied by :meth:`take_snapshot`).
        restore: ``(state) -> None``: puts a captured state back.
        rollback_after: consecutive non-finite steps before a rollback (``TrainConfig.guard.rollback_after``).
        counters: updated in place: ``nonfinite_skips`` (steps skipped) and ``rollbacks``.
    """

    def __init__(self, capture: Callable[[], Dict[str, Any]], restore: Callable[[Dict[str, Any]], None],
                 rollback_after: int, counters: MutableMapping[str, int]):
        self.capture, self.restore = capture, restore
        self.rollback_after = rollback_after
        self.counters = counters
        self.consecutive_bad = 0
        self.snapshot: Optional[Dict[str, Any]] = None

    def take_snapshot(self) -> None:
        """Remember the current state as the last good one."""
        self.snapshot = copy.deepcopy(self.capture())

    def rollback(self) -> None:
        """Return to the last snapshot (counted in ``counters["rollbacks"]``)."""
        self.restore(copy.deepcopy(self.snapshot))  # optimisers would otherwise update the snapshot's tensors
        self.counters["rollbacks"] += 1

    def step(self, optimizers: Sequence[torch.optim.Optimizer], params: Sequence[torch.Tensor],
             loss: torch.Tensor) -> bool:
        """Backward of ``loss`` into ``params`` and a step of ``optimizers`` unless the loss or a gradient is not
        finite (then the gradients are dropped, the skip counted, and a rollback made after ``rollback_after``
        skips in a row). True = stepped."""
        for opt in optimizers:
            opt.zero_grad(set_to_none=True)
        ok = bool(torch.isfinite(loss))
        if ok:
            # `inputs` limits the backward pass to these optimisers' parameters (no stray grads in the others).
            loss.backward(inputs=list(params))
            grads = [p.grad for p in params if p.grad is not None]
            ok = bool(torch.stack([torch.isfinite(g).all() for g in grads]).all()) if grads else True
        if ok:
            for opt in optimizers:
                opt.step()
            self.consecutive_bad = 0
            return True
        for opt in optimizers:
            opt.zero_grad(set_to_none=True)
        self.counters["nonfinite_skips"] += 1
        self.consecutive_bad += 1
        if self.consecutive_bad >= self.rollback_after and self.snapshot is not None:
            self.rollback()
            self.consecutive_bad = 0
        return False


__all__ = ["NumericalGuard"]
