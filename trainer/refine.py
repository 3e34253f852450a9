"""``svbrdf-preview --refine``: the preview corrected where one flash photo tells, kept where it does not.

* **free parameters**: one shift of the specular and one of the roughness map in logit space,
  ``sigmoid(logit(s) + dS)``, ``sigmoid(logit(r) + dR)``, pulled toward zero (the preview) by
  :data:`PRIOR_WEIGHT`; base colour and normals are the preview's;
* **the fit** (:mod:`svbrdf.trainer.fit`, shared with ``--capture``): one view, camera and flash above the photo's
  centre at the height of ``render_config.fov_deg`` (inverse-square fall-off, closed-form exposure, clipped pixels
  out), on the photo's block means at most :data:`FIT_SIDE` px long;
* **never worse**, by cross-validation on the photo itself: its :data:`HOLDOUT_BLOCK`-px blocks are dealt into
  :data:`FOLDS` folds (a fixed draw, :func:`holdout_folds`); each fold is held out of one fit and judged on. The
  result is the preview unless the fit's re-render error on the held-out fold is below the preview's times
  ``1 - MARGIN`` on **every** fold (both exposed over that fit's pixels; the folds are judged in turn and the first
  one the fit does not win ends the test, so a kept preview costs fewer fits). Then the two shifts are fitted once more
  on all the photo's pixels (from the folds' mean, pulled toward the preview as before), and kept if their burn-in
  is at most the preview's plus :data:`BURN_GUARD`; they are applied to the preview at the photo's size.

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
#: Adam steps of each fit (``--iters``; :data:`FOLDS` held-out fits, then one on all pixels), their learning rate
#: (logit units) and the weight of the pull toward the preview (mean squared shift).
ITERS = 25
LR = 0.05
PRIOR_WEIGHT = 0.05
#: The fit runs on block means of the photo at most this long (pixels).
FIT_SIDE = 256
#: The held-out test: blocks of this side (pixels of the fit), dealt into this many folds (a fixed draw).
HOLDOUT_BLOCK = 16
FOLDS = 4
#: The fit is kept when its held-out error is below the preview's times (1 - MARGIN) on every fold ...
MARGIN = 0.01
#: ... and its burn-in (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in`) at most the preview's plus this.
BURN_GUARD = 0.0
#: ``quality="auto"``: each fit stops when its error has not improved by 1e-4 (relative) for this many steps (about
#: half the steps and time of ``"fixed"``, the same figures within 1e-4: decision 050).
PATIENCE = 5

#: ``callback(step, total, error)``: after each step of every fit (``step`` counted over all of them, ``total`` =
#: ``(FOLDS + 1) * iters``); ``error`` the sRGB RMSE on that fit's pixels.
Callback = Callable[[int, int, float], None]

__all__ = ["refine", "holdout_folds", "shifted", "QUALITIES", "ITERS", "LR", "PRIOR_WEIGHT", "FIT_SIDE",
           "HOLDOUT_BLOCK", "FOLDS", "MARGIN", "BURN_GUARD", "PATIENCE"]


def holdout_folds(height: int, width: int, block: int = HOLDOUT_BLOCK, folds: int = FOLDS,
                  seed: int = 0) -> np.ndarray:
    """(H, W) int fold of every pixel, 0 to ``folds - 1``: the ``block``-px blocks dealt into ``folds`` folds whose
    block counts differ by at most one (a fixed draw by ``seed``; with fewer blocks than folds, some are empty)."""
    by, bx = -(-height // block), -(-width // block)
    n = by * bx
    fold = np.empty(n, np.int64)
    fold[np.random.default_rng(seed).permutation(n)] = np.arange(n) % folds
    return fold.reshape(by, bx).repeat(block, 0).repeat(block, 1)[:height, :width]


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
        quality: ``"fixed"``: ``iters`` steps a fit; ``"auto"``: at most ``iters``, each fit stopping when its
            error has stopped improving (:data:`PATIENCE`).
        iters: Adam steps of each of the ``FOLDS + 1`` fits (default :data:`ITERS`).
        threads: torch CPU threads (default: torch's).
        callback: :data:`Callback`.

    Returns:
        The refined :class:`Maps` (H, W, the preview's meta), or ``preview`` itself; either way with
        ``meta["refine"]`` = ``{"kept": "refined" | "preview", "reason" (why the preview was kept: "held-out
        error" or "burn-in"; None), "heldout_rmse_preview", "heldout_rmse_refined" (sRGB RMSE over the judged
        folds' held-out blocks, each judged by the fit that did not see it), "fold_ratios" (refined / preview per
        fold judged, in order: the first fold the fit does not win is the last judged), "folds_won", "folds" (how
        many were judged; folds without unclipped pixels are not), "margin", "burn_guard",
        "burn_in_preview", "burn_in_refined" (None without the final fit), "iterations" (steps of all fits),
        "stopped_early", "fit_rmse" (the final fit's; None without it), "seconds", "fit_size", "shifts" (the final
        fit's, logit units; None without it)}`` and ``meta["burn_in"]``
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
    folds = to_tensor(holdout_folds(*small_photo.shape[:2])[..., None].astype(np.float32))
    total, done, early = (FOLDS + 1) * iters, 0, False

    def fit(shifts, mask, start=None):
        nonlocal done, early
        offset = done
        steps, loss = adam_fit(shifts, lambda: view_rmse(shifted(small, shifts), view, mask), iters=iters, lr=LR,
                               prior_weight=PRIOR_WEIGHT, start=start,
                               patience=PATIENCE if quality == "auto" else None,
                               callback=(lambda step, err: callback(offset + step, total, err)) if callback else None)
        done, early = done + steps, early or steps < iters
        return loss

    # Cross-validation: each fold held out of one fit and judged on, in turn, until one the fit does not win;
    # squared errors pooled over the folds judged.
    ratios, sums, fold_shifts = [], np.zeros(3), []
    for f in range(FOLDS):
        held = (folds == f).float()
        n = float((view.ok * held).sum())
        if not n:  # nothing unclipped to judge on
            continue
        shifts = [torch.zeros(()), torch.zeros(())]
        fit(shifts, 1.0 - held)
        with torch.no_grad():
            err_p = float(view_rmse(small, view, held, exposure_mask=1.0 - held))
            err_r = float(view_rmse(shifted(small, shifts), view, held, exposure_mask=1.0 - held))
        ratios.append(err_r / max(err_p, 1e-12))
        sums += (n * err_p ** 2, n * err_r ** 2, n)
        fold_shifts.append([float(t.detach()) for t in shifts])
        if not ratios[-1] < 1.0 - MARGIN:  # the preview is kept whatever the other folds say: not fitted
            break
    err_preview, err_refined = (float(np.sqrt(x / max(sums[2], 1.0))) for x in sums[:2])
    won = sum(r < 1.0 - MARGIN for r in ratios)
    before = preview.meta.get("burn_in") or photo_burn_in(preview, photo)
    record = {"kept": "preview", "reason": "held-out error", "heldout_rmse_preview": err_preview,
              "heldout_rmse_refined": err_refined, "fold_ratios": [round(r, 4) for r in ratios],
              "folds_won": won, "folds": len(ratios), "margin": MARGIN, "burn_guard": BURN_GUARD,
              "burn_in_preview": float(before["burn_in"]), "burn_in_refined": None, "iterations": None,
              "stopped_early": None, "fit_rmse": None, "fit_size": list(small_photo.shape[:2]), "shifts": None}
    out = preview
    if ratios and won == len(ratios):  # every fold says the fit helps: the shifts from all pixels
        shifts = [torch.tensor(float(np.mean(v))) for v in zip(*fold_shifts)]
        record["fit_rmse"] = fit(shifts, None, start=[torch.zeros(()), torch.zeros(())])
        with torch.no_grad():
            out = Maps.unpack(shifted(to_tensor(full.pack()), shifts)[0].permute(1, 2, 0).numpy(),
                              meta=dict(preview.meta))
        out.meta["burn_in"] = photo_burn_in(out, photo)
        ds, dr = (float(t.detach()) for t in shifts)
        record.update(kept="refined", reason=None, burn_in_refined=float(out.meta["burn_in"]["burn_in"]),
                      shifts={"specular_logit": round(ds, 4), "roughness_logit": round(dr, 4)})
        if record["burn_in_refined"] > record["burn_in_preview"] + BURN_GUARD:
            record["kept"], record["reason"], out = "preview", "burn-in", preview
    record["iterations"], record["stopped_early"] = done, early
    out.meta.setdefault("burn_in", before)
    record["seconds"] = time.perf_counter() - t0
    out.meta["refine"] = record
    return out
