"""Helpers shared by the benchmark modules (``svbrdf-bench`` and the ``python -m svbrdf.trainer.bench.*`` scripts):
where the repository and the shared data are, and what machine a result was measured on."""

from __future__ import annotations

import os
import platform
from pathlib import Path
from typing import Any, Dict

import numpy as np

from .methods import BenchOptions, torch_available


def repo_root() -> Path:
    """The source checkout this package runs from (editable install), else the current folder."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / "pyproject.toml").is_file() else Path.cwd()


def default_data() -> Path:
    """``../shared/data`` next to the repository root."""
    return repo_root().parent / "shared" / "data"


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
