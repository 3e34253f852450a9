"""Named starting settings of a prior run (``svbrdf-train prior --preset``): :data:`PRIOR_PRESETS`.

Why each value is what it is: docs/decisions/023-stage-one-v2.md.
"""

from __future__ import annotations

from typing import Callable, Dict

from svbrdf.trainer.prior.config import PriorConfig

#: The v2 settings (dotted names, :func:`~svbrdf.trainer.prior.config.override` on the defaults).
_V2 = {
    "generator": {"width": 0.25, "decoder_blocks": 4, "train_encoder": True, "arch": "unet",
                  "height_activation": "linear"},
    "photos.size": 256, "photos.photo_size": 512,
    "optim.batch": 32, "optim.iters": 40000, "optim.lr": 1e-3, "optim.lr_min": 2e-5, "optim.bf16": True,
    "materials.batched": True,
    "losses.render_lights": 3, "losses.render_views": 6, "losses.grazing_share": 0.5, "losses.grad": 1.0,
    "losses.amount": 2.0, "losses.amount_maps": ("roughness",), "losses.amount_windows": (32,),
    "monitor.log_every": 50, "monitor.compact_checkpoint": True, "monitor.checkpoint_every": 2000,
    "monitor.eval_every": 500, "monitor.eval_batch": 32,
}

#: Named prior settings, each made fresh:
#: ``v1``: the first procedural stage one's (the defaults: a quarter-width Zhao generator, 128 px, host stream, CPU).
#: ``v2``: the shipped run's start, for a GPU: the U-Net (0.71 M parameters), 32 materials a batch built on the
#: device, 256 px crops of 512 px photos, bf16, relighting under 3 lights and 6 views, the gradient and roughness
#: detail terms, averaged log records, compact checkpoints (the run as trained: ``RECIPES["v2"]``, recipes.py).
PRIOR_PRESETS: Dict[str, Callable[[], PriorConfig]] = {
    "v1": PriorConfig,
    "v2": lambda: PriorConfig.from_dict(_V2),
}


def prior_preset(name: str) -> PriorConfig:
    """A fresh :class:`PriorConfig` of :data:`PRIOR_PRESETS` ``name``."""
    if name not in PRIOR_PRESETS:
        raise ValueError(f"unknown prior preset {name!r}; expected one of {', '.join(PRIOR_PRESETS)}")
    return PRIOR_PRESETS[name]()


__all__ = ["PRIOR_PRESETS", "prior_preset"]
