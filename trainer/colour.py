"""The trainer's one place of colour conversion: the sRGB transfer function on torch tensors, via kornia.

The same IEC 61966-2-1 curve as :mod:`svbrdf.runtime.colour` (the numpy pair, OpenImageIO), differentiable:
:func:`linear_to_srgb` is kornia's ``linear_rgb_to_rgb`` and :func:`srgb_to_linear` its ``rgb_to_linear_rgb``,
so results are exactly kornia's. Both agree with the numpy pair to within 3e-5 on [0, 1]
(``tests/trainer/test_colour.py``).

Clamping convention (that of the numpy pair): none. Values at or below the curve's threshold (0.0031308 linear,
0.04045 encoded) follow the linear segment, so negative values stay negative; values above 1 follow the power
segment. ``linear_to_srgb(x, clip=True)`` clamps to [0, 1] first (before comparing with a photo, which the
sensor clipped); the gradient of the encoding is finite everywhere (kornia evaluates the power segment on
``max(x, 0.0031308)``).
"""

from __future__ import annotations

import torch
from kornia.color import linear_rgb_to_rgb, rgb_to_linear_rgb


def linear_to_srgb(x: torch.Tensor, clip: bool = False) -> torch.Tensor:
    """Encode linear values with the sRGB curve, per channel.

    Args:
        x: (*, 3, H, W) linear RGB tensor, any float dtype.
        clip: clamp the linear values to [0, 1] first (as a camera or a display does); default: no clamping
            (see the module docstring).

    Returns:
        tensor of the same shape and dtype, sRGB-encoded.
    """
    return linear_rgb_to_rgb(x.clamp(0.0, 1.0) if clip else x)


def srgb_to_linear(x: torch.Tensor) -> torch.Tensor:
    """Decode sRGB-encoded values to linear, per channel (no clamping: see the module docstring).

    Args:
        x: (*, 3, H, W) sRGB-encoded RGB tensor, any float dtype.

    Returns:
        tensor of the same shape and dtype, linear.
    """
    return rgb_to_linear_rgb(x)


__all__ = ["linear_to_srgb", "srgb_to_linear"]
