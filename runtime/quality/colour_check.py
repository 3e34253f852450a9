"""Foreign colour: how much of a base colour has a hue the photo does not show at that place (numpy, label-free).

A base colour may be brighter or darker than the photo (the flash's light and fall-off are not the material), but
its colour at a place should be the photo's there: a patch of a hue the photo does not have (a maroon blotch, teal
shadows) is an error an artist sees at once. The score compares the two at equal lightness, on a coarse grid:

1. both images, linear RGB (H, W, 3), are averaged over square blocks of ``k = max(H, W) // GRID`` pixels (texture
   and noise average out; a patch of foreign hue does not);
2. each block's mean colour is scaled to the luminance :data:`LIGHTNESS_Y` (so brightness does not count) and
   converted to CIELAB (sRGB primaries, D65 white: :func:`chroma_ab`);
3. the distance of a block is ``|ab(base) - ab(photo)|``, the a*b* distance at L* about 50 (CIELAB units: about 2
   is a just noticeable difference, 10 a clear one);
4. blocks where the photo says nothing about the material's colour are left out: more than :data:`CLIP_SHARE` of
   their pixels clipped (any channel at or above :data:`CLIP_LEVEL`) or in the caller's ``unknown`` region (the
   flash highlight and its shoulder, where the photo shows the light's colour:
   :func:`svbrdf.runtime.post.highlight_fill.highlight_mask`, which the bench passes), or a luminance below :data:`DARK_FRACTION` of the photo's median block luminance (or below ``1e-4``).

:func:`foreign_colour` reports the mean over the kept blocks (``foreign_colour``), their 99th percentile
(``foreign_colour_p99``) and the share of kept blocks above :data:`VISIBLE` (``foreign_colour_area``). A base colour
that is the photo itself scores 0, the photo divided by a smooth grey lighting (evenly lit) nearly 0; pasting a
patch of another hue raises every number, the more the larger or the further in hue the patch. Greying a saturated
base colour raises it too (the photo's chroma is the reference), so the score cannot be won by flattening the
colours.
"""

from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from ..core.filters import block_mean

__all__ = ["foreign_colour", "chroma_distance", "chroma_ab", "GRID", "CLIP_LEVEL", "CLIP_SHARE", "DARK_FRACTION",
           "VISIBLE", "LIGHTNESS_Y", "COLOUR_METRICS"]

#: Blocks along the long side of the image (at least; the block side is ``max(H, W) // GRID`` pixels).
GRID = 16
#: A photo pixel with any linear channel at or above this is clipped.
CLIP_LEVEL = 0.98
#: Blocks with a larger share of clipped photo pixels (or of pixels in the highlight's region) are left out.
CLIP_SHARE = 0.02
#: Blocks whose photo luminance is below this fraction of the median block luminance are left out (too dark).
DARK_FRACTION = 0.1
#: A block's distance above this (CIELAB a*b* units) counts as a visible foreign colour.
VISIBLE = 15.0
#: Every block colour is scaled to this linear luminance Y before the conversion (L* about 50).
LIGHTNESS_Y = 0.18
#: Keys of :func:`foreign_colour`.
COLOUR_METRICS = ("foreign_colour", "foreign_colour_p99", "foreign_colour_area")

#: Linear sRGB -> CIE XYZ (D65), rows X, Y, Z.
_RGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                        [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])
_WHITE = _RGB_TO_XYZ.sum(axis=1)  # XYZ of linear RGB (1, 1, 1), the D65 white of sRGB


def chroma_ab(rgb: np.ndarray, y: float = LIGHTNESS_Y) -> np.ndarray:
    """CIELAB a*, b* of linear sRGB colours scaled to the luminance ``y`` (their lightness ignored).

    Args:
        rgb: (..., 3) linear sRGB, >= 0.
        y: the luminance every colour is scaled to (a luminance below 1e-6 counts as 1e-6: black is neutral).

    Returns:
        (..., 2) float64 a*, b*; 0, 0 for any grey.
    """
    xyz = np.asarray(rgb, np.float64) @ _RGB_TO_XYZ.T
    xyz *= (y / np.maximum(xyz[..., 1:2], 1e-6)) / _WHITE
    e = (6.0 / 29.0) ** 3
    f = np.where(xyz > e, np.cbrt(np.maximum(xyz, e)), xyz / (3 * (6.0 / 29.0) ** 2) + 4.0 / 29.0)
    return np.stack([500.0 * (f[..., 0] - f[..., 1]), 200.0 * (f[..., 1] - f[..., 2])], axis=-1)


def chroma_distance(diffuse: np.ndarray, photo: np.ndarray, grid: int = GRID,
                    unknown: Optional[np.ndarray] = None) -> Tuple[np.ndarray, np.ndarray]:
    """The per-block distance of the module docstring and the blocks it keeps.

    Args:
        diffuse: (H, W, 3) linear base colour.
        photo: (H, W, 3) linear photo it was estimated from, same size.
        grid: blocks along the long side (the block side is ``max(1, max(H, W) // grid)`` pixels; a partial last
            block row or column is dropped).
        unknown: (H, W) bool, True where the photo does not show the material's colour (e.g. the highlight and its
            shoulder); the clipped pixels count as unknown in any case.

    Returns:
        ``(distance, kept)``: (h, w) float64 a*b* distances and the (h, w) bool mask of kept blocks.
    """
    diffuse, photo = np.asarray(diffuse, np.float32), np.asarray(photo, np.float32)
    if diffuse.shape != photo.shape or photo.ndim != 3 or photo.shape[-1] != 3:
        raise ValueError(f"need two (H, W, 3) images of one size, got {diffuse.shape} and {photo.shape}")
    k = max(1, max(photo.shape[:2]) // max(1, int(grid)))
    p, d = block_mean(photo, k).astype(np.float64), block_mean(diffuse, k).astype(np.float64)
    clipped = photo.max(axis=-1) >= CLIP_LEVEL
    unknown = clipped if unknown is None else clipped | np.asarray(unknown, bool)
    unknown = block_mean(unknown[..., None].astype(np.float32), k)[..., 0]
    lum = p @ _RGB_TO_XYZ[1]
    kept = (unknown <= CLIP_SHARE) & (lum >= max(DARK_FRACTION * float(np.median(lum)), 1e-4))
    distance = np.linalg.norm(chroma_ab(np.maximum(d, 0)) - chroma_ab(np.maximum(p, 0)), axis=-1)
    return distance, kept


def foreign_colour(diffuse: np.ndarray, photo: np.ndarray, grid: int = GRID,
                   visible: Optional[float] = None, unknown: Optional[np.ndarray] = None) -> Dict[str, float]:
    """How far the base colour's hue is from the photo's at the same place (see the module docstring).

    Args:
        diffuse: (H, W, 3) linear base colour.
        photo: (H, W, 3) linear photo it was estimated from, same size.
        grid: see :func:`chroma_distance`.
        visible: the visible distance (default :data:`VISIBLE`).
        unknown: see :func:`chroma_distance`.

    Returns:
        ``foreign_colour`` (mean distance over the kept blocks, CIELAB a*b* units), ``foreign_colour_p99`` (their
        99th percentile) and ``foreign_colour_area`` (share of kept blocks above ``visible``, in [0, 1]); NaN
        each when no block is kept.
    """
    distance, kept = chroma_distance(diffuse, photo, grid, unknown)
    v = distance[kept]
    if v.size == 0:
        return {key: float("nan") for key in COLOUR_METRICS}
    return {"foreign_colour": float(v.mean()), "foreign_colour_p99": float(np.percentile(v, 99)),
            "foreign_colour_area": float(np.mean(v > (VISIBLE if visible is None else visible)))}
