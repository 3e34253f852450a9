"""The photo as :func:`~svbrdf.runtime.inference.pipeline.estimate` takes it: a file or an array read as linear RGB
and downsized to ``max_size`` (:func:`read_photo`), a large file on the guided path read strip by strip into its
block means and luminance, never whole (:func:`read_streamed`), and the greyscale check (:func:`warn_if_greyscale`).
"""

from __future__ import annotations

import os
import warnings
from typing import Optional, Union

import numpy as np

from ..core.filters import all_finite, block_mean
from ..errors import ImageError
from ..io.images import ImageWarning, read_image, read_strips, resize_long_side
from .guided import Upsampling, luminance
from .manifest import MIN_SIZE

__all__ = ["GREY_TOLERANCE", "READ_STRIP_BYTES", "read_photo", "read_streamed", "warn_if_greyscale"]

#: Largest channel spread (linear) of a photo taken as greyscale by :func:`warn_if_greyscale`.
GREY_TOLERANCE = 1.0 / 512
#: Bytes of float32 one strip of a photo read strip by strip takes (:func:`read_strips`): small enough for the C
#: allocator to reuse the strips' memory instead of mapping fresh pages.
READ_STRIP_BYTES = 8 << 20


def warn_if_greyscale(image: np.ndarray, name: str) -> bool:
    """Warn (:class:`~svbrdf.runtime.io.images.ImageWarning`) when an (H, W, 3) photo has no colour: a one-channel
    file (read as R = G = B) or three channels equal within :data:`GREY_TOLERANCE`. The model then invents the
    colour of the diffuse and specular maps. Returns whether it warned."""
    grey = True
    rows = max(1, (1 << 20) // max(1, image.shape[1]))  # strips of a megapixel: a colour photo stops at the first
    for y0 in range(0, image.shape[0], rows):
        s = image[y0:y0 + rows]
        if any(float(np.abs(s[..., c] - s[..., 1]).max()) > GREY_TOLERANCE for c in (0, 2)):
            grey = False
            break
    if grey:
        _greyscale_warning(name)
    return grey


def _greyscale_warning(name: str) -> None:
    warnings.warn(ImageWarning(f"{name}: greyscale photo (no colour); the model invents the colour of the diffuse and "
                               f"specular maps"), stacklevel=3)


def read_photo(photo: Union[str, os.PathLike, np.ndarray], max_size: int, info: Optional[dict] = None) -> tuple:
    """``(name, (H, W, 3) linear image with long side <= max_size, (height, width) before downsizing)``; ``info``:
    the file's header facts (:func:`~svbrdf.runtime.io.process.check_memory`)."""
    if isinstance(photo, np.ndarray):
        name = "<array>"
        if photo.ndim != 3 or photo.shape[-1] != 3:
            raise ImageError(f"{name}: expected an (H, W, 3) linear RGB array, got shape {photo.shape}")
        image = np.asarray(photo, dtype=np.float32)
        if not all_finite(image):
            raise ImageError(f"{name}: image has NaN/Inf values")
        if min(image.shape[:2]) >= MIN_SIZE and max(image.shape[:2]) > max_size:
            small = resize_long_side(image, max_size)
            if min(small.shape[:2]) < MIN_SIZE:  # refused by the caller
                return name, small, image.shape[:2]
            warnings.warn(ImageWarning(f"{name}: downsized from {image.shape[1]}x{image.shape[0]} to "
                                       f"{small.shape[1]}x{small.shape[0]} pixels (max_size={max_size})"),
                          stacklevel=3)
            return name, small, image.shape[:2]
        return name, image, image.shape[:2]
    image = read_image(photo, max_size=max_size)
    if max(image.shape[:2]) < max_size:  # not downsized
        return str(photo), image, image.shape[:2]
    size = (info["width"], info["height"]) if info["orientation"] in (5, 6, 7, 8) else (info["height"], info["width"])
    return str(photo), image, size


def read_streamed(photo, info: dict, max_size: int, upsampling: Upsampling) -> Optional[tuple]:
    """For a photo file (header facts ``info``) on the guided path read as it is (no downsizing, EXIF orientation 1):
    ``(block means, luminance, input size)`` of the guided path of
    :func:`~svbrdf.runtime.inference.pipeline.estimate`, read strip by strip (:func:`read_strips`; the same values
    as from the whole photo, the greyscale warning included); otherwise None (:func:`read_photo` reads it)."""
    if upsampling.network_size is None:
        return None
    h, w = info["height"], info["width"]
    if info["orientation"] != 1 or max(h, w) > max_size or min(h, w) < MIN_SIZE or not upsampling.applies((h, w)):
        return None
    k = upsampling.factor((h, w))
    small = np.empty((-(-h // k), -(-w // k), 3), np.float32)
    guide = np.empty((h, w), np.float32)
    grey = True
    for y0, strip in read_strips(photo, k * max(1, READ_STRIP_BYTES // (k * w * 12))):
        small[y0 // k:y0 // k + -(-strip.shape[0] // k)] = block_mean(strip, k, partial=True)
        guide[y0:y0 + strip.shape[0]] = luminance(strip)
        grey = grey and not any(float(np.abs(strip[..., c] - strip[..., 1]).max()) > GREY_TOLERANCE for c in (0, 2))
    if grey:
        _greyscale_warning(str(photo))
    return small, guide, (h, w)
