"""Named starting settings of a prior run (``svbrdf-train prior --preset``)."""

from __future__ import annotations

from typing import Callable, Dict

from svbrdf.trainer.models import GeneratorConfig
from svbrdf.trainer.prior.config import PriorConfig


#: Named prior settings (``svbrdf-train prior --preset``): ``v1`` is the first procedural stage one's (the defaults);
#: ``v2`` the GPU settings of issue 26 (the shipped run's start; the run itself: ``RECIPES["v2"]``, recipes.py): the U-Net candidate (``arch="unet"``, 4 levels, width 0.25: 0.71 M parameters), batches
#: of 32 built on the device, 256 px photos (crops of 512 px ones), bf16, relighting under 3 point lights and 6
#: random views and lights (half of them grazing), the detail term, one log record per 50 iterations, compact
#: checkpoints (about 4.3 MB). ``iters`` is the length of its cosine schedule (extend it with ``--iters`` on resume).
#: The detail-amount term on the roughness (weight 2, 32 px windows at 256 px): without it the recipe's roughness
#: collapsed to its mean (detail 0.05 on held-out procedural materials); continued on one CPU core at 128 px with
#: 16 px windows it placed the roughness pattern (detail 0.46); with 64 px windows too it made blobs and rings at
#: the highlight (CHANGELOG.md, study prior-v2).
PRIOR_PRESETS: Dict[str, Callable[[], PriorConfig]] = {
    "v1": PriorConfig,
    "v2": lambda: PriorConfig(
        generator=GeneratorConfig(width=0.25, decoder_blocks=4, train_encoder=True, arch="unet", height_activation="linear"),
        size=256, photo_size=512, batch=32, iters=40000, lr=1e-3, lr_min=2e-5, render_lights=3, render_views=6,
        grazing_share=0.5, lambda_grad=1.0, lambda_amount=2.0, amount_maps=("roughness",), amount_windows=(32,),
        batched=True, bf16=True, log_every=50, compact_checkpoint=True, checkpoint_every=2000, eval_every=500,
        eval_batch=32),
}


def prior_preset(name: str) -> PriorConfig:
    """A fresh :class:`PriorConfig` of :data:`PRIOR_PRESETS` ``name``."""
    if name not in PRIOR_PRESETS:
        raise ValueError(f"unknown prior preset {name!r}; expected one of {', '.join(PRIOR_PRESETS)}")
    return PRIOR_PRESETS[name]()


__all__ = ["PRIOR_PRESETS", "prior_preset"]
