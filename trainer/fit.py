"""The fit of maps to flash photos with known camera and flash, shared by ``--capture``
(:func:`svbrdf.trainer.capture.fit_capture`, several calibrated views) and ``--refine``
(:func:`svbrdf.trainer.refine.refine`, one photo, its camera above its centre).

One physics for both: a view is rendered by the project renderer (:class:`svbrdf.trainer.render.FlashGeometry`,
the one formula of :func:`svbrdf.runtime.core.render.shade`) with the view's camera and point light and
inverse-square fall-off; its exposure is one scale fitted in closed form over the view's pixels in use
(``k = sum(r p) / sum(r r)``, as the bench's :func:`svbrdf.trainer.bench.metrics.relight_view`); the error is the
sRGB RMSE of the exposed, clipped render against the photo over the pixels in use (clipped photo pixels, any
channel at or above :data:`CLIP` linear, are never in use). The parameters follow Adam on the photo error plus a
weight times their mean squared distance from their start (the pull toward the prior, :func:`adam_fit`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence

import numpy as np
import torch

from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import RenderConfig
from svbrdf.trainer.colour import linear_to_srgb as srgb
from svbrdf.trainer.render import FlashGeometry

#: Photo pixels with any channel at or above this (linear) are left out of every fit, as the bench leaves them out.
CLIP = 0.98

__all__ = ["CLIP", "View", "make_view", "exposure", "view_rmse", "logit", "pixel_params", "pixel_maps",
           "adam_fit", "to_tensor", "to_maps"]


def to_tensor(image: np.ndarray) -> torch.Tensor:
    """(H, W, C) float array -> (1, C, H, W) float32 tensor."""
    return torch.from_numpy(np.ascontiguousarray(image, np.float32)).permute(2, 0, 1)[None]


def to_maps(packed: torch.Tensor, meta: Optional[dict] = None) -> Maps:
    """(1, 8, H, W) packed maps tensor -> :class:`Maps` (H, W)."""
    return Maps.unpack(packed.detach()[0].permute(1, 2, 0).numpy(), meta=meta)


@dataclass
class View:
    """One photo with its camera and flash, ready for the fit.

    Attributes:
        geometry: the view's view/light directions and squared light distance (fall-off on).
        target: (1, 3, H, W) linear photo.
        target_srgb: the photo clipped to [0, 1], sRGB.
        ok: (1, 1, H, W) 1 where the photo is not clipped, else 0.
    """

    geometry: FlashGeometry
    target: torch.Tensor
    target_srgb: torch.Tensor
    ok: torch.Tensor


def make_view(photo: np.ndarray, config: RenderConfig, camera: Optional[Sequence[float]] = None,
              light: Optional[Sequence[float]] = None) -> View:
    """A :class:`View` of ``photo`` ((H, W, 3) linear float) seen from ``camera`` and lit by ``light`` (scene units,
    :mod:`svbrdf.runtime.core.render`; None: above the centre at ``config``'s field of view, and the flash at the
    camera), rendered with ``config`` and inverse-square fall-off."""
    h, w = photo.shape[:2]
    target = to_tensor(photo)
    ok = (target.amax(1, keepdim=True) < CLIP).float()
    return View(FlashGeometry(h, w, config.replace(falloff=True), light_pos=light, camera_pos=camera), target,
                srgb(target.clamp(0, 1)), ok)


def exposure(render: torch.Tensor, view: View, mask: torch.Tensor) -> torch.Tensor:
    """The closed-form exposure (a detached scalar) that scales ``render`` to the photo over ``mask`` (1, 1, H, W)."""
    m = mask * view.ok
    return ((render * view.target * m).sum() / (render * render * m).sum().clamp(min=1e-12)).detach()


def view_rmse(maps: torch.Tensor, view: View, mask: Optional[torch.Tensor] = None,
              exposure_mask: Optional[torch.Tensor] = None) -> torch.Tensor:
    """sRGB RMSE of packed ``maps`` (1, 8, H, W) rendered at ``view`` against its photo, over the photo's unclipped
    pixels in ``mask`` (1, 1, H, W; None: all); the exposure is fitted over ``exposure_mask`` (default ``mask``).
    Differentiable in ``maps``."""
    m = view.ok if mask is None else view.ok * mask
    r = view.geometry.render(maps)
    k = exposure(r, view, m if exposure_mask is None else exposure_mask)
    err = (srgb((k * r).clamp(0, 1)) - view.target_srgb) * m
    return torch.sqrt((err * err).sum() / (m.sum() * 3).clamp(min=1.0))


def logit(x: torch.Tensor) -> torch.Tensor:
    """The inverse of the sigmoid, ``x`` clamped to [1e-3, 1 - 1e-3]."""
    x = x.clamp(1e-3, 1 - 1e-3)
    return torch.log(x / (1 - x))


def pixel_params(prior: Maps) -> List[torch.Tensor]:
    """The per-pixel parameters of ``prior``: ``[logit diffuse (1, 3, H, W), logit specular, logit roughness
    (1, 1, H, W), normal slopes nx / nz, ny / nz (1, 2, H, W)]`` (:func:`pixel_maps` inverts it)."""
    p0 = to_tensor(prior.pack())
    return [logit(p0[:, 0:3]), logit(p0[:, 3:4]), logit(p0[:, 4:5]), p0[:, 5:7] / p0[:, 7:8].clamp(min=0.05)]


def pixel_maps(params: Sequence[torch.Tensor]) -> torch.Tensor:
    """(1, 8, H, W) packed maps of per-pixel parameters (:func:`pixel_params`): sigmoids and a unit normal."""
    d, s, r, slopes = params
    n = torch.cat([slopes, torch.ones_like(slopes[:, :1])], 1)
    n = n / n.norm(dim=1, keepdim=True)
    return torch.cat([torch.sigmoid(d), torch.sigmoid(s), torch.sigmoid(r), n], 1)


def adam_fit(params: Sequence[torch.Tensor], objective: Callable[[], torch.Tensor], *, iters: int, lr: float,
             prior_weight: float, start: Optional[Sequence[torch.Tensor]] = None,
             callback: Optional[Callable[[int, float], None]] = None, patience: Optional[int] = None,
             min_gain: float = 1e-4) -> tuple:
    """Adam on ``objective() + prior_weight * sum(mean((p - start)^2))`` over ``params`` (leaf tensors, updated in
    place; ``start`` default: their values now).

    Args:
        objective: the photo error (a scalar tensor of the current ``params``).
        iters: at most this many steps; lr: Adam's learning rate.
        callback: ``callback(step, photo_error)`` after each step.
        patience: stop when the photo error has not improved by ``min_gain`` (relative) for this many steps
            (None: never stop early).

    Returns:
        ``(steps done, last photo error)``.
    """
    start = [p.detach().clone() for p in params] if start is None else list(start)
    for p in params:
        p.requires_grad_(True)
    opt = torch.optim.Adam(params, lr=lr)
    last, best, since = float("nan"), float("inf"), 0
    step = 0
    for step in range(1, iters + 1):
        opt.zero_grad()
        loss = objective()
        pull = sum(((p - s) ** 2).mean() for p, s in zip(params, start))
        (loss + prior_weight * pull).backward()
        opt.step()
        last = float(loss.detach())
        if callback is not None:
            callback(step, last)
        if patience is not None:
            if last < best * (1.0 - min_gain):
                best, since = last, 0
            else:
                since += 1
                if since >= patience:
                    break
    return step, last
