"""The torch sRGB pair (svbrdf.trainer.colour) against the runtime's numpy pair (svbrdf.runtime.colour)."""

import numpy as np
import pytest
import torch

from svbrdf.runtime import colour as np_colour
from svbrdf.trainer.colour import linear_to_srgb, srgb_to_linear


def _ramp():
    # The toe of both segments, the knees and the end points, as (1, 3, H, W).
    v = np.concatenate([np.linspace(0, 1, 4097), [0.0031308, 0.04045]]).astype(np.float32)
    return np.repeat(v[None, None, None, :], 3, axis=1)


@pytest.mark.parametrize("torch_fn, np_fn", [(linear_to_srgb, np_colour.linear_to_srgb),
                                             (srgb_to_linear, np_colour.srgb_to_linear)])
def test_torch_pair_is_the_runtime_curve(torch_fn, np_fn):
    x = _ramp()
    np.testing.assert_allclose(torch_fn(torch.from_numpy(x)).numpy(), np_fn(x), atol=3e-5, rtol=0)


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
