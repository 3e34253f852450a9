"""The preview's base colour with the photo's colour balance (pure numpy): the generator's instance normalisation
hides a photo's overall colour from it, and the learned stage one predicts a nearly grey base colour for every
material (docs/decisions/008-photo-colour.md). Its casts are local too (a green or blue disc under the
flash, a greyed side): :func:`local_colour` takes out those the photo does not show, at a coarse scale
(:mod:`svbrdf.runtime.quality.colour_check` measures what is left); the flash-trend removal runs it
(:func:`svbrdf.runtime.post.flash_trend.remove_flash_trend`, after the highlight fill)."""

from __future__ import annotations

import math

import numpy as np

from ..core.filters import block_mean, box_mean

__all__ = ["photo_colour", "local_colour", "COLOUR_MAX_SIDE", "COLOUR_QUANTILE", "LOCAL_SIGMA", "LOCAL_GAIN_MAX",
           "LOCAL_MAX_SIDE", "LOCAL_TOLERANCE", "HIGHLIGHT_MAX_SIDE"]


#: :func:`photo_colour` takes its mean colours from a block-mean copy no longer than this (they are global statistics).
COLOUR_MAX_SIDE = 256
#: Pixels whose luminance is above this quantile of the photo's are left out of :func:`photo_colour` (the flash
#: highlight is the light's colour, not the material's).
COLOUR_QUANTILE = 0.9
#: The scale of :func:`local_colour`: the standard deviation of its low pass, a fraction of the width
#: (008-photo-colour.md).
LOCAL_SIGMA = 0.125
#: The largest factor (and 1 / the smallest) :func:`local_colour` gives a channel.
LOCAL_GAIN_MAX = 2.0
#: :func:`local_colour` works on block means no longer than this, interpolated bilinearly to full size.
LOCAL_MAX_SIDE = 64
#: :func:`local_colour` leaves the diffuse as it is when no channel's factor differs from 1 by more than this.
LOCAL_TOLERANCE = 1e-3
#: :func:`local_colour` finds the highlight's region on a block-mean copy of the photo no longer than this.
HIGHLIGHT_MAX_SIDE = 256


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


def local_colour(diffuse: np.ndarray, photo: np.ndarray, sigma: float = LOCAL_SIGMA) -> np.ndarray:
    """The diffuse albedo with the photo's colours at a coarse scale, each pixel's luminance kept.

    On block means no longer than :data:`LOCAL_MAX_SIDE` (both over the pixels where the photo is not clipped nor
    in the flash highlight and its shoulder, :func:`~svbrdf.runtime.post.highlight_fill.highlight_mask` of a copy no
    longer than :data:`HIGHLIGHT_MAX_SIDE`, and the diffuse is below 1), over the blocks where the photo tells the colour (as
    :func:`svbrdf.runtime.quality.colour_check.chroma_distance` keeps them: not clipped, not too dark), the
    chromaticities ``x_c / mean(x)`` of the photo and of the diffuse are low-passed (a normalised Gaussian of
    ``sigma`` x the width: three box blurs of the kept blocks' values over three of the kept mask); each channel is
    multiplied by their ratio, photo over diffuse, clipped to ``[1 / LOCAL_GAIN_MAX, LOCAL_GAIN_MAX]`` and eased
    towards 1 where less than a quarter of the low pass's weight falls on kept blocks (a large clipped highlight,
    black surroundings), interpolated bilinearly to full size; then each pixel is scaled back to its luminance
    (channel mean), and a pixel above 1 is scaled down as a whole. The texture's colours finer than ``sigma`` are
    kept; a base colour whose coarse colours are already the photo's (every factor within :data:`LOCAL_TOLERANCE`
    of 1) is returned as it is. The overall balance moves with the casts: it becomes the photo's over the blocks
    that tell the colour (:func:`photo_colour` weighs the photo's brighter pixels more).

    Args:
        diffuse: (H, W, 3) linear diffuse albedo in [0, 1].
        photo: (H, W, 3) linear photo, same size.
        sigma: the low pass's standard deviation, a fraction of the width, > 0.

    Returns:
        (H, W, 3) float32 linear diffuse in [0, 1]; ``diffuse`` as float32 when fewer than 16 blocks tell the colour.
    """
    from ..quality.colour_check import CLIP_LEVEL, CLIP_SHARE, DARK_FRACTION
    from .flash_trend import _interp_matrix
    from .highlight_fill import highlight_mask

    diffuse = np.asarray(diffuse, np.float32)
    photo = np.asarray(photo, np.float32)
    h, w = photo.shape[:2]
    k = max(1, math.ceil(max(h, w) / LOCAL_MAX_SIDE))
    # Both block means over the same pixels: the photo not clipped and outside the highlight and its shoulder (the
    # light's colour, not the material's), the diffuse below 1 in every channel.
    photo_ok = _channel_max(photo) < CLIP_LEVEL
    j = max(1, math.ceil(max(h, w) / HIGHLIGHT_MAX_SIDE))  # the highlight's region from a block-mean copy
    region = highlight_mask(block_mean(photo, j, partial=True))
    region = np.repeat(np.repeat(region, j, axis=0), j, axis=1)[:h, :w, None]
    both = (photo_ok & ~region & (_channel_max(diffuse) < 1)).astype(np.float32)
    p = block_mean(photo * both, k, partial=True).astype(np.float64)
    d = block_mean(diffuse * both, k, partial=True).astype(np.float64)
    share = block_mean(np.concatenate([photo_ok.astype(np.float32), both], axis=-1), k, partial=True)
    lp, ld = p.mean(axis=-1, keepdims=True), d.mean(axis=-1, keepdims=True)
    lum = lp / np.maximum(share[..., 1:], 1e-6)  # the photo's mean luminance over those pixels
    kept = ((share[..., :1] >= 1 - CLIP_SHARE) & (share[..., 1:] > 0.5) & (ld > 1e-4)
            & (lum >= max(DARK_FRACTION * float(np.median(lum)), 1e-4)))
    if kept.sum() < 16:
        return diffuse
    s = sigma * w / k  # in blocks; three boxes of radius r have the variance r (r + 1)
    r = max(1, int(round((math.sqrt(1 + 4 * s * s) - 1) / 2)))
    weight = kept.astype(np.float64)
    stack = np.concatenate([p / np.maximum(lp, 1e-6), d / np.maximum(ld, 1e-6), np.ones_like(lp)], axis=-1) * weight
    for _ in range(3):
        stack = box_mean(stack, r)
    support = stack[..., 6:]
    ratio = stack[..., :3] / np.maximum(stack[..., 3:6], 1e-9)  # the photo's low-passed chromaticity over the diffuse's
    ratio = 1 + np.clip(support / 0.25, 0, 1) * (ratio - 1)
    np.clip(ratio, 1 / LOCAL_GAIN_MAX, LOCAL_GAIN_MAX, out=ratio)
    if float(np.abs(ratio - 1).max()) < LOCAL_TOLERANCE:
        return diffuse
    rows, cols = _interp_matrix(h, ratio.shape[0], k), _interp_matrix(w, ratio.shape[1], k)
    gain = np.stack([(rows @ ratio[..., c] @ cols.T).astype(np.float32) for c in range(3)], axis=-1)
    out = diffuse * gain
    before, after = _channel_sum(diffuse), _channel_sum(out)
    out *= np.where(after > 0, before / np.maximum(after, np.float32(1e-12)), np.float32(1))
    np.divide(out, np.maximum(_channel_max(out), np.float32(1)), out=out)
    return np.clip(out, 0, 1, out=out)


def _channel_max(a: np.ndarray) -> np.ndarray:
    """(H, W, 1) the largest of the three channels (3x faster than ``max(axis=-1)``, a strided reduction)."""
    return np.maximum(np.maximum(a[..., 0:1], a[..., 1:2]), a[..., 2:3])


def _channel_sum(a: np.ndarray) -> np.ndarray:
    """(H, W, 1) the sum of the three channels."""
    return a[..., 0:1] + a[..., 1:2] + a[..., 2:3]
