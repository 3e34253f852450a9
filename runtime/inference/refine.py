"""The runtime's extension points: ``--refine`` and ``--capture`` run code of the training side, which the runtime
never imports. The training side declares it in the package's metadata (``pyproject.toml``,
``[project.entry-points."svbrdf.extensions"]``: ``refine`` = :func:`svbrdf.trainer.refine.refine`, ``capture`` =
:mod:`svbrdf.trainer.capture`), and :func:`load_refine` / :func:`load_capture` load it by name only when asked, so the
runtime has no import of a higher layer (tests/runtime/test_layering.py) and a light install (no torch) still
previews."""

from __future__ import annotations

from importlib import metadata

from ..errors import MissingExtraError
from ..install import install_command, missing_train_module, train_hint

__all__ = ["EXTENSIONS", "load_capture", "load_refine"]

#: The entry-point group the training side registers its extensions in.
EXTENSIONS = "svbrdf.extensions"


def _load(name: str, what: str):
    """The extension ``name`` of :data:`EXTENSIONS`, loaded.

    Raises:
        MissingExtraError: the extension is not registered (stale metadata: the command to reinstall) or its
            module needs torch or kornia, which are not installed (the pip command for this installation).
    """
    found = [ep for ep in metadata.entry_points(group=EXTENSIONS) if ep.name == name]
    if not found:
        raise MissingExtraError(f"{what} needs the training side's '{name}' extension, which this installation does not "
                                f"register (reinstall svbrdf: {install_command('train')})")
    try:
        return found[0].load()
    except ImportError as exc:
        module = missing_train_module(exc)
        if module is None:
            raise
        raise MissingExtraError(train_hint(what, module)) from None


def load_refine():
    """:func:`svbrdf.trainer.refine.refine` (the ``refine`` extension), loaded only for ``--refine``.

    Raises:
        MissingExtraError: torch or kornia (the training side) is not installed; the message names the pip command
            for this installation.
    """
    return _load("refine", "--refine")


def load_capture():
    """The capture fit, the module :mod:`svbrdf.trainer.capture` (the ``capture`` extension), loaded only for
    ``--capture``.

    Raises:
        MissingExtraError: the training side is not installed (the message names the pip command).
    """
    return _load("capture", "--capture")
