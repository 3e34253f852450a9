"""The project's one place of colour conversion: the sRGB transfer function on numpy arrays.

Photos (8/16-bit integer files) are sRGB-encoded; every map and render in memory is linear. The curve is the exact
piecewise IEC 61966-2-1 transfer function, per channel:

.. math::

    \\text{linear} = \\begin{cases} s / 12.92 & s \\le 0.04045 \\\\
                                   ((s + 0.055) / 1.055)^{2.4} & s > 0.04045 \\end{cases}

and its inverse (``12.92 l`` for ``l <= 0.0031308``, else ``1.055 l^{1/2.4} - 0.055``), in float32 with the same
operations as the trainer's torch pair (:mod:`svbrdf.trainer.colour`, itself kornia's): the two agree to a float32
rounding (``tests/trainer/test_colour.py``). Values below the thresholds, negative ones included, follow the linear
segment and values above 1 the power segment (no clamping here, unless :func:`linear_to_srgb` is asked to ``clip``).

Until 2026-11-28 this was OpenImageIO's ``colorconvert`` (within 1e-5 of the curve on [0, 1]); the closed form is 3.5x
faster (50 M values: 0.21 s on one core against 0.75 s on two) and the same as the trainer's.
"""

from __future__ import annotations

import numpy as np

#: Linear value / encoded value where the curve's linear segment ends.
LINEAR_THRESHOLD = np.float32(0.0031308)
ENCODED_THRESHOLD = np.float32(0.04045)


def srgb_to_linear(arr: np.ndarray) -> np.ndarray:
    """Decode sRGB-encoded values to linear (exact IEC 61966-2-1 curve, per channel).

    Args:
        arr: float array of any shape (typically (H, W, C)), sRGB-encoded, nominally in [0, 1].

    Returns:
        float32 array of the same shape, linear.
    """
    s = np.asarray(arr, dtype=np.float32)
    power = np.atleast_1d(s + np.float32(0.055))  # an array, for the in-place steps (a 0-d input gives a scalar)
    np.maximum(power, np.float32(0.0), out=power)
    power /= np.float32(1.055)
    np.power(power, np.float32(2.4), out=power)
    return np.where(s > ENCODED_THRESHOLD, power.reshape(s.shape), s / np.float32(12.92))


def linear_to_srgb(arr: np.ndarray, clip: bool = False) -> np.ndarray:
    """Encode linear values to sRGB (exact IEC 61966-2-1 curve, per channel).

    Args:
        arr: float array of any shape (typically (H, W, C)), linear, nominally in [0, 1].
        clip: clip the linear values to [0, 1] first (as for display, or for an error measured on what a
            viewer sees); default: no clamping (see the module docstring).

    Returns:
        float32 array of the same shape, sRGB-encoded. Without ``clip``, clip to [0, 1] before quantising.
    """
    x = np.asarray(arr, dtype=np.float32)
    if clip:
        x = np.clip(x, np.float32(0.0), np.float32(1.0))
    power = np.atleast_1d(np.maximum(x, LINEAR_THRESHOLD))  # an array, for the in-place steps
    np.power(power, np.float32(1 / 2.4), out=power)
    power *= np.float32(1.055)
    power -= np.float32(0.055)
    return np.where(x > LINEAR_THRESHOLD, power.reshape(x.shape), x * np.float32(12.92))


__all__ = ["srgb_to_linear", "linear_to_srgb", "LINEAR_THRESHOLD", "ENCODED_THRESHOLD"]
