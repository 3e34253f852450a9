"""Does the instant preview already explain the photo? The rule that lets ``--quality auto`` skip the fine-tune.

Two label-free tests, both on the preview's maps (numpy only):

* its sRGB re-render error under the input flash (:func:`svbrdf.runtime.core.render.rerender_rmse` against the photo)
  is at or below :data:`SKIP_REFINE_RMSE`;
* its highlight burn-in (:mod:`svbrdf.runtime.quality.burn_in`) is at or below :data:`SKIP_REFINE_BURN_IN`: the burn-in of
  the network's maps (``meta["burn_in_model"]``), before the runtime removed their flash trend
  (:mod:`svbrdf.runtime.post.flash_trend`), so a model that baked the highlight in still gets its fine-tune.

The runtime's ``--help`` quotes the thresholds, the trainer's :func:`svbrdf.trainer.refine.refine` applies the rule
and the benchmark report measures what it saves; all three read them here.
"""

from __future__ import annotations

from typing import Any, Dict

import numpy as np

from ..core.maps import Maps
from ..core.render import RenderConfig, rerender_rmse

# The fine-tune is skipped when the preview's sRGB RMSE under the input flash is already at or below this: the
# mean that 200 fast fine-tune iterations reach on the 12 Henzler photos.
SKIP_REFINE_RMSE = 0.117
# ... and only when the preview's label-free burn-in (svbrdf.runtime.quality.burn_in, the worst map's disc or ring score) is
# at or below this: about the 95th percentile of stationary ground-truth maps' own burn-in.
# Decision: docs/decisions/014-skip-refine.md.
SKIP_REFINE_BURN_IN = 0.5


def check_preview(preview: Maps, photo: np.ndarray, config: RenderConfig) -> Dict[str, Any]:
    """Apply the skip rule to a preview of ``photo``.

    Args:
        preview: the preview's maps of the whole photo, as :func:`svbrdf.runtime.inference.pipeline.estimate` returns them
            (all four maps; ``meta["burn_in"]`` set, and ``meta["burn_in_model"]``, which is read first).
        photo: (H, W, 3) linear RGB float32, the photo the preview was computed from.
        config: renderer settings of the re-render (the model's, with the user's field of view).

    Returns:
        ``{"skipped": bool, "preview_input_rmse", "threshold", "preview_burn_in", "burn_in_threshold"}`` (the
        ``meta["refine"]`` record of a skipped fine-tune).
    """
    rmse = rerender_rmse(preview, photo, [None], config)
    burn = preview.meta.get("burn_in_model", preview.meta["burn_in"])["burn_in"]
    return {"skipped": bool(rmse <= SKIP_REFINE_RMSE and burn <= SKIP_REFINE_BURN_IN), "preview_input_rmse": rmse,
            "threshold": SKIP_REFINE_RMSE, "preview_burn_in": burn, "burn_in_threshold": SKIP_REFINE_BURN_IN}


__all__ = ["SKIP_REFINE_RMSE", "SKIP_REFINE_BURN_IN", "check_preview"]
