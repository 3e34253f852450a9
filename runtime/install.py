"""What to install for the optional training side, phrased for the way this copy of svbrdf was installed.

Standard library only and no import at module level beyond it, so that a command can say what is missing
before it imports anything heavy. ``svbrdf-train``, ``svbrdf-export`` and ``svbrdf-preview --refine`` use it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional
from urllib.parse import unquote, urlparse

#: Top-level modules of the ``train`` extra (pyproject.toml). A missing one means the light install.
TRAIN_MODULES = ("torch", "kornia", "onnx", "onnxscript")


def install_command(extra: str = "train", package_dir: Optional[Path] = None) -> str:
    """The pip command that adds ``extra`` to this installation.

    Args:
        extra: a name of ``[project.optional-dependencies]``.
        package_dir: the folder of ``svbrdf.runtime`` (default: this module's); for tests.

    Returns:
        ``pip install -e "<checkout>[extra]"`` when the package runs from a source checkout (an editable install),
        ``pip install "<checkout or wheel>[extra]"`` when it was installed from a local folder or wheel file that
        still exists (pip's ``direct_url.json``), else ``pip install "svbrdf[extra]"``.
    """
    here = Path(package_dir) if package_dir is not None else Path(__file__).resolve().parent
    root = here.parent
    if (root / "pyproject.toml").is_file():  # runtime/ of a checkout: the package is the checkout itself
        return f'pip install -e "{root}[{extra}]"'
    for info in sorted(here.parent.parent.glob("svbrdf-*.dist-info")):  # site-packages/svbrdf/runtime
        try:
            origin = json.loads((info / "direct_url.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        url = urlparse(origin.get("url", ""))
        source = Path(unquote(url.path)) if url.scheme == "file" else None
        if source is not None and source.exists():
            editable = "-e " if origin.get("dir_info", {}).get("editable") else ""
            return f'pip install {editable}"{source}[{extra}]"'
    return f'pip install "svbrdf[{extra}]"'


def missing_train_module(exc: BaseException) -> Optional[str]:
    """The top-level name of the ``train`` extra's module whose absence raised ``exc``, else None."""
    if not isinstance(exc, ImportError):
        return None
    root = (exc.name or "").split(".")[0]
    return root if root in TRAIN_MODULES else None


def train_hint(what: str, module: str = "torch") -> str:
    """One line: ``what`` needs ``module`` of the ``train`` extra, and the command that installs it."""
    return f'{what} needs {module} (the "train" extra), not installed here: {install_command("train")}'


__all__ = ["TRAIN_MODULES", "install_command", "missing_train_module", "train_hint"]
