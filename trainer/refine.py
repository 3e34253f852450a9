"""``svbrdf-preview --refine``: the preview corrected where one flash photo tells, kept where it does not.

* **free parameters**: one shift of the specular and one of the roughness map in logit space,
  ``sigmoid(logit(s) + dS)``, ``sigmoid(logit(r) + dR)``, pulled toward zero (the preview) by
  :data:`PRIOR_WEIGHT`; base colour and normals are the preview's;
* **the fit** (:mod:`svbrdf.trainer.fit`, shared with ``--capture``): one view, camera and flash above the photo's
  centre at the height of ``render_config.fov_deg`` (inverse-square fall-off, closed-form exposure, clipped pixels
  out), on the photo's block means at most :data:`FIT_SIDE` px long;
* **never worse**: a fixed :data:`HOLDOUT_SHARE` of the photo's :data:`HOLDOUT_BLOCK`-px blocks is held out of the
  fit; the result is the preview unless the fit's re-render error on them is below the preview's times
  ``1 - MARGIN`` (both exposed over the fitted pixels) and its burn-in is at most the preview's plus
  :data:`BURN_GUARD`. When the fit wins, the maps are its two shifts applied to the preview at the photo's size
  (no refit on all pixels).

Decision: docs/decisions/050-refine.md
"""

from __future__ import annotations

import math
import time
from typing import Callable, Optional

import numpy as np
import torch

from svbrdf.runtime.core.filters import block_mean
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import RenderConfig
from svbrdf.runtime.quality.burn_in import photo_burn_in
from svbrdf.trainer.fit import CLIP, adam_fit, logit, make_view, to_tensor, view_rmse

QUALITIES = ("fixed", "auto")
#: Adam steps of the fit (``--iters``), its learning rate (logit units) and the weight of the pull toward the
#: preview (mean squared shift).
ITERS = 100
LR = 0.05
PRIOR_WEIGHT = 0.05
#: The fit runs on block means of the photo at most this long (pixels).
FIT_SIDE = 256
#: The held-out test: blocks of this side (pixels of the fit), this share of them held out (a fixed draw).
HOLDOUT_BLOCK = 16
HOLDOUT_SHARE = 0.25
#: The fit is kept when its held-out error is below the preview's times (1 - MARGIN) ...
MARGIN = 0.01
#: ... and its burn-in (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in`) at most the preview's plus this.
BURN_GUARD = 0.0
#: ``quality="auto"``: stop when the fitted error has not improved by 1e-4 (relative) for this many steps.
PATIENCE = 15

#: ``callback(step, iters, error)``: after each step; ``error`` the sRGB RMSE on the fitted pixels.
Callback = Callable[[int, int, float], None]

__all__ = ["refine", "holdout_mask", "shifted", "QUALITIES", "ITERS", "LR", "PRIOR_WEIGHT", "FIT_SIDE",
           "HOLDOUT_BLOCK", "HOLDOUT_SHARE", "MARGIN", "BURN_GUARD", "PATIENCE"]


def holdout_mask(height: int, width: int, block: int = HOLDOUT_BLOCK, share: float = HOLDOUT_SHARE,
                 seed: int = 0) -> np.ndarray:
    """(H, W) bool, True on the held-out pixels: ``share`` of the ``block``-px blocks (at least one), a fixed draw
    by ``seed``."""
    by, bx = -(-height // block), -(-width // block)
    n = by * bx
    held = np.zeros(n, bool)
    held[np.random.default_rng(seed).permutation(n)[:max(1, int(round(share * n)))]] = True
    return held.reshape(by, bx).repeat(block, 0).repeat(block, 1)[:height, :width]


def shifted(packed: torch.Tensor, shifts) -> torch.Tensor:
    """Packed maps (1, 8, H, W) with ``shifts = (dS, dR)`` (scalar tensors, logit units) added to the specular and
    roughness logits; the base colour and the normals unchanged."""
    ds, dr = shifts
    s = torch.sigmoid(logit(packed[:, 3:4]) + ds)
    r = torch.sigmoid(logit(packed[:, 4:5]) + dr)
    return torch.cat([packed[:, 0:3], s, r, packed[:, 5:8]], 1)


def refine(photo: np.ndarray, preview: Maps, render_config: RenderConfig, *, quality: str = "fixed",
           iters: Optional[int] = None, threads: Optional[int] = None, callback: Optional[Callback] = None) -> Maps:
    """Refine ``preview`` on ``photo`` (module docstring), or keep it when the photo's own test says so.

    Args:
        photo: (H, W, 3) linear RGB float photo.
        preview: the preview's four maps of ``photo`` (H, W) (:func:`svbrdf.runtime.inference.pipeline.estimate`).
        render_config: the photo's renderer settings: its field of view gives the camera's height; fall-off is on.
        quality: ``"fixed"``: ``iters`` steps; ``"auto"``: at most ``iters``, stopping when the fitted error has
            stopped improving (:data:`PATIENCE`).
        iters: Adam steps (default :data:`ITERS`).
        threads: torch CPU threads (default: torch's).
        callback: :data:`Callback`.

    Returns:
        The refined :class:`Maps` (H, W, the preview's meta), or ``preview`` itself; either way with
        ``meta["refine"]`` = ``{"kept": "refined" | "preview", "reason" (why the preview was kept: "held-out
        error" or "burn-in"; None), "heldout_rmse_preview", "heldout_rmse_refined" (sRGB RMSE on the held-out
        blocks), "margin", "burn_guard", "burn_in_preview", "burn_in_refined", "iterations",
        "stopped_early", "fit_rmse", "seconds", "fit_size", "heldout_share", "shifts"}`` and ``meta["burn_in"]``
        (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in` of the maps returned).

    Raises:
        ValueError: unknown ``quality``, ``iters`` < 1, a preview without all four maps or of another size.
    """
    if quality not in QUALITIES:
        raise ValueError(f"unknown quality {quality!r}; expected one of {', '.join(QUALITIES)}")
    iters = ITERS if iters is None else int(iters)
    if iters < 1:
        raise ValueError(f"iters must be >= 1, got {iters}")
    preview.require(what="--refine")
    photo = np.asarray(photo, np.float32)
    if photo.shape[:2] != preview.shape:
        raise ValueError(f"the preview is {preview.shape[1]}x{preview.shape[0]} px, the photo "
                         f"{photo.shape[1]}x{photo.shape[0]}")
    if threads:
        torch.set_num_threads(int(threads))
    t0 = time.perf_counter()
    h, w = preview.shape
    k = max(1, math.ceil(max(h, w) / FIT_SIDE))
    small_photo = block_mean(photo, k, partial=True)
    if k > 1:  # a block with a clipped pixel is left out
        clipped = block_mean((photo.max(-1, keepdims=True) >= CLIP).astype(np.float32), k, partial=True) > 0
        small_photo = np.where(clipped, 1.0, small_photo).astype(np.float32)
    full = preview.clipped()
    small = to_tensor(full.pack() if k == 1 else block_mean(full.pack(), k, partial=True))
    small = torch.cat([small[:, :5], small[:, 5:8] / small[:, 5:8].norm(dim=1, keepdim=True)], 1)
    view = make_view(small_photo, render_config)
    held = to_tensor(holdout_mask(*small_photo.shape[:2])[..., None].astype(np.float32))
    fitted = 1.0 - held
    shifts = [torch.zeros(()), torch.zeros(())]
    steps, loss = adam_fit(shifts, lambda: view_rmse(shifted(small, shifts), view, fitted), iters=iters, lr=LR,
                           prior_weight=PRIOR_WEIGHT, patience=PATIENCE if quality == "auto" else None,
                           callback=(lambda step, err: callback(step, iters, err)) if callback else None)
    with torch.no_grad():
        err_preview = float(view_rmse(small, view, held, exposure_mask=fitted))
        err_refined = float(view_rmse(shifted(small, shifts), view, held, exposure_mask=fitted))
        out = Maps.unpack(shifted(to_tensor(full.pack()), shifts)[0].permute(1, 2, 0).numpy(),
                          meta=dict(preview.meta))
    out.meta["burn_in"] = photo_burn_in(out, photo)
    before = preview.meta.get("burn_in") or photo_burn_in(preview, photo)
    ds, dr = (float(t.detach()) for t in shifts)
    record = {"kept": "refined", "reason": None, "heldout_rmse_preview": err_preview,
              "heldout_rmse_refined": err_refined, "margin": MARGIN, "burn_guard": BURN_GUARD,
              "burn_in_preview": float(before["burn_in"]), "burn_in_refined": float(out.meta["burn_in"]["burn_in"]),
              "iterations": steps,
              "stopped_early": steps < iters, "fit_rmse": loss, "fit_size": list(small_photo.shape[:2]),
              "heldout_share": HOLDOUT_SHARE,
              "shifts": {"specular_logit": round(ds, 4), "roughness_logit": round(dr, 4)}}
    if not err_refined < err_preview * (1.0 - MARGIN):
        record["kept"], record["reason"], out = "preview", "held-out error", preview
    elif record["burn_in_refined"] > record["burn_in_preview"] + BURN_GUARD:
        record["kept"], record["reason"], out = "preview", "burn-in", preview
    record["seconds"] = time.perf_counter() - t0
    out.meta["refine"] = record
    return out
