"""Several calibrated flash photos of one material fitted together: ``svbrdf-preview --capture DIR``.

A multi-view flash capture in the published layout of Guo et al.'s captures (``bath_tile/``: views ``NN.png``
rectified to the material's plane, ``parameters.json`` or ``optim.json`` with each view's camera and light
position; :func:`svbrdf.trainer.bench.datasets.read_capture_calibration`) gives one texture set in the plane's frame:

1. **the prior**: the preview of every view (the stage one's maps, each view's own guess), averaged (normals
   renormalised): a view's burn-in and guesses differ from the others', the average keeps what they agree on;
2. **the fit**: per-pixel maps (base colour, specular, roughness through a logistic; the normal through its two
   slopes) start at the prior and follow Adam on the mean over the views of the sRGB RMSE between each photo and
   the maps rendered with that view's camera and flash (inverse-square fall-off; one exposure per view, fitted in
   closed form as the bench does, :func:`svbrdf.trainer.bench.metrics.relight_view`; clipped pixels left out),
   plus :data:`PRIOR_WEIGHT` times the mean squared distance of the parameters from the prior's: where the views
   say nothing (no highlight ever crossed a place), the maps stay the prior's. The physics, the parameterisation
   and the loop are :mod:`svbrdf.trainer.fit`, shared with ``--refine``.

A fit without the prior overfits (issue 68 reports per-pixel maps fitted to 8 of bath_tile's views reproducing them
at 0.052 and relighting the ninth at 0.186). The figures of this fit, each view left out in turn:
``docs/results/capture.md`` (``docs/results/capture.py``).
"""

from __future__ import annotations

import math
import time
from typing import Callable, Dict, Optional

import numpy as np
import torch

from svbrdf.runtime.core.maps import Maps, normalize_normals
from svbrdf.runtime.core.render import ZHAO, RenderConfig
from svbrdf.trainer.bench.datasets import capture_view_file as view_file  # noqa: F401  (the views' files)
from svbrdf.trainer.bench.datasets import read_capture_calibration as read_calibration  # noqa: F401
from svbrdf.trainer.fit import CLIP, adam_fit, make_view, pixel_maps, pixel_params, to_maps, view_rmse

#: Adam steps of the fit and its learning rate (in the parameters' logit and slope units).
ITERS = 200
LR = 0.02
#: Weight of the pull toward the prior (mean squared parameter distance).
PRIOR_WEIGHT = 0.3

__all__ = ["CLIP", "ITERS", "LR", "PRIOR_WEIGHT", "average_maps", "fit_capture", "capture_fov", "read_calibration",
           "view_file"]


def average_maps(maps: list) -> Maps:
    """The mean of several :class:`Maps` of one size (all four maps), normals renormalised."""
    mean = Maps.unpack(np.mean([m.pack() for m in maps], axis=0))
    mean.normal = normalize_normals(mean.normal)
    return mean


def capture_fov(calibration) -> float:
    """The field of view (degrees) of the capture's mean camera height over its photographed width."""
    heights = [cam[2] for cam, _ in calibration.views.values()]
    return 2.0 * math.degrees(math.atan(calibration.width_cm / 2.0 / float(np.mean(heights))))


def fit_capture(photos: Dict[int, np.ndarray], calibration, prior: Maps, *, iters: int = ITERS, lr: float = LR,
                prior_weight: float = PRIOR_WEIGHT, config: RenderConfig = ZHAO, threads: Optional[int] = None,
                callback: Optional[Callable[[int, float], None]] = None) -> Maps:
    """Fit one texture set to the views of a capture (module docstring).

    Args:
        photos: view index -> (S, S, 3) float32 linear photo (rectified to the plane; every view one size).
        calibration: :class:`svbrdf.trainer.bench.datasets.CaptureCalibration` with every view of ``photos``.
        prior: the start and the pull (:func:`average_maps` of the views' previews), (S, S).
        iters, lr, prior_weight: the fit's length, Adam's learning rate, the prior's weight.
        config: renderer settings (fall-off is switched on).
        threads: torch CPU threads (default: torch's).
        callback: ``callback(step, loss)`` after each step.

    Returns:
        :class:`Maps` (S, S) with ``meta["capture"]``: ``views``, ``iterations``, ``loss`` (the last photo term),
        ``seconds``.
    """
    if threads:
        torch.set_num_threads(int(threads))
    size = prior.shape
    if any(p.shape[:2] != size for p in photos.values()):
        raise ValueError(f"every view must be {size[1]}x{size[0]} px like the prior")
    params = pixel_params(prior)
    views = [make_view(photo, config, *calibration.scene_units(i)) for i, photo in sorted(photos.items())]

    def objective() -> torch.Tensor:
        maps = pixel_maps(params)
        return sum(view_rmse(maps, view) for view in views) / len(views)

    t0 = time.perf_counter()
    _, photo_loss = adam_fit(params, objective, iters=iters, lr=lr, prior_weight=prior_weight, callback=callback)
    with torch.no_grad():
        out = pixel_maps(params)
    return to_maps(out, meta={"capture": {"views": sorted(photos), "iterations": iters, "loss": photo_loss,
                                          "prior_weight": prior_weight, "seconds": time.perf_counter() - t0}})
