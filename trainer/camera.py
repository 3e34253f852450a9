"""The realistic photo model of :mod:`svbrdf.trainer.camera_model` on batched torch tensors, on any device.

Same steps and order as :func:`svbrdf.trainer.camera_model.expose` (exposure ``2 ** ev``, vignetting
``1 - v (r / r_corner)^2``, Poisson-Gaussian noise of variance ``shot * x + read^2``, the highlight roll-off
:func:`svbrdf.trainer.camera_model.roll_off`, clip to [0, 1], 8-bit sRGB storage), one camera per photo, for the
procedural prior's batched stream (``PriorConfig.materials.batched``). The noise comes
from a generator on the photos' device seeded by the caller, so a GPU never waits for the host. Checked against the
numpy model in ``tests/trainer/test_camera.py``.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Optional

import torch

from svbrdf.trainer.camera_model import radius2, roll_off
from svbrdf.trainer.colour import linear_to_srgb, srgb_to_linear
from svbrdf.trainer.device import to_device


@lru_cache(maxsize=16)
def _radius2(height: int, width: int, device: torch.device) -> torch.Tensor:
    """(1, 1, H, W) :func:`svbrdf.trainer.camera_model.radius2` on ``device``, cached."""
    return to_device(torch.from_numpy(radius2(height, width))[..., 0][None, None], device)


def frame_radius2(height: int, width: int, device=None) -> torch.Tensor:
    """(1, 1, H, W) float32 :func:`svbrdf.trainer.camera_model.radius2` of a whole frame on ``device`` (cached)."""
    return _radius2(int(height), int(width), torch.device(device if device is not None else "cpu"))


def expose_batch(radiance: torch.Tensor, ev: torch.Tensor, vignetting: torch.Tensor, shot: torch.Tensor,
                 read: torch.Tensor, generator: Optional[torch.Generator] = None,
                 quantize: bool = True, radius2_map: Optional[torch.Tensor] = None,
                 white: Optional[torch.Tensor] = None, check_white: bool = True) -> torch.Tensor:
    """The photos cameras record of ``radiance``.

    Args:
        radiance: (B, 3, H, W) linear renderings (>= 0, may exceed 1).
        ev, vignetting, shot, read: (B,) camera parameters (see :class:`svbrdf.trainer.camera_model.Camera`).
        generator: noise generator on ``radiance``'s device (None: torch's default one).
        quantize: store as 8-bit sRGB and decode back.
        radius2_map: (B or 1, 1, H, W) squared distance from the frame's centre (:func:`svbrdf.trainer.camera_model.radius2`)
            of each pixel, for renderings that are crops of a larger frame; default: ``radiance`` is the frame.
        white: (B,) white points of the highlight roll-off (>= 1; None or all 1: none).
        check_white: skip the roll-off when every ``white`` is 1 (a read-back of ``white``); False applies it
            whenever ``white`` is given (a white point of 1 leaves a value as it is, to rounding): the device stream,
            whose ``white`` stays on a GPU.

    Returns:
        (B, 3, H, W) float32 linear photos in [0, 1].
    """
    b, _, h, w = radiance.shape
    col = lambda t: to_device(t, radiance.device, torch.float32).view(b, 1, 1, 1)  # noqa: E731
    r2 = _radius2(h, w, radiance.device) if radius2_map is None else radius2_map
    img = radiance.float() * torch.exp2(col(ev)) * (1.0 - col(vignetting) * r2)
    var = col(shot) * img.clamp_min(0.0) + col(read) ** 2
    noise = torch.randn(img.shape, generator=generator, device=img.device, dtype=img.dtype)
    img = img + noise * var.sqrt()
    if white is not None and (not check_white or bool((white != 1.0).any())):
        img = roll_off(img.clamp_min(0.0), col(white))
    img = img.clamp(0.0, 1.0)
    if quantize:
        img = srgb_to_linear(torch.round(linear_to_srgb(img) * 255.0) / 255.0).clamp(0.0, 1.0)
    return img


__all__ = ["expose_batch", "frame_radius2"]
