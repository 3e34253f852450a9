"""The runtime's calls into the trainer: :func:`svbrdf.trainer.refine.refine` for ``--refine`` and
:mod:`svbrdf.trainer.capture` for ``--capture``, imported only when asked (the runtime imports no torch otherwise;
tests/runtime/test_layering.py)."""

from __future__ import annotations

from ..errors import MissingExtraError
from ..install import missing_train_module, train_hint

__all__ = ["load_capture", "load_refine"]


def _missing(what: str, exc: ImportError) -> Exception:
    """The error to raise for ``exc``: :class:`MissingExtraError` naming the pip command when a module of the
    training side is missing (:func:`svbrdf.runtime.install.train_hint`), else ``exc`` itself."""
    module = missing_train_module(exc)
    return exc if module is None else MissingExtraError(train_hint(what, module))


def load_refine():
    """The runtime's one call into the trainer, :func:`svbrdf.trainer.refine.refine`, imported only for ``--refine``.

    Raises:
        MissingExtraError: torch or kornia (the training side) is not installed; the message names the pip command
            for this installation.
    """
    try:
        from svbrdf.trainer.refine import refine
    except ImportError as exc:
        raise _missing("--refine", exc) from None
    return refine


def load_capture():
    """The trainer's capture fit for ``--capture``, the module :mod:`svbrdf.trainer.capture`, imported only then.

    Raises:
        MissingExtraError: the training side is not installed (the message names the pip command).
    """
    try:
        from svbrdf.trainer import capture
    except ImportError as exc:
        raise _missing("--capture", exc) from None
    return capture
