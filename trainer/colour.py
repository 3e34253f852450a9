"""The trainer's sRGB transfer function on torch tensors: the runtime's curve (:mod:`svbrdf.runtime.core.colour`).

One formula serves numpy arrays and tensors; on a tensor it keeps the dtype and device and is differentiable, with
kornia's operations (so results are exactly kornia's, checked in ``tests/trainer/test_colour.py``) without importing
kornia: the procedural prior trains on GPU machines that do not have it. No clamping unless
``linear_to_srgb(x, clip=True)`` (before comparing with a photo, which the sensor clipped); the gradient of the
encoding is finite everywhere.
"""

from __future__ import annotations

from svbrdf.runtime.core.colour import ENCODED_THRESHOLD, LINEAR_THRESHOLD, linear_to_srgb, srgb_to_linear

__all__ = ["linear_to_srgb", "srgb_to_linear", "LINEAR_THRESHOLD", "ENCODED_THRESHOLD"]
