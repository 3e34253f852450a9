"""The trainer's one place of colour conversion: the sRGB transfer function on torch tensors.

The same IEC 61966-2-1 curve as :mod:`svbrdf.runtime.core.colour` (the numpy pair), differentiable, written
with the same operations as kornia's ``linear_rgb_to_rgb`` / ``rgb_to_linear_rgb`` (which it used to call), so results
are exactly kornia's (checked in ``tests/trainer/test_colour.py``) without importing kornia: the procedural prior
trains on GPU machines that do not have it. The numpy pair uses the same float32 operations: the two agree but for
the last bits of the power.

Clamping convention (that of the numpy pair): none. Values at or below the curve's threshold (0.0031308 linear,
0.04045 encoded) follow the linear segment, so negative values stay negative; values above 1 follow the power
segment. ``linear_to_srgb(x, clip=True)`` clamps to [0, 1] first (before comparing with a photo, which the
sensor clipped); the gradient of the encoding is finite everywhere (kornia evaluates the power segment on
``max(x, 0.0031308)``).
"""

from __future__ import annotations

import torch

#: Linear value / encoded value where the curve's linear segment ends.
LINEAR_THRESHOLD = 0.0031308
ENCODED_THRESHOLD = 0.04045


def linear_to_srgb(x: torch.Tensor, clip: bool = False) -> torch.Tensor:
    """Encode linear values with the sRGB curve, per channel.

    Args:
        x: (*, 3, H, W) linear RGB tensor, any float dtype.
        clip: clamp the linear values to [0, 1] first (as a camera or a display does); default: no clamping
            (see the module docstring).

    Returns:
        tensor of the same shape and dtype, sRGB-encoded.
    """
    x = x.clamp(0.0, 1.0) if clip else x
    power = 1.055 * torch.pow(x.clamp(min=LINEAR_THRESHOLD), 1 / 2.4) - 0.055
    return torch.where(x > LINEAR_THRESHOLD, power, 12.92 * x)


def srgb_to_linear(x: torch.Tensor) -> torch.Tensor:
    """Decode sRGB-encoded values to linear, per channel (no clamping: see the module docstring).

    Args:
        x: (*, 3, H, W) sRGB-encoded RGB tensor, any float dtype.

    Returns:
        tensor of the same shape and dtype, linear.
    """
    power = torch.pow((x + 0.055).clamp(min=0.0) / 1.055, 2.4)
    return torch.where(x > ENCODED_THRESHOLD, power, x / 12.92)


__all__ = ["linear_to_srgb", "srgb_to_linear"]
