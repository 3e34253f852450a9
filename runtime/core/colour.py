"""The project's one place of colour conversion: the sRGB transfer function, via OpenImageIO.

Photos (8/16-bit integer files) are sRGB-encoded; every map and render in memory is linear. The conversion
is OpenImageIO's ``ImageBufAlgo.colorconvert`` between its built-in ``"sRGB"`` and ``"linear"`` colour spaces
(OCIO names "sRGB Encoded Rec.709 (sRGB)" and "Linear Rec.709 (sRGB)"), run on a FLOAT buffer. Both share the
Rec.709 primaries, so only the transfer function changes, and it is the exact piecewise IEC 61966-2-1 curve:

.. math::

    \\text{linear} = \\begin{cases} s / 12.92 & s \\le 0.04045 \\\\
                                   ((s + 0.055) / 1.055)^{2.4} & s > 0.04045 \\end{cases}

and its inverse (``12.92 l`` for ``l <= 0.0031308``, else ``1.055 l^{1/2.4} - 0.055``), to within 3e-5
(measured against this closed form; see ``tests/runtime/core/test_colour.py``). It is applied per channel.
Values below 0 follow the linear segment and values above 1 the power segment (no clamping here, unless
:func:`linear_to_srgb` is asked to ``clip``). The torch pair of the trainer, :mod:`svbrdf.trainer.colour`, is the
same curve with the same convention.

Two traps this module avoids (see the platform notes): converting a uint8 buffer keeps uint8 precision, and
OpenImageIO's ``"scene_linear"`` role is a different gamut (ACEScg), not linear sRGB.
"""

from __future__ import annotations

import numpy as np
import OpenImageIO as oiio

#: OpenImageIO colour-space names used for the conversion (never "scene_linear": wrong gamut).
SRGB_SPACE = "sRGB"
LINEAR_SPACE = "linear"
_ROW = 1024


def _convert(arr: np.ndarray, src: str, dst: str) -> np.ndarray:
    a = np.asarray(arr, dtype=np.float32)
    if a.size == 0:
        return a.copy()
    # The curve is per channel, so any layout is converted as a flat list of RGB triples laid out in rows
    # of up to _ROW pixels (zero-padded): OpenImageIO transforms the first three channels of each pixel, and
    # narrow images are slow (per-scanline overhead).
    flat = a.reshape(-1)
    width = min(_ROW, -(-flat.size // 3))
    rows = -(-flat.size // (3 * width))
    pad = rows * width * 3 - flat.size
    if pad:
        flat = np.concatenate([flat, np.zeros(pad, np.float32)])
    buf = oiio.ImageBuf(oiio.ImageSpec(width, rows, 3, oiio.FLOAT))
    buf.set_pixels(oiio.ROI(), np.ascontiguousarray(flat.reshape(rows, width, 3)))
    out = oiio.ImageBufAlgo.colorconvert(buf, src, dst)
    if out.has_error:  # only possible if the built-in colour config were broken
        raise RuntimeError(f"OpenImageIO colorconvert {src} -> {dst} failed: {out.geterror()}")
    res = out.get_pixels(oiio.FLOAT).reshape(-1)
    return res[: a.size].reshape(a.shape).astype(np.float32, copy=False)


def srgb_to_linear(arr: np.ndarray) -> np.ndarray:
    """Decode sRGB-encoded values to linear (exact IEC 61966-2-1 curve, per channel).

    Args:
        arr: float array of any shape (typically (H, W, C)), sRGB-encoded, nominally in [0, 1].

    Returns:
        float32 array of the same shape, linear.
    """
    return _convert(arr, SRGB_SPACE, LINEAR_SPACE)


def linear_to_srgb(arr: np.ndarray, clip: bool = False) -> np.ndarray:
    """Encode linear values to sRGB (exact IEC 61966-2-1 curve, per channel).

    Args:
        arr: float array of any shape (typically (H, W, C)), linear, nominally in [0, 1].
        clip: clip the linear values to [0, 1] first (as for display, or for an error measured on what a
            viewer sees); default: no clamping (see the module docstring).

    Returns:
        float32 array of the same shape, sRGB-encoded. Without ``clip``, clip to [0, 1] before quantising.
    """
    if clip:
        arr = np.clip(np.asarray(arr, dtype=np.float32), 0.0, 1.0)
    return _convert(arr, LINEAR_SPACE, SRGB_SPACE)


__all__ = ["srgb_to_linear", "linear_to_srgb", "SRGB_SPACE", "LINEAR_SPACE"]
