"""The torch sRGB pair (svbrdf.trainer.colour) against the runtime's numpy pair (svbrdf.runtime.core.colour)."""

import numpy as np
import pytest
import torch

from svbrdf.runtime.core import colour as np_colour
from svbrdf.trainer.colour import linear_to_srgb, srgb_to_linear


def _ramp():
    # Both segments, the knees, below 0 and above 1, as (1, 3, H, W).
    v = np.concatenate([np.linspace(-0.2, 1.5, 4097), [0.0031308, 0.04045]]).astype(np.float32)
    return np.repeat(v[None, None, None, :], 3, axis=1)


@pytest.mark.parametrize("torch_fn, np_fn", [(linear_to_srgb, np_colour.linear_to_srgb),
                                             (srgb_to_linear, np_colour.srgb_to_linear)])
def test_torch_pair_is_the_runtime_curve(torch_fn, np_fn):
    """The same float32 operations: equal but for the last bits of the power, whose vectorised kernels (numpy's,
    torch's) differ between CPUs; allowed 8 float32 steps (measured here: 2)."""
    x = _ramp()
    eps = float(np.finfo(np.float32).eps)
    np.testing.assert_allclose(torch_fn(torch.from_numpy(x)).numpy(), np_fn(x), atol=8 * eps, rtol=8 * eps)


def test_no_clamping_unless_asked():
    x = torch.tensor([-0.5, 0.5, 2.0]).view(1, 3, 1, 1)
    enc = linear_to_srgb(x)
    assert float(enc[0, 0]) == pytest.approx(-0.5 * 12.92)  # the linear segment continues below 0
    assert float(enc[0, 2]) > 1.0  # the power segment above 1
    assert torch.equal(linear_to_srgb(x, clip=True), linear_to_srgb(x.clamp(0, 1)))
    np.testing.assert_array_equal(np_colour.linear_to_srgb(x.numpy(), clip=True),
                                  np_colour.linear_to_srgb(np.clip(x.numpy(), 0, 1)))
    assert torch.equal(srgb_to_linear(linear_to_srgb(x, clip=True)).clamp(0, 1), srgb_to_linear(
        linear_to_srgb(x.clamp(0, 1))))


def test_gradient_is_finite_at_zero():
    x = torch.zeros(1, 3, 2, 2, requires_grad=True)
    linear_to_srgb(x).sum().backward()
    assert torch.isfinite(x.grad).all()


def test_the_curves_are_kornias_without_importing_it():
    kornia = pytest.importorskip("kornia")
    x = torch.linspace(-0.1, 1.2, 3 * 23 * 29).view(3, 23, 29)
    assert torch.equal(linear_to_srgb(x), kornia.color.linear_rgb_to_rgb(x))
    assert torch.equal(srgb_to_linear(x), kornia.color.rgb_to_linear_rgb(x))


@pytest.mark.integration
def test_the_prior_imports_without_kornia_and_openimageio():
    import subprocess
    import sys

    code = (
        "import sys, importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path, target=None):\n"
        "        if name.split('.')[0] in ('kornia', 'kornia_rs', 'OpenImageIO'):\n"
        "            raise ImportError('blocked ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import svbrdf.trainer.prior, svbrdf.trainer.cli\n"
        "print('ok')\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and run.stdout.strip() == "ok", run.stderr[-2000:]
