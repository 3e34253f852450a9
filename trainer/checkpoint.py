"""Self-describing training checkpoints.

A checkpoint is a plain dict of tensors, numbers, strings, lists and dicts only, so that
``torch.load(path, weights_only=True)`` reads it (no pickled classes, no numpy arrays)::

    format, format_version      "svbrdf-train-checkpoint", 1
    generator_config            GeneratorConfig.to_dict()
    discriminator_config        DiscriminatorConfig.to_dict()
    train_config                TrainConfig.to_dict()
    stage, step, iters          "pretrain" | "finetune" | "fit", iterations done, iterations planned
    generator, discriminator    state dicts (discriminator may be None in a cleaned checkpoint)
    generator_ema               a prior run's moving average of the generator's weights (``PriorConfig.ema``), or
                                absent: where present it is the model (:func:`model_weights`), ``generator`` what a
                                resume trains on
    optimizers                  {"nr", "ds", "d"} (+ "cam"): Adam state dicts, or None (cleaned)
    history                     one dict of loss terms per iteration (None for a non-finite value)
    photo                       {"name", "sha256", "height", "width"} of the training photo
    rng                         {"torch": ByteTensor, "tiles": ByteTensor, "cuda": [ByteTensor]} or None
    counters                    {"nonfinite_skips", "rollbacks"}
    init                        for a finetune: {"path", "stage", "step", "photo"} of the starting checkpoint
    perceptual_backend, notes   what actually ran (backend name, fallbacks)
    eval_maps                   maps of the fixed evaluation tiles at the last evaluation (for the map-change signal)
    camera                      the photo's learned camera ({"vignetting": tensor}) or None
    anchor                      a fine-tune's starting maps of the whole photo (float16, ``losses.anchor``) or None
    versions, date              library versions, ISO date (UTC)
    network_input               a shipped stage one's {"mode", "even_lighting"}: what the runtime shows its network
                                (set by :func:`clean_checkpoint`; absent: the runtime's default)
    refine                      a shipped stage one's fine-tune settings ({TrainConfig field: value}, one of
                                :data:`~svbrdf.trainer.config.REFINE_RECIPES`; set by :func:`clean_checkpoint`,
                                applied by :func:`svbrdf.trainer.stage.finetune_config`; absent: the preset's)

Files are written atomically (:func:`svbrdf.runtime.io.files.atomic_write`).
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import shutil
from pathlib import Path
from typing import Any, Dict, Mapping, Optional, Tuple, Union

import numpy as np
import torch

from svbrdf.runtime.errors import ModelError
from svbrdf.runtime.post.flash_trend import EVEN_LIGHTING_WIDTH
from svbrdf.runtime.inference.manifest import PRIOR_STAGE, network_input_record
from svbrdf.runtime.io.files import atomic_write
from svbrdf.trainer.config import REFINE_RECIPES
from svbrdf.trainer.models import Generator, create_generator

FORMAT = "svbrdf-train-checkpoint"
FORMAT_VERSION = 1
#: Keys every checkpoint must have.
REQUIRED_KEYS = ("format", "format_version", "generator_config", "train_config", "stage", "step", "generator")

PathLike = Union[str, os.PathLike]

#: Settings measured and not adopted, then deleted, with the value that meant "off": a checkpoint that records one
#: at that value loads without it; one that records it switched on was trained with code that no longer exists.
#: Keys: ``train_config`` (TrainConfig) and ``prior_config`` (PriorConfig) settings.
RETIRED_OPTIONS: Dict[str, Dict[str, Any]] = {
    "train_config": {"diffuse_weighting": "uniform", "unexplained_ratio": 0.0, "diffuse_robust": 0.0,
                     "locate_flash": False},
    "prior_config": {"crop_context": False},
}


def without_retired(settings: Mapping[str, Any], kind: str, source: PathLike = "checkpoint") -> Dict[str, Any]:
    """``settings`` (a ``train_config``, ``refine`` or ``prior_config`` dict, ``kind`` naming its table in
    :data:`RETIRED_OPTIONS`; ``refine`` uses ``train_config``'s) without the retired options it records at their
    off value.

    Raises:
        ModelError: one is recorded switched on (one line naming it and its value).
    """
    table = RETIRED_OPTIONS["train_config" if kind == "refine" else kind]
    out = dict(settings)
    for name, off in table.items():
        if name in out:
            value = out.pop(name)
            if value != off:
                raise ModelError(f"{source}: {kind} sets the retired option {name}={value!r} (only {off!r} is still "
                                 f"supported; train with an older svbrdf)")
    return out


def library_versions() -> Dict[str, str]:
    try:
        from importlib.metadata import version

        svbrdf_version = version("svbrdf")
    except Exception:  # running from a source tree without an install
        svbrdf_version = "0.0.0+local"
    return {"svbrdf": svbrdf_version, "torch": str(torch.__version__), "numpy": str(np.__version__),
            "python": platform.python_version()}


def build_checkpoint(
    *,
    generator: torch.nn.Module,
    discriminator: Optional[torch.nn.Module],
    train_config: Mapping[str, Any],
    stage: str,
    step: int,
    iters: int,
    optimizers: Optional[Mapping[str, torch.optim.Optimizer]] = None,
    history=(),
    photo: Optional[Mapping[str, Any]] = None,
    rng: Optional[Mapping[str, Any]] = None,
    counters: Optional[Mapping[str, int]] = None,
    init: Optional[Mapping[str, Any]] = None,
    perceptual_backend: Optional[str] = None,
    notes=(),
    eval_maps: Optional[torch.Tensor] = None,
    camera: Optional[Mapping[str, torch.Tensor]] = None,
    anchor: Optional[torch.Tensor] = None,
) -> Dict[str, Any]:
    """Assemble the checkpoint dict (see the module docstring); tensors are moved to the CPU."""
    def cpu(obj):
        if isinstance(obj, torch.Tensor):
            return obj.detach().to("cpu", copy=True)
        if isinstance(obj, Mapping):
            return {k: cpu(v) for k, v in obj.items()}
        if isinstance(obj, (list, tuple)):
            return type(obj)(cpu(v) for v in obj)
        return obj

    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "generator_config": generator.cfg.to_dict(),
        "discriminator_config": None if discriminator is None else discriminator.cfg.to_dict(),
        "train_config": dict(train_config),
        "stage": str(stage),
        "step": int(step),
        "iters": int(iters),
        "generator": cpu(generator.state_dict()),
        "discriminator": None if discriminator is None else cpu(discriminator.state_dict()),
        "optimizers": None if optimizers is None else {k: cpu(o.state_dict()) for k, o in optimizers.items()},
        "history": [dict(h) for h in history],
        "photo": dict(photo or {}),
        "rng": None if rng is None else cpu(dict(rng)),
        "counters": dict(counters or {}),
        "init": None if init is None else dict(init),
        "perceptual_backend": perceptual_backend,
        "notes": list(notes),
        "eval_maps": None if eval_maps is None else cpu(eval_maps),
        "camera": None if camera is None else cpu(dict(camera)),
        "anchor": None if anchor is None else cpu(anchor).half(),
        "versions": library_versions(),
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    }


def _atomic_save(obj: Any, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, force=True, error=ModelError) as tmp:
        torch.save(obj, tmp)
    return path


def save_checkpoint(path: PathLike, checkpoint: Mapping[str, Any]) -> Path:
    """Write ``checkpoint`` (from :func:`build_checkpoint`) atomically to ``path``, replacing it if present.

    Raises:
        ModelError: the dict is not a checkpoint, or the file cannot be written.
    """
    path = Path(path)
    if checkpoint.get("format") != FORMAT:
        raise ModelError(f"{path}: refusing to save a dict that is not an {FORMAT}")
    try:
        return _atomic_save(dict(checkpoint), path)
    except OSError as e:
        raise ModelError(f"{path}: cannot write checkpoint ({e.strerror or e})") from e


def load_checkpoint(path: PathLike) -> Dict[str, Any]:
    """Read and check a checkpoint (CPU tensors, ``weights_only=True``).

    Raises:
        ModelError: missing file, unreadable/corrupt file, not a checkpoint of this project, a newer format, or a
            retired option switched on (:data:`RETIRED_OPTIONS`; at its off value it is dropped).
    """
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"{path}: no such checkpoint file")
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # zip, pickle, EOF and unpickler-policy errors all mean "not a usable checkpoint"
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ModelError(f"{path}: corrupt or unreadable checkpoint ({first[:160]})") from None
    if not isinstance(ckpt, dict) or ckpt.get("format") != FORMAT:
        raise ModelError(f"{path}: not an svbrdf training checkpoint")
    missing = [k for k in REQUIRED_KEYS if k not in ckpt]
    if missing:
        raise ModelError(f"{path}: checkpoint lacks {', '.join(missing)}")
    if not isinstance(ckpt["format_version"], int) or ckpt["format_version"] > FORMAT_VERSION:
        raise ModelError(f"{path}: checkpoint format version {ckpt['format_version']!r} is newer than this "
                         f"toolkit's ({FORMAT_VERSION}); upgrade svbrdf")
    for kind in ("train_config", "prior_config", "refine"):
        if isinstance(ckpt.get(kind), Mapping):
            ckpt[kind] = without_retired(ckpt[kind], kind, path)
    return ckpt


def model_weights(ckpt: Mapping[str, Any]) -> Dict[str, torch.Tensor]:
    """The generator weights a checkpoint's model is: its weights' moving average (``generator_ema``, a prior run
    with ``ema``) where it has one, else ``generator``."""
    return ckpt["generator_ema"] if ckpt.get("generator_ema") is not None else ckpt["generator"]


def generator_from_checkpoint(ckpt: Mapping[str, Any], source: PathLike = "checkpoint") -> Generator:
    """Build the generator of a loaded checkpoint dict (CPU, eval mode; :func:`model_weights`)."""
    try:
        gen = create_generator(**ckpt["generator_config"])
        gen.load_state_dict({k: v.float() if v.is_floating_point() else v for k, v in model_weights(ckpt).items()})
    except (ValueError, TypeError, KeyError, RuntimeError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ModelError(f"{source}: generator weights do not match its configuration ({first[:160]})") from None
    return gen.eval()


def load_generator(path: PathLike) -> Tuple[Generator, Dict[str, Any]]:
    """The trained generator of a checkpoint and its metadata (every key but the weights and optimiser states).

    Returns:
        ``(generator, meta)``: a CPU :class:`~svbrdf.trainer.models.Generator` (the class of its ``arch``) in eval
        mode, and a dict with ``generator_config``, ``train_config``, ``stage``, ``step``, ``photo``, ``history``,
        ``versions``, ...

    Raises:
        ModelError: see :func:`load_checkpoint`, or weights that do not fit the stored configuration.
    """
    ckpt = load_checkpoint(path)
    gen = generator_from_checkpoint(ckpt, path)
    weights = ("generator", "generator_ema", "discriminator", "optimizers", "rng")
    meta = {k: v for k, v in ckpt.items() if k not in weights}
    return gen, meta


def clean_checkpoint(src: PathLike, dst: PathLike, *, keep_discriminator: bool = False,
                     force: bool = False, network_input: Optional[str] = None,
                     refine: Optional[str] = None) -> Path:
    """Copy a checkpoint without optimiser states and RNG states (and the discriminator unless kept), for shipping;
    its weights are the model's (:func:`model_weights`: a prior run's moving average replaces the trained weights).

    Args:
        network_input: for a stage one, what the runtime shows its network, chosen by measurement when it is
            shipped: ``"even"`` (the photo evenly lit at :data:`~svbrdf.runtime.post.flash_trend.EVEN_LIGHTING_WIDTH`)
            or ``"photo"`` (as it is); recorded as the checkpoint's ``network_input``
            (:func:`svbrdf.runtime.inference.manifest.network_input_record`), which the export copies into the manifest, the preview
            follows and ``fast``'s fine-tune input takes. None keeps what ``src`` records (nothing: the runtime's
            default, v1's).
        refine: for a stage one, the name of the fine-tune settings measured for it
            (:data:`~svbrdf.trainer.config.REFINE_RECIPES`), recorded as the checkpoint's ``refine`` (the settings
            themselves, so the checkpoint needs no table to be read); None keeps what ``src`` records.

    Raises:
        ModelError: unreadable ``src``, ``dst`` exists and ``force`` is False, or ``network_input`` or ``refine``
            given for a checkpoint that is not a stage one (a fine-tuned model is shown what it was trained on).
        ValueError: an unknown ``network_input`` or ``refine``.
    """
    dst = Path(dst)
    record = None if network_input is None else network_input_record(network_input, EVEN_LIGHTING_WIDTH)
    if refine is not None and refine not in REFINE_RECIPES:
        raise ValueError(f"unknown refine recipe {refine!r}; expected one of {', '.join(REFINE_RECIPES)}")
    if dst.exists() and not force:
        raise ModelError(f"{dst}: already exists (use force=True to overwrite)")
    ckpt = load_checkpoint(src)
    if (record is not None or refine is not None) and ckpt.get("stage") != PRIOR_STAGE:
        raise ModelError(f"{src}: a network input and a refine recipe are chosen for a stage one only (stage "
                         f"{ckpt.get('stage')!r} is shown what it was trained on)")
    if record is not None:
        ckpt["network_input"] = record
    if refine is not None:
        ckpt["refine"] = dict(REFINE_RECIPES[refine])
    ckpt["optimizers"] = None
    ckpt["rng"] = None
    ckpt["eval_maps"] = None
    ckpt["anchor"] = None
    ckpt["generator"] = model_weights(ckpt)
    ckpt.pop("generator_ema", None)
    ckpt.pop("ema_updates", None)
    if not keep_discriminator:
        ckpt["discriminator"] = None
    return save_checkpoint(dst, ckpt)


def default_checkpoint(model: Optional[PathLike] = None) -> Optional[Path]:
    """The stage-one checkpoint the preview model was exported from (its manifest's ``checkpoint`` entry, sha256
    verified): where ``svbrdf-preview --refine``, ``svbrdf-train finetune`` and ``svbrdf-bench`` start by default.

    Args:
        model: as in :func:`svbrdf.runtime.inference.manifest.find_model` (None = ``$SVBRDF_MODEL``, else the packaged model).

    Returns:
        The path, or None where that model names no checkpoint or the file is missing or altered.
    """
    from svbrdf.runtime.inference.manifest import find_checkpoint, find_model

    try:
        return find_checkpoint(find_model(model))
    except ModelError:
        return None


# ----------------------------------------------------------------------------------------------- a Trainer's state
# The functions below read and write the state of a svbrdf.trainer.train.Trainer (given as ``trainer``; this module
# does not import it): the Trainer's load_init / load_resume / checkpoint / save methods call them.
def last_good_path(path: PathLike) -> Path:
    """``checkpoint.pt`` -> ``checkpoint_last_good.pt``."""
    path = Path(path)
    return path.with_name(f"{path.stem}_last_good{path.suffix}")


def load_init(trainer, ckpt: Mapping[str, Any], source: PathLike = "checkpoint") -> None:
    """Start ``trainer`` (a :class:`~svbrdf.trainer.train.Trainer`) from a pretrained checkpoint (finetune): G, D
    and, unless ``reset_optimizers``, the Adam states; when the config needs them (``TrainConfig.needs_anchor``),
    its starting maps as the anchor.

    The generator/discriminator configuration must match ``trainer.config`` (use
    :func:`svbrdf.trainer.stage.make_trainer`, which takes them from the checkpoint).

    Raises:
        ModelError: an architecture or weights that do not fit.
    """
    _load_models(trainer, ckpt, source)
    if ckpt.get("discriminator") is None:
        trainer.notes.append(f"{Path(source).name}: no discriminator weights; D starts from scratch")
    if trainer.config.optim.reset_optimizers:
        trainer.notes.append("optimiser states reset")
    elif not ckpt.get("optimizers"):
        trainer.notes.append(f"{Path(source).name}: no optimiser states; Adam starts fresh")
    else:
        for key, opt in trainer.optimizers.items():
            if key == "cam":  # the new photo's own camera and offsets: a fresh Adam
                continue
            try:
                opt.load_state_dict(ckpt["optimizers"][key])
            except (KeyError, ValueError) as e:
                trainer.optimizers[key] = trainer._adam(trainer.params[key])
                trainer.notes.append(f"optimiser {key!r} state not reusable ({str(e)[:80]}); started fresh")
            else:
                for group in opt.param_groups:  # the new run's learning rate and betas win
                    group["lr"], group["betas"] = trainer.config.optim.lr, tuple(trainer.config.optim.betas)
    trainer.init = {"path": str(source), "stage": ckpt.get("stage"), "step": ckpt.get("step"),
                    "photo": dict(ckpt.get("photo") or {})}
    if trainer.config.needs_anchor:
        with torch.no_grad():
            trainer.anchor = trainer.predict().float()


def load_resume(trainer, ckpt: Mapping[str, Any], source: PathLike = "checkpoint") -> None:
    """Continue ``trainer`` exactly where ``ckpt`` stood: weights, Adam states, step, history, counters, RNG
    states, camera, evaluation maps and anchor.

    Raises:
        ModelError: another photo, a cleaned checkpoint, states that do not fit.
    """
    if ckpt.get("photo", {}).get("sha256") != trainer.photo_info.get("sha256"):
        raise ModelError(f"{source}: was trained on {ckpt.get('photo', {}).get('name')!r}, not on this photo "
                         f"{trainer.photo_info.get('name')!r}")
    if not ckpt.get("optimizers") or not ckpt.get("rng") or ckpt.get("discriminator") is None:
        raise ModelError(f"{source}: cleaned checkpoint (no optimiser/RNG/discriminator state); cannot resume")
    _load_models(trainer, ckpt, source)
    try:
        for key, opt in trainer.optimizers.items():
            opt.load_state_dict(ckpt["optimizers"][key])
    except (KeyError, ValueError) as e:
        raise ModelError(f"{source}: optimiser states do not match the model ({str(e)[:120]})") from None
    trainer.load_camera(ckpt.get("camera"))
    trainer.step = int(ckpt["step"])
    trainer.history = [dict(h) for h in ckpt.get("history", [])]
    trainer.counters.update({k: int(v) for k, v in (ckpt.get("counters") or {}).items()})
    trainer._skips_at_last_save = trainer.counters["nonfinite_skips"]
    trainer.init = ckpt.get("init")
    trainer.notes.extend(n for n in ckpt.get("notes", []) if n not in trainer.notes)
    rng = ckpt["rng"]
    torch.set_rng_state(rng["torch"])
    trainer.tile_rng.set_state(rng["tiles"])
    if rng.get("cuda") and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(rng["cuda"])
    eval_maps = ckpt.get("eval_maps")
    trainer.eval_maps = None if eval_maps is None else eval_maps.to(trainer.device)
    anchor = ckpt.get("anchor")
    trainer.anchor = None if anchor is None else anchor.to(trainer.device, torch.float32)
    if trainer.anchor is None and trainer.stage == "finetune" and trainer.config.needs_anchor:
        raise ModelError(f"{source}: a fine-tune that keeps its starting maps (losses.anchor) but no stored anchor; "
                         f"cannot resume")


def _load_models(trainer, ckpt: Mapping[str, Any], source: PathLike) -> None:
    for key, cfg, net in (("generator", trainer.config.generator, trainer.generator),
                          ("discriminator", trainer.config.discriminator, trainer.discriminator)):
        state = model_weights(ckpt) if key == "generator" else ckpt.get(key)
        if state is None:
            continue
        stored = ckpt.get(f"{key}_config") or {}
        try:  # fields added later (GeneratorConfig.arch) take their defaults, as when the model is rebuilt
            stored = type(cfg).from_dict(stored).to_dict()
        except (TypeError, ValueError):
            pass
        mine = {k: v for k, v in cfg.to_dict().items() if k != "train_encoder"}
        theirs = {k: v for k, v in stored.items() if k != "train_encoder"}
        if mine != theirs:
            raise ModelError(f"{source}: {key} configuration {theirs} differs from the run's {mine}")
        try:
            net.load_state_dict(state)
        except RuntimeError as e:
            raise ModelError(f"{source}: {key} weights do not fit ({str(e).splitlines()[0][:120]})") from None


def trainer_checkpoint(trainer) -> Dict[str, Any]:
    """The current state of ``trainer`` as a checkpoint dict (see the module docstring)."""
    rng = {"torch": torch.get_rng_state(), "tiles": trainer.tile_rng.get_state(),
           "cuda": torch.cuda.get_rng_state_all() if torch.cuda.is_available() else []}
    return build_checkpoint(
        generator=trainer.generator, discriminator=trainer.discriminator, train_config=trainer.config.to_dict(),
        stage=trainer.stage, step=trainer.step, iters=trainer.iters, optimizers=trainer.optimizers,
        history=trainer.history,
        photo=trainer.photo_info, rng=rng, counters=trainer.counters, init=trainer.init,
        perceptual_backend=trainer.perceptual_backend, notes=trainer.notes, eval_maps=trainer.eval_maps,
        camera=trainer.camera_state(), anchor=trainer.anchor)


def save_trainer(trainer, path: PathLike) -> Path:
    """Write the checkpoint of ``trainer`` to ``path`` and, when no non-finite step occurred since its previous
    save, refresh the last-good copy beside it (:func:`last_good_path`, a hard link where the file system allows).
    """
    path = Path(path)
    save_checkpoint(path, trainer_checkpoint(trainer))
    if trainer.counters["nonfinite_skips"] == trainer._skips_at_last_save:
        good = last_good_path(path)
        with atomic_write(good, force=True, error=ModelError) as tmp:
            tmp.unlink()  # the reserved temporary name, for a hard link (no copy) where the file system allows
            try:
                os.link(path, tmp)  # the next checkpoint is a new file (os.replace), this one stays
            except OSError:
                shutil.copyfile(path, tmp)
    trainer._skips_at_last_save = trainer.counters["nonfinite_skips"]
    return path


__all__ = ["FORMAT", "RETIRED_OPTIONS", "without_retired", "default_checkpoint", "FORMAT_VERSION", "build_checkpoint", "save_checkpoint", "load_checkpoint",
           "load_generator", "generator_from_checkpoint", "model_weights", "clean_checkpoint", "library_versions",
           "last_good_path", "load_init", "load_resume", "trainer_checkpoint", "save_trainer"]
