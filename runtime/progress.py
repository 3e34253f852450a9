"""Progress of long work on stderr, the same way in every command: a tqdm bar (count, rate, ETA and the latest
loss) when stderr is a terminal, one plain line every ``every`` steps when it is not (a log file, a pipe, CI), and
nothing when quiet.

::

    with Progress(total=300, desc="refine wood.png", quiet=args.quiet) as bar:
        for step in range(1, 301):
            ...
            bar.update(step, loss=f"{loss:.4f}")
"""

from __future__ import annotations

import sys
import time
from typing import IO, Any, Dict, Mapping, Optional

from tqdm import tqdm

#: The plain line of the non-terminal mode: ``refine wood.png: 40/300 [00:12<01:18, 3.33it/s, loss 0.0412]``.
LINE_FORMAT = "{desc}: {n_fmt}/{total_fmt} [{elapsed}<{remaining}, {rate_fmt}{postfix}]"


def default_every(total: int) -> int:
    """Steps between two plain lines: about 20 lines per run, at least one every 100 steps."""
    return max(1, min(100, total // 20))


class Progress:
    """Progress of ``total`` steps: a bar, plain lines or nothing (see the module docstring).

    Args:
        total: number of steps (an upper bound when the work may stop early).
        desc: what is being done, e.g. ``"refine wood.png"``.
        quiet: print nothing.
        file: the stream (default ``sys.stderr``); a terminal gets the bar, anything else plain lines.
        every: steps between plain lines (default :func:`default_every`); the first and the last step are always
            printed.
        initial: steps already done (a resumed run); the rate and ETA count only the new ones.
        unit: what one step is, for the rate (``"it"`` iterations, ``"photo"``, ``"run"``).
    """

    def __init__(self, total: int, desc: str = "", *, quiet: bool = False, file: Optional[IO[str]] = None,
                 every: Optional[int] = None, initial: int = 0, unit: str = "it"):
        self.file = file if file is not None else sys.stderr
        self.total, self.desc, self.unit, self.initial = int(total), desc, unit, int(initial)
        self.every = every or default_every(self.total)
        self.n, self.postfix = self.initial, ""
        self.start = time.perf_counter()
        isatty = getattr(self.file, "isatty", None)
        self.mode = "off" if quiet else ("bar" if isatty is not None and isatty() else "lines")
        self._bar, self._printed = None, None
        if self.mode == "bar":
            self._bar = tqdm(total=self.total, initial=self.initial, desc=desc, unit=unit, file=self.file,
                             dynamic_ncols=True, leave=True)

    def update(self, n: Optional[int] = None, **postfix: Any) -> None:
        """Move to step ``n`` (default: one more) and show ``postfix`` (e.g. ``loss="0.041"``) beside it."""
        n = self.n + 1 if n is None else int(n)
        advanced, self.n = n - self.n, n
        if postfix:
            self.postfix = ", ".join(f"{k} {v}" for k, v in postfix.items())
        if self._bar is not None:
            if postfix:
                self._bar.set_postfix_str(self.postfix, refresh=False)
            self._bar.update(advanced)
        elif self.mode == "lines" and (n % self.every == 0 or n == self.total or n == self.initial + 1):
            self._print_line()

    def _print_line(self) -> None:
        self.file.write(self.line() + "\n")
        self.file.flush()
        self._printed = self.n

    def line(self) -> str:
        """The current state as one plain line (:data:`LINE_FORMAT`)."""
        return tqdm.format_meter(self.n, self.total, time.perf_counter() - self.start, prefix=self.desc,
                                 unit=self.unit, postfix=self.postfix or None, initial=self.initial,
                                 bar_format=LINE_FORMAT)

    def close(self) -> None:
        """End the bar; in the plain mode print the last step if it was not printed (a run that stopped early)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif self.mode == "lines" and self.n > self.initial and self._printed != self.n:
            self._print_line()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def loss_postfix(record: Mapping[str, Any]) -> Dict[str, str]:
    """The headline losses of a training record (``svbrdf.trainer.train.Trainer`` or the prior's) for
    :meth:`Progress.update`: each group's total (``nr/total`` -> ``nr``, ``d/loss`` -> ``d``, ``total`` -> ``loss``),
    and ``skipped`` when steps were skipped."""
    out = {}
    for key, value in record.items():
        if value is None or isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        if key == "total":
            out["loss"] = f"{value:.4g}"
        elif key.endswith("/total") or key == "d/loss":
            out[key.split("/")[0]] = f"{value:.4g}"
    if record.get("skipped"):
        out["skipped"] = str(record["skipped"])
    return out


def write(msg: str, file: Optional[IO[str]] = None) -> None:
    """Print one line without breaking a bar that is on the screen (``tqdm.write``); default stream stderr."""
    tqdm.write(msg, file=file if file is not None else sys.stderr)


__all__ = ["Progress", "LINE_FORMAT", "default_every", "loss_postfix", "write"]
