"""``svbrdf-preview --refine``: fine-tune the preview model's training checkpoint on one photo, or skip it.

:func:`refine` is the runtime's only entry into the trainer (imported lazily by :mod:`svbrdf.runtime.cli.preview`, so a
light install without torch still previews). The fine-tune runs the checkpoint's preset as this version defines it
(fine-tune length, stopping rule, ...), with the architecture of the checkpoint itself
(:func:`svbrdf.trainer.stage.finetune_config`); a preset this version does not know keeps the recorded settings.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping, Optional, Union

import numpy as np

from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.quality.preview_check import check_preview
from svbrdf.runtime.core.render import RenderConfig
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer import train
from svbrdf.trainer.config import TRAIN_PRESETS, TrainConfig, resolve
from svbrdf.trainer.stage import make_trainer

QUALITIES = ("fixed", "auto")


def refine_config(init: Mapping[str, Any], quality: str = "fixed", iters: Optional[int] = None,
                  fov_deg: Optional[float] = None) -> TrainConfig:
    """The fine-tune settings of ``refine``: the checkpoint's preset (or its recorded settings when this version
    does not know the preset), ``quality``, ``iters`` fine-tune iterations and the renderer's field of view
    ``fov_deg`` (the photo's camera) when given."""
    preset = init["train_config"].get("preset")
    cfg = (resolve(preset) if preset in TRAIN_PRESETS else TrainConfig.from_dict(init["train_config"])).to_dict()
    cfg["quality"] = quality
    if iters:
        cfg["iters_finetune"] = iters
    if fov_deg is not None:
        cfg["render"]["fov_deg"] = float(fov_deg)
    return TrainConfig.from_dict(cfg)


Checkpoint = Union[train.PathLike, Mapping[str, Any]]


def refine(photo: np.ndarray, init: Union[Checkpoint, Callable[[], Checkpoint]], quality: str = "fixed",
           iters: Optional[int] = None, threads: Optional[int] = None, name: str = "<photo>",
           callback: Optional[train.Callback] = None, preview: Optional[Maps] = None,
           render_config: Optional[RenderConfig] = None) -> Maps:
    """Fine-tune stage one on ``photo`` and return the maps of the whole photo.

    With ``quality="auto"`` and a ``preview``, the fine-tune is skipped when the preview already explains the photo
    (:func:`svbrdf.runtime.quality.preview_check.check_preview`); otherwise it stops when the label-free re-render error
    stops improving (at most the preset's length).

    Args:
        photo: (H, W, 3) linear RGB float32 photo.
        init: the stage-one checkpoint, a path or a loaded dict, or a function without arguments that returns one
            (called only when the fine-tune runs, so a skipped fine-tune needs no checkpoint; e.g. a lookup with
            ``svbrdf.runtime.inference.manifest.find_checkpoint``).
        quality: "fixed" (every iteration) or "auto" (see above).
        iters: fine-tune iterations (default: the preset's).
        threads: CPU threads (default: all cores).
        name: the photo's name in the run's records.
        callback: ``callback(trainer, record)`` after every iteration (:data:`svbrdf.trainer.train.Callback`).
        preview: the instant preview of ``photo`` (:func:`svbrdf.runtime.inference.pipeline.estimate`), for the skip rule.
        render_config: the photo's renderer settings: the skip rule's re-render (needed with ``preview``) and the
            fine-tune's renderer takes its field of view (the photo's camera); None: the checkpoint's.

    Returns:
        :class:`~svbrdf.runtime.core.maps.Maps` with ``meta["refine"]``: ``{"checkpoint", "iterations",
        "stopped_early", "notes"}`` (plus ``preview_input_rmse`` and ``preview_burn_in`` when a preview was
        checked) and ``meta["burn_in"]`` (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in`); or, when skipped, the
        preview itself with ``meta["refine"] = {"skipped": True, "preview_input_rmse", "threshold",
        "preview_burn_in", "burn_in_threshold"}``.
    """
    if quality not in QUALITIES:
        raise ValueError(f"unknown quality {quality!r}; expected one of {', '.join(QUALITIES)}")
    check = None
    if quality == "auto" and preview is not None:
        if render_config is None:
            raise ValueError("the skip rule needs the render_config of the preview")
        check = check_preview(preview, photo, render_config)
        if check["skipped"]:
            preview.meta["refine"] = check
            return preview
    if callable(init):
        init = init()
    ckpt = ckpt_io.load_checkpoint(init) if not isinstance(init, Mapping) else init
    tensor = train.photo_to_tensor(photo)
    fov = render_config.fov_deg if render_config is not None else None
    trainer = make_trainer(tensor, "finetune", refine_config(ckpt, quality, iters, fov), init=ckpt, threads=threads,
                           photo_info=train.tensor_photo_info(tensor, name), callback=callback)
    trainer.run()
    meta = {"refine": {"checkpoint": str(init) if not isinstance(init, Mapping) else "checkpoint",
                       "iterations": trainer.step, "stopped_early": trainer.stopped_early,
                       "notes": list(trainer.notes)}}
    maps = trainer.predict_maps(meta)  # meta["burn_in"] set
    if check is not None:
        maps.meta["refine"].update(preview_input_rmse=check["preview_input_rmse"],
                                   preview_burn_in=check["preview_burn_in"])
    return maps


__all__ = ["refine", "refine_config", "QUALITIES"]
