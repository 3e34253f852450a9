"""Helpers of ``svbrdf-bench``: where the repository and the shared data are, and what machine a result was measured on."""

from __future__ import annotations

import os
import platform
from pathlib import Path
from typing import Any, Dict, Optional

import numpy as np

from svbrdf.runtime.errors import SvbrdfError

from .methods import BenchOptions, torch_available


def _checkout() -> Optional[Path]:
    """The svbrdf source checkout: the one this package runs from (editable install), else the current folder if
    it is one (a regular install run from its checkout, as CI does), else None."""
    for root in (Path(__file__).resolve().parents[2], Path.cwd()):
        project = root / "pyproject.toml"
        try:
            if project.is_file() and 'name = "svbrdf"' in project.read_text(encoding="utf-8"):
                return root
        except OSError:
            continue
    return None


def repo_root() -> Path:
    """The source checkout (:func:`_checkout`), else the current folder."""
    return _checkout() or Path.cwd()


def default_data() -> Path:
    """``shared/data`` beside the source checkout (``<checkout>/../shared/data``).

    The checkout is the one the package runs from (editable install), or the current folder when it is an svbrdf
    checkout (a regular install run from its checkout).

    Raises:
        SvbrdfError: no source checkout (an installed wheel run elsewhere has no default), or the folder is
            missing; the message says to pass ``--data DIR``.
    """
    root = _checkout()
    if root is None:
        raise SvbrdfError("no default data folder outside a source checkout; pass --data DIR")
    data = root.parent / "shared" / "data"
    if not data.is_dir():
        raise SvbrdfError(f"default data folder {data} (shared/data beside the checkout) does not exist; "
                          f"pass --data DIR")
    return data


def machine_info(opts: BenchOptions) -> Dict[str, Any]:
    """CPU model, visible cores, thread counts and library versions."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    versions: Dict[str, str] = {"python": platform.python_version(), "numpy": np.__version__}
    import OpenImageIO as oiio

    versions["OpenImageIO"] = oiio.__version__
    torch_threads = None
    if torch_available():
        import torch

        versions["torch"] = torch.__version__
        if opts.threads:
            torch.set_num_threads(opts.threads)
        torch_threads = torch.get_num_threads()
    try:
        import onnxruntime

        versions["onnxruntime"] = onnxruntime.__version__
    except ImportError:
        pass
    return {"cpu": cpu, "cores": cores, "cpu_count": os.cpu_count(), "platform": platform.platform(),
            "torch_threads": torch_threads, "ort_threads": opts.threads or os.cpu_count(), "versions": versions}


__all__ = ["repo_root", "default_data", "machine_info"]
