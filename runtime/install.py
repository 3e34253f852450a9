"""What to install for the optional training side, phrased for the way this copy of svbrdf was installed.

Standard library only and no import at module level beyond it, so that a command can say what is missing
before it imports anything heavy. ``svbrdf-train``, ``svbrdf-export`` and ``svbrdf-preview --refine`` use it.
"""

from __future__ import annotations

import json
import os
import sys
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
        ``PIP install -e "<checkout>[extra]"`` when the package runs from a source checkout (an editable install),
        ``PIP install "<checkout or wheel>[extra]"`` when it was installed from a local folder or wheel file that
        still exists (pip's ``direct_url.json``), else ``PIP install "svbrdf[extra]"``; ``PIP`` is
        :func:`pip_command`.
    """
    here = Path(package_dir) if package_dir is not None else Path(__file__).resolve().parent
    root = here.parent
    pip = pip_command()
    if (root / "pyproject.toml").is_file():  # runtime/ of a checkout: the package is the checkout itself
        return f'{pip} install -e "{root}[{extra}]"'
    for info in sorted(here.parent.parent.glob("svbrdf-*.dist-info")):  # site-packages/svbrdf/runtime
        try:
            origin = json.loads((info / "direct_url.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        url = urlparse(origin.get("url", ""))
        source = Path(unquote(url.path)) if url.scheme == "file" else None
        if source is not None and source.exists():
            editable = "-e " if origin.get("dir_info", {}).get("editable") else ""
            return f'{pip} install {editable}"{source}[{extra}]"'
    return f'{pip} install "svbrdf[{extra}]"'


def pip_command(python: Optional[str] = None, cwd: Optional[Path] = None) -> str:
    """The pip that installs into the environment running ``python`` (default this interpreter).

    In a virtual environment, its ``bin/pip`` (``Scripts/pip.exe`` on Windows) as a path relative to ``cwd``
    (default the current folder) when it lies below it (``.venv/bin/pip``), else absolute; outside one, or when
    the venv has no pip, ``pip``.
    """
    exe = Path(python or sys.executable)
    in_venv = python is not None or sys.prefix != sys.base_prefix
    pip = exe.with_name("pip.exe" if exe.suffix == ".exe" else "pip")
    if not in_venv or not pip.is_file():
        return "pip"
    here = Path(cwd) if cwd is not None else Path.cwd()
    try:
        return str(Path(os.path.relpath(pip, here))) if pip.resolve().is_relative_to(here.resolve()) else str(pip)
    except ValueError:  # another drive
        return str(pip)


def missing_train_module(exc: BaseException) -> Optional[str]:
    """The top-level name of the ``train`` extra's module whose absence raised ``exc``, else None."""
    if not isinstance(exc, ImportError):
        return None
    root = (exc.name or "").split(".")[0]
    return root if root in TRAIN_MODULES else None


def train_hint(what: str, module: str = "torch") -> str:
    """One line: ``what`` needs ``module`` of the ``train`` extra, and the command that installs it."""
    return f'{what} needs {module} (the "train" extra), not installed here: {install_command("train")}'


__all__ = ["TRAIN_MODULES", "install_command", "missing_train_module", "pip_command", "train_hint"]
