"""The runtime must never import torch (a light install has none)."""

import subprocess
import sys


def test_runtime_does_not_import_torch():
    code = (
        "import svbrdf.runtime, svbrdf.runtime.imageio, svbrdf.runtime.texture_set, svbrdf.runtime.render, "
        "svbrdf.runtime.colour, sys; "
        "assert 'torch' not in sys.modules, 'torch was imported'"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
