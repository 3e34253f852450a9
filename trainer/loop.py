"""The one training loop of both trainers: :class:`TrainingLoop`.

The per-photo :class:`~svbrdf.trainer.train.Trainer` and the stage one's
:class:`~svbrdf.trainer.prior.trainer.PriorTrainer` run the same loop (:meth:`TrainingLoop.run`): iterate until
``iters``; one JSON line per log record; a checkpoint every ``config.monitor.checkpoint_every`` iterations and one
when the run stops, of the state it stops in; stop when the callback returns True or ``stop_requested`` is set
(``interrupted``), at a wall-clock limit (``timed_out``, resumable) or by the trainer's own rule (``stopped_early``).
What is particular to a trainer is a hook:

======================  =========================================  ===========================================
hook                    Trainer                                    PriorTrainer
======================  =========================================  ===========================================
``_on_start``           the guard's first snapshot; a "start" or   the log window starts
                        "resume" line in the log
``_before_iteration``   -                                          the recipe's changes due at this step
``_next_record``        one iteration (its record)                 one step; every ``log_every`` steps the
                                                                   mean record of the window (else None)
``_on_record``          the guard's snapshot every                 wall time; the evaluation on the held-out
                        ``guard.snapshot_every`` clean steps        batch every ``eval_every``
``_history_entry``      the record                                 the record without its evaluation
``_stop_early``         the plateau rule (``quality="auto"``)      never
``_can_stop_in_time``   any iteration                              where a new draw of materials starts (so a
                                                                   resume continues the same stream)
``_on_end``             a "stop" line in the log                   -
======================  =========================================  ===========================================
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Callable, Dict, IO, List, Mapping, Optional

from svbrdf.runtime.jsonutil import finite_json

#: ``callback(trainer, record)`` after every log record; returning True stops the run (after this record; the
#: trainer's ``interrupted`` is then set and its checkpoint saved).
Callback = Callable[[Any, Dict[str, Any]], Optional[bool]]


class TrainingLoop:
    """The loop of a trainer (see the module docstring); a trainer subclasses it and sets, in its ``__init__``:
    ``step``, ``iters`` (attribute or property), ``config`` (with ``monitor.checkpoint_every``), ``history``,
    ``checkpoint_path``, ``log_path``, ``callback`` and a ``save()`` method, then calls :meth:`_init_loop`.

    Attributes:
        interrupted: the last run stopped because the callback or ``stop_requested`` asked.
        stop_requested: set (by a signal handler, another thread, a callback) to end :meth:`run` after the current
            iteration: it writes the (possibly short) log record and the checkpoint and returns; a resume continues.
        timed_out: the last run stopped at its wall-clock limit (checkpoint saved, resumable).
        stopped_early: a run stopped by the trainer's own rule (:meth:`_stop_early`).
    """

    step: int
    history: List[Dict[str, Any]]
    checkpoint_path: Optional[Path]
    log_path: Optional[Path]
    callback: Optional[Callback]

    def _init_loop(self) -> None:
        self.interrupted = False
        self.stop_requested = False
        self.timed_out = False
        self.stopped_early = False
        self._deadline: Optional[float] = None

    # ------------------------------------------------------------------ hooks (defaults: nothing particular)
    def _on_start(self) -> Optional[Dict[str, Any]]:
        """Before the first iteration of a run; returns a line for the log, or None."""
        return None

    def _before_iteration(self) -> None:
        """Before every iteration, and once more before the run ends at ``iters``."""

    def _next_record(self) -> Optional[Dict[str, Any]]:
        """Train (at least) one iteration; returns its log record, or None when no record is due yet."""
        raise NotImplementedError

    def _on_record(self, record: Dict[str, Any]) -> None:
        """A record is made (before it enters the history and the log; it may add to it)."""

    def _history_entry(self, record: Dict[str, Any]) -> Dict[str, Any]:
        """What of ``record`` the history (and so the checkpoint) keeps."""
        return record

    def _stop_early(self, record: Dict[str, Any]) -> bool:
        """The trainer's own rule to end the run after ``record``."""
        return False

    def _can_stop_in_time(self) -> bool:
        """Whether the run may stop for its time limit at this step."""
        return True

    def _on_end(self) -> Optional[Dict[str, Any]]:
        """After the last checkpoint of a run; returns a line for the log, or None."""
        return None

    # ------------------------------------------------------------------ the loop
    def _time_up(self) -> bool:
        """The wall-clock limit of this run is reached where the run may stop for it (:meth:`_can_stop_in_time`)."""
        return (self._deadline is not None and self._can_stop_in_time()
                and time.perf_counter() >= self._deadline)

    def _open_log(self) -> Optional[IO[str]]:
        if self.log_path is None:
            return None
        self.log_path.parent.mkdir(parents=True, exist_ok=True)
        return open(self.log_path, "a", encoding="utf-8")

    @property
    def checkpoint_every(self) -> int:
        """Iterations between checkpoints (0: only when the run stops): ``config.monitor.checkpoint_every``."""
        return self.config.monitor.checkpoint_every

    def run(self, max_seconds: Optional[float] = None) -> List[Dict[str, Any]]:
        """Train from ``step`` up to ``iters``; returns the history.

        Every ``config.monitor.checkpoint_every`` iterations (0: never) and when the run stops, the checkpoint is
        saved (with a ``checkpoint_path``); a run that stops saves the state it stops in once, and a run that had
        nothing left to do saves its state as it is. The run stops at ``iters``, when the callback returns True or
        ``stop_requested`` is set (``interrupted``), when the trainer's own rule says so (``stopped_early``) or
        past ``max_seconds`` of wall time (``timed_out``; checked after each log record where
        :meth:`_can_stop_in_time`).
        """
        self.timed_out = False
        self._deadline = None if max_seconds is None else time.perf_counter() + max_seconds
        log = self._open_log()

        def write(line: Optional[Mapping[str, Any]]) -> None:
            if log is not None and line is not None:
                log.write(json.dumps(finite_json(line), allow_nan=False) + "\n")
                log.flush()

        saved: Optional[int] = None
        try:
            write(self._on_start())
            while True:
                self._before_iteration()
                if self.step >= self.iters:
                    break
                record = self._next_record()
                if record is None:
                    continue
                self._on_record(record)
                self.history.append(self._history_entry(record))
                write(record)
                early = self._stop_early(record)
                stop = bool(self.callback(self, record)) if self.callback is not None else False
                stop = stop or self.stop_requested
                at_end = self.step >= self.iters
                late = not at_end and self._time_up()
                every = self.checkpoint_every
                if self.checkpoint_path is not None and (at_end or stop or early or late
                                                         or (every and self.step % every == 0)):
                    self.save()
                    saved = self.step
                self.stopped_early = self.stopped_early or early
                if stop:
                    self.interrupted = True
                if stop or early:
                    break
                if late:
                    self.timed_out = True
                    break
            if self.checkpoint_path is not None and saved != self.step:
                self.save()
            write(self._on_end())
        finally:
            if log is not None:
                log.close()
        return self.history


__all__ = ["TrainingLoop", "Callback"]
