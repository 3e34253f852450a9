"""The project's one place of colour conversion: the sRGB transfer function, on numpy arrays and torch tensors.

Photos (8/16-bit integer files) are sRGB-encoded; every map and render in memory is linear. The curve is the exact
piecewise IEC 61966-2-1 transfer function, per channel:

.. math::

    \\text{linear} = \\begin{cases} s / 12.92 & s \\le 0.04045 \\\\
                                   ((s + 0.055) / 1.055)^{2.4} & s > 0.04045 \\end{cases}

and its inverse (``12.92 l`` for ``l <= 0.0031308``, else ``1.055 l^{1/2.4} - 0.055``). One formula serves both
array kinds (as :func:`svbrdf.runtime.core.render.shade` does), taking its functions from the input's module: numpy
input becomes float32; a torch tensor keeps its dtype and device and stays differentiable (the trainer's
:mod:`svbrdf.trainer.colour` re-exports this pair; torch is never imported here). The operations are kornia's
``linear_rgb_to_rgb`` / ``rgb_to_linear_rgb`` (``tests/trainer/test_colour.py``), so the gradient of the encoding is
finite everywhere (the power segment is evaluated on ``max(x, 0.0031308)``); numpy and torch results agree but for
the last bits of the power.

Clamping convention: none. Values below the thresholds, negative ones included, follow the linear segment and values
above 1 the power segment, unless :func:`linear_to_srgb` is asked to ``clip``.

Decision: docs/decisions/017-srgb-in-numpy.md.
"""

from __future__ import annotations

import sys
from typing import Any, Tuple

import numpy as np

#: Linear value / encoded value where the curve's linear segment ends (Python floats: compared in the input's dtype).
LINEAR_THRESHOLD = 0.0031308
ENCODED_THRESHOLD = 0.04045


def _as_float(x: Any) -> Tuple[Any, Any]:
    """``(x, module)``: a torch tensor as it is with ``torch``; anything else as a float32 array with ``numpy``."""
    if type(x).__module__.partition(".")[0] == "torch":
        return x, sys.modules["torch"]
    return np.asarray(x, dtype=np.float32), np


def srgb_to_linear(x: Any) -> Any:
    """Decode sRGB-encoded values to linear (exact IEC 61966-2-1 curve, per channel, no clamping).

    Args:
        x: array-like of any shape (typically (H, W, C)), or a torch tensor (any float dtype), sRGB-encoded,
            nominally in [0, 1].

    Returns:
        linear values of the same shape: a float32 array, or a tensor of the input's dtype.
    """
    s, xp = _as_float(x)
    power = (xp.clip(s + 0.055, 0.0, None) / 1.055) ** 2.4  # positional: numpy < 2.1 has no min=
    return xp.where(s > ENCODED_THRESHOLD, power, s / 12.92)


def linear_to_srgb(x: Any, clip: bool = False) -> Any:
    """Encode linear values to sRGB (exact IEC 61966-2-1 curve, per channel).

    Args:
        x: array-like of any shape (typically (H, W, C)), or a torch tensor (any float dtype), linear, nominally
            in [0, 1].
        clip: clip the linear values to [0, 1] first (as a camera or a display does, or for an error measured on
            what a viewer sees); default: no clamping (see the module docstring).

    Returns:
        sRGB-encoded values of the same shape: a float32 array, or a tensor of the input's dtype. Without ``clip``,
        clip to [0, 1] before quantising.
    """
    x, xp = _as_float(x)
    if clip:
        x = xp.clip(x, 0.0, 1.0)
    power = xp.clip(x, LINEAR_THRESHOLD, None) ** (1 / 2.4) * 1.055 - 0.055
    return xp.where(x > LINEAR_THRESHOLD, power, x * 12.92)


__all__ = ["srgb_to_linear", "linear_to_srgb", "LINEAR_THRESHOLD", "ENCODED_THRESHOLD"]
