"""One way to set up a training stage: :func:`make_trainer`, used by ``svbrdf-train``, ``svbrdf-bench`` and
:func:`svbrdf.trainer.refine.refine`.

=============  ===========================================================================================
stage          what the trainer starts from
=============  ===========================================================================================
``pretrain``   random weights (stage one on one photo), ``config.optim.iters_pretrain`` iterations
``fit``        random weights, ``config.optim.iters_fit`` iterations
``finetune``   a stage-one checkpoint (``init``): its architecture (:func:`finetune_config`), G, D and, unless
               ``reset_optimizers``, its Adam states (:meth:`~svbrdf.trainer.train.Trainer.load_init`);
               ``config.optim.iters_finetune`` iterations
resume         a checkpoint of an interrupted run (``resume``): its settings, stage, weights, Adam and RNG
               states, history and step (:meth:`~svbrdf.trainer.train.Trainer.load_resume`)
=============  ===========================================================================================

The trainer is returned ready to :meth:`~svbrdf.trainer.train.Trainer.run`; nothing has been trained yet.
"""

from __future__ import annotations

from typing import Any, Iterable, List, Mapping, Optional, Tuple, Union

import torch

from svbrdf.runtime.errors import ModelError
from svbrdf.runtime.inference.manifest import recorded_even_lighting
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer.config import TRAIN_PRESETS, TrainConfig, flat_settings, setting_name
from svbrdf.trainer.models import DiscriminatorConfig, GeneratorConfig
from svbrdf.trainer.train import PathLike, Trainer

#: A checkpoint file, or one already loaded with :func:`svbrdf.trainer.checkpoint.load_checkpoint`.
CheckpointLike = Union[PathLike, Mapping[str, Any]]


def finetune_config(config: TrainConfig, init: Mapping[str, Any], keep: Iterable[str] = ()
                    ) -> Tuple[TrainConfig, List[str]]:
    """``config`` with the generator/discriminator architecture of checkpoint ``init`` (``train_encoder`` kept).

    A config that shows the generator an evenly lit photo (``post.even_lighting`` > 0: ``fast``) shows it what the stage
    one's ``network_input`` record says when it has one (:func:`svbrdf.runtime.inference.manifest.recorded_even_lighting`;
    the photo as it is for a stage one shipped so), as the preview does; the paper's presets (0) keep the photo.
    Such a config also takes the stage one's ``refine`` record (the fine-tune settings measured for it,
    :data:`~svbrdf.trainer.config.REFINE_RECIPES`) for every setting that still has its preset's value and is not in
    ``keep``: a setting the user changed (``--set``) to another value wins, and so does one the user set to the
    preset's own value when its name is in ``keep`` (the names the user gave; the bench passes its ``--set``).

    Raises:
        ModelError: an invalid ``network_input`` or ``refine`` record.
    """
    gen = GeneratorConfig.from_dict({**init["generator_config"], "train_encoder": config.train_encoder})
    disc = config.discriminator
    if init.get("discriminator_config"):
        disc = DiscriminatorConfig.from_dict(init["discriminator_config"])
    notes = []
    if gen != config.generator or disc != config.discriminator:
        notes.append("model architecture taken from the initial checkpoint")
    d = config.to_dict()
    d.update(generator=gen.to_dict(), discriminator=disc.to_dict())
    recorded = recorded_even_lighting(init)
    if recorded is not None and config.even_lighting > 0 and recorded != config.even_lighting:
        d["post"]["even_lighting"] = recorded
        notes.append(f"network input taken from the initial checkpoint: "
                     f"{'the photo as it is' if not recorded else f'evenly lit at {recorded:g}'}")
    if init.get("refine") is not None and config.even_lighting > 0:
        taken = _recorded_refine(config, init["refine"], d, frozenset(keep))
        if taken:
            notes.append(f"fine-tune settings taken from the initial checkpoint: {', '.join(taken)}")
    return TrainConfig.from_dict(d), notes


def _recorded_refine(config: TrainConfig, record: Any, d: dict, keep: frozenset) -> List[str]:
    """Put a ``refine`` record's settings into ``d`` (``config`` as a nested dict) where ``config`` has its preset's
    value and the name is not in ``keep``; returns ``"name=value"`` of those that changed. Raises
    :class:`ModelError` for an invalid record. Settings are compared one by one by their dotted names, whatever form
    the record and ``keep`` name them in (a group dict, dotted or the flat names of earlier records:
    :func:`~svbrdf.trainer.config.flat_settings`, :func:`~svbrdf.trainer.config.setting_name`)."""
    try:
        if not isinstance(record, Mapping):
            raise ValueError("not a mapping of training settings")
        names = list(flat_settings(record))
        own = TrainConfig.from_dict({**config.flat_dict(), **flat_settings(record)}).flat_dict()  # validates
    except (TypeError, ValueError) as e:
        raise ModelError(f"invalid refine record in the initial checkpoint: {record!r} ({e})") from None
    mine = config.flat_dict()
    preset = TRAIN_PRESETS[config.preset].flat_dict() if config.preset in TRAIN_PRESETS else mine
    keep = frozenset(setting_name(k) for k in keep)
    taken = []
    for name in names:
        if name in own and name not in keep and own[name] != mine[name] and mine[name] == preset[name]:
            group, _, key = name.partition(".")
            if key:
                d[group][key] = own[name]
            else:
                d[name] = own[name]
            taken.append(f"{name}={own[name]}")
    return taken


def _load(ckpt: CheckpointLike, source: Optional[PathLike]) -> Tuple[Mapping[str, Any], PathLike]:
    if isinstance(ckpt, Mapping):
        return ckpt, "checkpoint" if source is None else source
    return ckpt_io.load_checkpoint(ckpt), ckpt if source is None else source


def make_trainer(photo: torch.Tensor, stage: Optional[str] = None, config: Optional[TrainConfig] = None, *,
                 init: Optional[CheckpointLike] = None, resume: Optional[CheckpointLike] = None,
                 source: Optional[PathLike] = None, iters: Optional[int] = None, keep: Iterable[str] = (),
                 **kw) -> Trainer:
    """Build the :class:`~svbrdf.trainer.train.Trainer` of one stage (see the module docstring).

    Args:
        photo: (1, 3, H, W) linear RGB photo (see :class:`~svbrdf.trainer.train.Trainer`).
        stage: "pretrain", "fit" or "finetune"; with ``resume``, None or the checkpoint's stage (checked).
        config: training settings (not with ``resume``: the checkpoint's are used).
        init: ``finetune`` only: the stage-one checkpoint, a path or a loaded dict.
        resume: continue this checkpoint (path or loaded dict) exactly where it stopped.
        source: how ``init`` / ``resume`` is named in notes and in the run's ``init`` record (default: its path,
            or "checkpoint" for a loaded dict).
        iters: iterations to reach (default: the stage's from ``config``; with ``resume`` the checkpoint's plan).
        keep: ``finetune`` only: names of the settings the user gave, which the stage one's ``refine`` record never
            replaces (:func:`finetune_config`).
        **kw: the other :class:`~svbrdf.trainer.train.Trainer` keywords (device, threads, photo_info,
            checkpoint_path, log_path, callback).

    Raises:
        ModelError: unreadable checkpoint, a resumed run of another stage or with unreadable settings, weights
            that do not fit.
        ValueError: a missing or superfluous argument for the stage.
    """
    if resume is not None:
        if config is not None or init is not None:
            raise ValueError("a resumed run takes its settings and weights from its checkpoint")
        ckpt, src = _load(resume, source)
        if stage is not None and ckpt["stage"] != stage:
            raise ModelError(f"{src}: is a {ckpt['stage']!r} run, not {stage!r}")
        try:
            config = TrainConfig.from_dict(ckpt["train_config"])
        except (TypeError, ValueError) as e:
            raise ModelError(f"{src}: bad training settings ({e})") from None
        trainer = Trainer(photo, config, stage=ckpt["stage"], iters=iters if iters is not None else ckpt.get("iters"),
                          **kw)
        trainer.load_resume(ckpt, src)
        return trainer
    if config is None or stage is None:
        raise ValueError("a new run needs a stage and a config")
    if (stage == "finetune") != (init is not None):
        raise ValueError("a finetune, and only a finetune, starts from a checkpoint (init)")
    if init is None:
        return Trainer(photo, config, stage=stage, iters=iters, **kw)
    ckpt, src = _load(init, source)
    config, notes = finetune_config(config, ckpt, keep)
    trainer = Trainer(photo, config, stage=stage, iters=iters, **kw)
    trainer.notes.extend(notes)
    trainer.load_init(ckpt, src)
    return trainer


__all__ = ["make_trainer", "finetune_config", "CheckpointLike"]
