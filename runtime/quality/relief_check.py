"""Relief check: how much of a height map is a dome (or a bowl) centred on the flash (numpy, label-free).

A flat material's height (:func:`svbrdf.runtime.core.relief.height_from_normals`) looks the same everywhere; the
integral of a faint radial tilt the flash leaves in the normals does not: it is high (or low) at the highlight and
falls off with the distance to it. Two scores of one height field ``h`` around the highlight centre ``c``:

=====================  ================================================================================
key                    definition
=====================  ================================================================================
relief_radial_corr     Pearson correlation of ``h`` and the distance ``|x - c|`` over every pixel, in
                       [-1, 1]: < 0 a dome (high under the flash), > 0 a bowl, about 0 for a stationary
                       relief; 0 for a constant height
relief_radial_share    share of the variance of ``h`` within ``RELIEF_RADIUS`` (0.5 W) of ``c`` that its
                       radial profile explains (:func:`~svbrdf.runtime.quality.burn_in.radial_share`,
                       annuli of 1/64 W), in [0, 1]: a few hundredths by chance, tenths for a dome
=====================  ================================================================================

Both are computed on a block-averaged copy no longer than :data:`RELIEF_MAX_SIDE` px (the dome is broad) and do not
depend on the height's scale or offset (the written ``_height.png`` scores as the height itself). ``c`` is the
photo's :func:`~svbrdf.runtime.quality.burn_in.highlight_centre` (the image centre for synthetic cases). The
benchmark reports them for every case (:mod:`svbrdf.trainer.bench.metrics`).
"""

from __future__ import annotations

import math
from typing import Dict, Optional, Tuple

import numpy as np

from ..core.filters import block_mean
from ..core.stats import pearson
from .burn_in import RING_BINS, radial_share

#: The scores are computed on a block-averaged copy no longer than this (pixels).
RELIEF_MAX_SIDE = 256
#: Radius of :func:`relief_radial`'s radial share, as a fraction of the width.
RELIEF_RADIUS = 0.5
#: Keys returned by :func:`relief_radial`.
RELIEF_METRICS = ("relief_radial_corr", "relief_radial_share")


def relief_radial(height: np.ndarray, centre: Optional[Tuple[float, float]] = None) -> Dict[str, float]:
    """The radial scores of a height field around ``centre`` (see the module docstring).

    Args:
        height: (H, W) or (H, W, 1) height, any units and offset (e.g. the written map in [0, 1]).
        centre: (row, column) of the flash highlight in the height's pixels (pixel centres at integer + 0.5);
            default the image centre.

    Returns:
        ``{"relief_radial_corr": r in [-1, 1], "relief_radial_share": q in [0, 1]}``; both 0 for a constant
        height.
    """
    g = np.asarray(height, dtype=np.float32)
    if g.ndim == 3 and g.shape[2] == 1:
        g = g[..., 0]
    if g.ndim != 2 or g.size == 0:
        raise ValueError(f"relief_radial expects an (H, W) height, got shape {np.shape(height)}")
    h, w = g.shape
    cy, cx = (h / 2.0, w / 2.0) if centre is None else (float(centre[0]), float(centre[1]))
    k = max(1, math.ceil(max(h, w) / RELIEF_MAX_SIDE))
    if k > 1 and min(h, w) >= k:
        g, cy, cx = block_mean(g[..., None], k)[..., 0], cy / k, cx / k
    g = g.astype(np.float64)
    if not np.ptp(g) > 0:
        return {"relief_radial_corr": 0.0, "relief_radial_share": 0.0}
    r = np.hypot(np.arange(g.shape[0])[:, None] + 0.5 - cy, np.arange(g.shape[1])[None, :] + 0.5 - cx)
    corr = pearson(g, r)
    corr = 0.0 if corr is None else corr
    share = radial_share(g, (cy, cx), RING_BINS, RELIEF_RADIUS)
    return {"relief_radial_corr": float(np.clip(corr, -1.0, 1.0)), "relief_radial_share": float(share)}


__all__ = ["relief_radial", "RELIEF_METRICS", "RELIEF_MAX_SIDE", "RELIEF_RADIUS"]
