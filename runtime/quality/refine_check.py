"""Did the refine improve the preview? The label-free rule that keeps the preview's maps when it did not.

``--refine`` fine-tunes stage one on the photo; its loss is the re-render error under the input flash, which a
fine-tune can always lower by painting the photo (highlight included) into the base colour, so a lower input error
alone does not mean better maps. After the fine-tune, :func:`check_refine` compares the refined maps with the
instant preview's, using only the photo and the two texture sets (never a ground truth), and keeps the preview
when either

* the refined maps carry more of the flash: their highlight burn-in
  (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in`, the worst map's disc or ring score, centred on the photo's
  highlight) exceeds the preview's by more than :data:`KEEP_BURN_IN_MARGIN`; or
* they do not explain the photo better: their sRGB re-render error under the input flash
  (:func:`svbrdf.runtime.core.render.rerender_rmse`) is not lower than the preview's by at least
  :data:`KEEP_INPUT_GAIN`.

Both thresholds were chosen on the **tune** part of the shared data only (``docs/benchmarks/refine-check/``).
"""

from __future__ import annotations

from typing import Any, Dict, Optional

import numpy as np

from ..core.maps import Maps
from ..core.render import RenderConfig, rerender_rmse
from .burn_in import photo_burn_in

#: The preview is kept when the refined maps' burn-in exceeds the preview's by more than this (burn-in units: the
#: worst map's ``max(|b|, 3.5 q)``, chance level about 0.1-0.2 for a stationary material).
KEEP_BURN_IN_MARGIN = 0.0
#: ... or when the refined maps' input-flash sRGB RMSE is not at least this much below the preview's.
KEEP_INPUT_GAIN = 0.0


def _burn(maps: Maps, photo: np.ndarray) -> float:
    return float(photo_burn_in(maps, photo)["burn_in"])


def check_refine(preview: Maps, refined: Maps, photo: np.ndarray, config: RenderConfig,
                 burn_margin: Optional[float] = None, input_gain: Optional[float] = None) -> Dict[str, Any]:
    """Apply the keep-the-preview rule to a refine of ``photo``.

    Args:
        preview: the instant preview's maps of ``photo`` (H, W; all four maps; diffuse/specular in [0, 1] linear,
            roughness in [0, 1], unit normals), as :func:`svbrdf.runtime.inference.pipeline.estimate` returns them.
        refined: the refine's maps of the same photo, same size and maps.
        photo: (H, W, 3) linear RGB float32 in [0, 1], the photo both were computed from.
        config: renderer settings of the re-render (the model's, with the user's field of view).
        burn_margin: see :data:`KEEP_BURN_IN_MARGIN` (default: its value at call time).
        input_gain: see :data:`KEEP_INPUT_GAIN` (default: its value at call time).

    Returns:
        ``{"kept_preview": reason or None, "preview_burn_in", "refined_burn_in", "preview_input_rmse",
        "refined_input_rmse", "burn_in_margin", "input_gain"}``; ``reason`` is one line saying which test failed.
    """
    if preview.shape != refined.shape:
        raise ValueError(f"preview {preview.shape} and refined maps {refined.shape} differ in size")
    burn_margin = KEEP_BURN_IN_MARGIN if burn_margin is None else float(burn_margin)
    input_gain = KEEP_INPUT_GAIN if input_gain is None else float(input_gain)
    pb, rb = _burn(preview, photo), _burn(refined, photo)
    pe = rerender_rmse(preview, photo, [None], config)
    re = rerender_rmse(refined, photo, [None], config)
    reason: Optional[str] = None
    if rb > pb + burn_margin:
        reason = f"the refine raised the burn-in ({pb:.2f} -> {rb:.2f})"
    elif re > pe - input_gain:
        reason = f"the refine did not lower the input re-render error enough ({pe:.3f} -> {re:.3f})"
    return {"kept_preview": reason, "preview_burn_in": pb, "refined_burn_in": rb, "preview_input_rmse": pe,
            "refined_input_rmse": re, "burn_in_margin": burn_margin, "input_gain": input_gain}


__all__ = ["KEEP_BURN_IN_MARGIN", "KEEP_INPUT_GAIN", "check_refine"]
