"""The stage one's supervised loss: per-map L1, relighting, detail, amount of detail and slope pattern."""

from __future__ import annotations

from typing import Callable, Dict, Optional

import torch

from svbrdf.runtime.core.maps import SLICES
from svbrdf.runtime.core.render import RenderConfig, camera_position
from svbrdf.trainer.config import resolve
from svbrdf.trainer.device import to_device
from svbrdf.trainer.losses import (detail_amount_loss, gradient_loss, relit_loss, slope_correlation_loss,
                                    supervised_maps_loss)
from svbrdf.trainer.prior.config import PriorConfig
from svbrdf.trainer.prior.photos import _geometry, lights_for, view_light_directions
from svbrdf.trainer.render import direction_vectors, plane_grid, point_light_vectors, render_maps


def relit_pair(pred: torch.Tensor, target: torch.Tensor, view: torch.Tensor, light: torch.Tensor,
               config: RenderConfig, light_dist2: Optional[torch.Tensor] = None) -> torch.Tensor:
    """:func:`~svbrdf.trainer.losses.relit_loss` of two map sets rendered under one geometry.

    Args:
        pred, target: (B, 8, H, W) packed maps.
        view, light, light_dist2: the geometry of :func:`~svbrdf.trainer.render.render_maps`.
        config: renderer settings.

    Returns:
        The scalar loss (float32).
    """
    return relit_loss(render_maps(pred, view, light, config, light_dist2),
                      render_maps(target, view, light, config, light_dist2))


class CompiledRelit:
    """:func:`relit_pair` through ``torch.compile`` (a few fused kernels instead of dozens of elementwise ops),
    falling back to the plain function for good when compiling fails (no C++ compiler, an unsupported backend).

    On one CPU thread a (32, 8, 256, 256) pair, forward and backward, takes 1.0 -> 0.31 s (gradients equal to 3e-6
    of 7e-4); compiling the point-light pair took 41 s there, at its first call (a distant pair compiles again). Not
    measured on a GPU.
    """

    def __init__(self):
        self.compiled: Optional[Callable[..., torch.Tensor]] = torch.compile(relit_pair, dynamic=False)
        #: Why compiling failed (None while it works).
        self.note: Optional[str] = None

    def __call__(self, *args, **kw) -> torch.Tensor:
        if self.compiled is not None:
            try:
                return self.compiled(*args, **kw)
            except Exception as e:  # the plain function below raises any error of the inputs themselves
                self.compiled = None
                self.note = f"torch.compile failed ({type(e).__name__}: {str(e).splitlines()[0][:160]}); running eager"
        return relit_pair(*args, **kw)


def prior_loss(pred: torch.Tensor, target: torch.Tensor, config: PriorConfig, rng: torch.Generator,
               relit: Callable[..., torch.Tensor] = relit_pair) -> Dict[str, torch.Tensor]:
    """The prior's loss terms: per-map L1 (``maps/*``), relighting (``render``), detail (``grad``), amount of detail
    (``amount``, with ``config.losses.amount > 0``: :func:`~svbrdf.trainer.losses.detail_amount_loss`), pattern of
    the normals' slopes (``slope``, with ``config.losses.slope > 0``:
    :func:`~svbrdf.trainer.losses.slope_correlation_loss`) and ``total``.

    Relighting renders both map sets with the fine-tune's renderer settings under the flash and
    ``config.losses.render_lights`` random lights (:func:`lights_for`), on the training image as a whole photo, and
    under ``config.losses.render_views`` random distant (view, light) pairs (:func:`view_light_directions`, no
    fall-off); ``render`` is the mean over all these renderings, each pair compared by ``relit``
    (:func:`relit_pair`, or its :class:`CompiledRelit`). ``grad`` (with ``config.losses.grad > 0``) is
    :func:`~svbrdf.trainer.losses.gradient_loss` on the normal and roughness maps. With ``config.materials.batched``
    the geometry is computed with torch on ``pred``'s device (the same formula as the numpy one).
    """
    terms = supervised_maps_loss(pred, target)
    out = {f"maps/{k}": v for k, v in terms.items() if k != "total"}
    total = terms["total"]
    if config.losses.render > 0:
        rc = resolve(config.finetune_preset).render_config.replace(falloff=True)
        h, w = pred.shape[-2:]
        rel = []
        lights = [None] + lights_for(rc, config.losses.render_lights, rng)
        if config.materials.batched:
            cam = to_device(camera_position(rc)[None], pred.device)
            pos = plane_grid(h, w, pred.device)
            for light in lights:
                lp = cam if light is None else to_device(torch.tensor([light]), pred.device)
                v, l, d2 = point_light_vectors(pos, cam, lp)
                rel.append(relit(pred, target, v, l, rc, d2))
        else:
            for light in lights:
                v, l, d2 = (t.to(pred.device) for t in _geometry(h, w, light, rc))
                rel.append(relit(pred, target, v, l, rc, d2))
        if config.losses.render_views:
            distant = rc.replace(falloff=False)
            pairs = to_device(view_light_directions(config.losses.render_views, config, rng), pred.device)
            for pair in pairs:
                v, l = (direction_vectors(d[None], h, w) for d in pair)
                rel.append(relit(pred, target, v, l, distant))
        out["render"] = torch.stack(rel).mean()
        total = total + config.losses.render * out["render"]
    if config.losses.grad > 0:
        out["grad"] = gradient_loss(pred, target)
        total = total + config.losses.grad * out["grad"]
    if config.losses.amount > 0:
        out["amount"] = detail_amount_loss(pred, target, config.losses.amount_maps, config.losses.amount_windows)
        total = total + config.losses.amount * out["amount"]
    if config.losses.slope > 0:
        out["slope"] = slope_correlation_loss(pred, target)
        total = total + config.losses.slope * out["slope"]
    out["total"] = total
    return out


def map_errors(pred: torch.Tensor, target: torch.Tensor) -> Dict[str, float]:
    """RMSE of diffuse (linear), specular and roughness, and the mean normal angle in degrees."""
    out = {}
    for name in ("diffuse", "specular", "roughness"):
        out[name] = float(((pred[:, SLICES[name]] - target[:, SLICES[name]]) ** 2).mean().sqrt())
    cos = (pred[:, SLICES["normal"]] * target[:, SLICES["normal"]]).sum(1).clamp(-1.0, 1.0)
    out["normal_deg"] = float(torch.rad2deg(torch.acos(cos)).mean())
    return out


__all__ = ["relit_pair", "CompiledRelit", "prior_loss", "map_errors"]
