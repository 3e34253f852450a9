"""The preview's base colour with the photo's colour balance (pure numpy): the generator's instance normalisation
hides a photo's overall colour from it, and the learned stage one predicts a nearly grey base colour for every
material (docs/benchmarks/prior/README.md, "Colour")."""

from __future__ import annotations

import math

import numpy as np

from ..core.filters import block_mean

__all__ = ["photo_colour", "COLOUR_MAX_SIDE", "COLOUR_QUANTILE"]


#: :func:`photo_colour` takes its mean colours from a block-mean copy no longer than this (they are global statistics;
#: at 1024 px the full-size quantile alone cost 0.1 s).
COLOUR_MAX_SIDE = 256
#: Pixels whose luminance is above this quantile of the photo's are left out of :func:`photo_colour` (the flash
#: highlight is the light's colour, not the material's).
COLOUR_QUANTILE = 0.9


def photo_colour(diffuse: np.ndarray, photo: np.ndarray) -> np.ndarray:
    """The diffuse albedo with its mean colour balance set to the photo's, luminance kept.

    Over the photo's pixels that are not clipped and not in its brightest ``1 - COLOUR_QUANTILE`` (the
    highlight; pixels of a block-mean copy no longer than :data:`COLOUR_MAX_SIDE`), the per-channel gains
    ``g_c = (p_c / mean(p)) / (d_c / mean(d))`` (p, d: mean photo and diffuse colour there, linear) multiply the
    diffuse; a grey photo keeps a grey base colour, a base colour already balanced like the photo is unchanged.

    Args:
        diffuse: (H, W, 3) linear diffuse albedo in [0, 1].
        photo: (H, W, 3) linear photo the maps were estimated from, same size.

    Returns:
        (H, W, 3) float32 linear diffuse in [0, 1].
    """
    k = max(1, math.ceil(max(photo.shape[:2]) / COLOUR_MAX_SIDE))  # the statistics of a block-mean copy
    small_photo, small_diffuse = block_mean(photo, k), block_mean(diffuse, k)
    lum = small_photo.mean(axis=-1)
    keep = (small_photo.max(axis=-1) < 0.98) & (lum <= np.quantile(lum, COLOUR_QUANTILE)) & (lum > 1e-4)
    if keep.sum() < 64:
        return diffuse
    p = small_photo[keep].mean(axis=0).astype(np.float64)
    d = small_diffuse[keep].mean(axis=0).astype(np.float64)
    if p.min() <= 1e-6 or d.min() <= 1e-6:
        return diffuse
    gains = (p / p.mean()) / (d / d.mean())
    return np.clip(diffuse * gains.astype(np.float32), 0.0, 1.0)
