"""Every training choice as one named setting: :class:`TrainConfig` and the presets :data:`TRAIN_PRESETS`.

Presets (``resolve(name, **overrides)``): ``paper``, ``zhao``, ``fast``, ``fast-v1`` and ``tiny`` for
``svbrdf-train``, and the benchmark's ablations :data:`BENCH_PRESETS`. What each one is, with its measured cost,
is said once, in :data:`PRESET_DESCRIPTIONS` (printed by ``svbrdf-train --help``).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field, fields
from typing import Any, Dict, Iterable, Mapping, Optional, Tuple

from svbrdf.runtime.post.settings import EVEN_LIGHTING_WIDTH, PostProcess
from svbrdf.runtime.core.maps import MAP_NAMES
from svbrdf.runtime.core.render import ZHAO, RenderConfig
from svbrdf.trainer.losses import DIFFUSE_TARGETS
from svbrdf.trainer.models import DISC_PRESETS, MODEL_PRESETS, DiscriminatorConfig, GeneratorConfig

STAGES = ("pretrain", "finetune", "fit")
#: The trainer's post-processing where a preset asks for none (the paper): the generator sees the photo as it is
#: (``even_lighting`` 0) and the final maps are the generator's own.
NO_POST = PostProcess.off().replace(even_lighting=0.0)
#: The fields of :class:`~svbrdf.runtime.post.PostProcess`: named ``post.<field>``, or by the field's name alone as in
#: the checkpoints and ``refine`` records written before ``TrainConfig.post`` existed (converted when read).
POST_FIELDS: Tuple[str, ...] = tuple(f.name for f in fields(PostProcess))
FOURIER_MODES = ("complex", "magnitude")
PERCEPTUAL_BACKENDS = ("auto", "vgg19", "vgg19-random", "pyramid")
QUALITY_MODES = ("fixed", "auto")
SCHEDULES = ("alternating", "joint")


@dataclass

@dataclass(frozen=True)
class Optimisation:
    """How the networks are optimised.

    Attributes:
        tile: side of the random square training tiles, pixels (clipped to the photo).
        nr_updates, ds_updates, d_updates: optimiser steps per iteration of the normal/roughness decoder, the
            diffuse/specular decoder (plus the encoder if trained) and the discriminator, each on a fresh random tile
            (``schedule="alternating"``).
        schedule: "alternating" (the published schedule: every sub-step runs the generator on its own tile) or
            "joint" (needs 1:1:1): one tile per iteration, one generator pass with both decoders trained by one
            backward pass, then the discriminator step on the same tile and rendering
            (``git show 0b5a711:./trainer/bench/speed.py``, ``--variants alternating,joint``).
        lr, betas: Adam settings shared by the three optimisers.
        camera_lr: learning rate (own Adam) of the learned camera and of the output offsets.
        gan_steps: the GAN (the generator's term and the discriminator's update) runs for the first ``gan_steps``
            iterations of a run only (0 = every iteration, as in the paper; docs/decisions/020-fast-schedule.md).
        iters_pretrain, iters_finetune, iters_fit: iterations of each stage.
        seed: seeds weights and the tile sequence.
        bf16: bfloat16 autocast around the networks (falls back to fp32 where unsupported).
        reset_optimizers: finetune with fresh Adam states instead of the pretrained ones.
    """

    tile: int = 256
    nr_updates: int = 5
    ds_updates: int = 1
    d_updates: int = 1
    schedule: str = "alternating"
    lr: float = 2e-5
    betas: Tuple[float, float] = (0.0, 0.9)
    camera_lr: float = 5e-3
    gan_steps: int = 0
    iters_pretrain: int = 10000
    iters_finetune: int = 3000
    iters_fit: int = 20000
    seed: int = 24
    bf16: bool = False
    reset_optimizers: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "betas", tuple(float(b) for b in self.betas))


@dataclass(frozen=True)
class Losses:
    """The loss terms: each weight (0 = off) and its options.

    Attributes:
        gan: weight of the generator GAN term in both decoder losses.
        fourier: weight of the Fourier loss L_F; ``fourier_mode``: "complex" | "magnitude".
        perceptual: weight of the perceptual loss L_P; ``perceptual_backend``: its backend; ``vgg_weights``: optional
            VGG-19 state-dict file; ``perceptual_min_clipped``: photos with a smaller fraction of clipped pixels
            (:func:`svbrdf.trainer.losses.clipped_fraction`) train without L_P (0 = never skipped;
            docs/decisions/021-fast-highlight-free.md).
        diffuse: weight of L_d (1 = the paper's); ``diffuse_target``: "absolute" (the paper's L_d) or "normalized"
            (L_d on standardised tiles, :func:`svbrdf.trainer.losses.diffuse_loss`).
        render: weight of the per-pixel re-render loss (:func:`svbrdf.trainer.losses.render_loss`).
        flash: weight of the flash-correlation stationarity loss (:func:`svbrdf.trainer.losses.flash_correlation_loss`).
        specular_prior: weight of the dielectric prior on the specular albedo
            (:func:`svbrdf.trainer.losses.specular_prior_loss`).
        anchor: weight of the pull of a fine-tune towards the initial checkpoint's prediction of the whole photo
            (:func:`svbrdf.trainer.losses.supervised_maps_loss`; only a fine-tune has a starting point);
            ``anchor_maps``: the maps that pull (names of :data:`svbrdf.runtime.core.maps.MAP_NAMES`).
    """

    gan: float = 0.1
    fourier: float = 0.1
    fourier_mode: str = "complex"
    perceptual: float = 0.2
    perceptual_backend: str = "auto"
    vgg_weights: Optional[str] = None
    perceptual_min_clipped: float = 0.0
    diffuse: float = 1.0
    diffuse_target: str = "absolute"
    render: float = 0.0
    flash: float = 0.0
    specular_prior: float = 0.0
    anchor: float = 0.0
    anchor_maps: Tuple[str, ...] = MAP_NAMES

    def __post_init__(self) -> None:
        object.__setattr__(self, "anchor_maps", tuple(self.anchor_maps))


@dataclass(frozen=True)
class PhotoModel:
    """How the renderings are made comparable with the photo.

    Attributes:
        saturate: renderings are clipped to [0, 1] before the discriminator, the perceptual loss and the progress
            signal, as the photo was by the sensor (False: the paper's unclipped renderings).
        learn_vignetting: fit the photo's vignetting (``1 - v r^2``, ``v = 0.9 sigmoid(t)`` per photo, from 0.05).
        learn_offsets: train the generator's six pre-tanh output offsets
            (:attr:`svbrdf.trainer.models.Generator.out_offset`) at ``optim.camera_lr``.
        flash_position: where the flash (with the camera) is over the photo, (x, y) in the renderer's units
            (:func:`svbrdf.runtime.core.render.plane_positions`); None = above the photo's centre.
    """

    saturate: bool = False
    learn_vignetting: bool = False
    learn_offsets: bool = False
    flash_position: Optional[Tuple[float, float]] = None

    def __post_init__(self) -> None:
        if self.flash_position is not None:
            object.__setattr__(self, "flash_position", tuple(float(v) for v in self.flash_position))


@dataclass(frozen=True)
class Monitoring:
    """Checkpoints, map dumps and the label-free progress signal.

    Attributes:
        checkpoint_every: iterations between checkpoints (0 = only at the end).
        maps_every: iterations between full-photo map dumps by the CLI (0 = only at the end).
        eval_every, eval_tiles: cadence and number of fixed tiles of the progress signal (re-render L1 vs the
            photo, mean map change between evaluations); 0 = off.
        quality: "fixed" (run all iterations) or "auto" (stop early when the re-render L1 stops improving).
        plateau_window, plateau_render_tol: the ``quality="auto"`` rule (:meth:`svbrdf.trainer.train.Trainer.plateaued`).
    """

    checkpoint_every: int = 500
    maps_every: int = 500
    eval_every: int = 100
    eval_tiles: int = 4
    quality: str = "fixed"
    plateau_window: int = 4
    plateau_render_tol: float = 0.05


@dataclass(frozen=True)
class Guard:
    """The non-finite step guard: roll back to the last in-memory snapshot after ``rollback_after`` consecutive
    non-finite optimiser steps; a snapshot every ``snapshot_every`` iterations."""

    rollback_after: int = 5
    snapshot_every: int = 50


@dataclass(frozen=True)
class Prediction:
    """How the whole photo is predicted.

    Attributes:
        max_side, overlap: photos with a longer side are predicted in overlapping tiles of this size and overlap.
        photo_context: a U-Net generator sees every tile with the whole photo's flash spot and global vectors
            (:class:`svbrdf.trainer.models.PhotoContext`), refreshed every ``context_every`` iterations
            (docs/decisions/066-unet-photo-context.md). No effect on ``"wen"``.
    """

    max_side: int = 1024
    overlap: int = 128
    photo_context: bool = True
    context_every: int = 5


#: The groups of :class:`TrainConfig`, by attribute name (``post`` is the runtime's own :class:`PostProcess`); each is
#: frozen, so copies of a config never share a mutable group (change one with :func:`resolve` or ``dataclasses.replace``).
GROUPS: Dict[str, type] = {"optim": Optimisation, "losses": Losses, "photo": PhotoModel, "monitor": Monitoring,
                           "guard": Guard, "predict": Prediction, "post": PostProcess}

#: Flat names of the settings as checkpoints, ``refine`` records and overrides before the groups named them
#: (``TrainConfig.to_dict()`` was one flat dict) -> their dotted names now. Read by :meth:`TrainConfig.from_dict`,
#: :func:`resolve` and :func:`setting_name`.
FLAT_NAMES: Dict[str, str] = {
    **{n: f"optim.{n}" for n in ("tile", "nr_updates", "ds_updates", "d_updates", "schedule", "lr", "betas",
                                 "camera_lr", "gan_steps", "iters_pretrain", "iters_finetune", "iters_fit", "seed",
                                 "bf16", "reset_optimizers")},
    "lambda_gan": "losses.gan", "lambda_fourier": "losses.fourier", "fourier_mode": "losses.fourier_mode",
    "lambda_perceptual": "losses.perceptual", "perceptual": "losses.perceptual_backend",
    "vgg_weights": "losses.vgg_weights", "perceptual_min_clipped": "losses.perceptual_min_clipped",
    "lambda_diffuse": "losses.diffuse", "diffuse_target": "losses.diffuse_target", "lambda_render": "losses.render",
    "lambda_flash": "losses.flash", "lambda_specular_prior": "losses.specular_prior",
    "lambda_anchor": "losses.anchor", "anchor_maps": "losses.anchor_maps",
    **{n: f"photo.{n}" for n in ("saturate", "learn_vignetting", "learn_offsets", "flash_position")},
    **{n: f"monitor.{n}" for n in ("checkpoint_every", "maps_every", "eval_every", "eval_tiles", "quality",
                                   "plateau_window", "plateau_render_tol")},
    "guard_rollback_after": "guard.rollback_after", "guard_snapshot_every": "guard.snapshot_every",
    "predict_max_side": "predict.max_side", "predict_overlap": "predict.overlap",
    "photo_context": "predict.photo_context", "context_every": "predict.context_every",
    **{n: f"post.{n}" for n in POST_FIELDS},
    "train_encoder": "generator.train_encoder", "fov_deg": "render.fov_deg",
}

#: Settings of earlier versions that checkpoints may still carry; ignored when read.
RETIRED_SETTINGS = frozenset({"plateau_change_tol"})


@dataclass
class TrainConfig:
    """Training settings, grouped (JSON-safe through :meth:`to_dict` / :meth:`from_dict`).

    Attributes:
        preset: name of the preset these settings started from (informative).
        generator: generator architecture (``train_encoder`` lives there: a frozen random encoder by default).
        discriminator: PatchGAN architecture.
        render: :class:`~svbrdf.runtime.core.render.RenderConfig` as a dict (see :attr:`render_config`): the
            renderer of the photo terms.
        optim: :class:`Optimisation` (tiles, schedule, Adam, iterations, seed, bf16).
        losses: :class:`Losses` (weights and options of every term).
        photo: :class:`PhotoModel` (the camera model of the photo terms).
        post: what is done around the generator, as the runtime does it (:class:`svbrdf.runtime.post.PostProcess`;
            :data:`NO_POST` by default). ``post.even_lighting``: the generator sees the photo divided by its own
            smooth lighting (a low pass of this width, a fraction of the photo width) in training and prediction,
            the losses compare with the photo itself (0: the photo); the map corrections apply to the final maps
            of :meth:`svbrdf.trainer.train.Trainer.predict_maps` (:func:`svbrdf.runtime.post.apply`).
        monitor: :class:`Monitoring` (checkpoints, map dumps, progress signal, ``quality="auto"``).
        guard: :class:`Guard` (the non-finite step guard).
        predict: :class:`Prediction` (tiled prediction, the U-Net's photo context).

    Every setting has one dotted name (``losses.fourier``, ``post.even_lighting``): :meth:`flat_dict`, :func:`resolve`,
    ``--set``. The flat names of earlier records are :data:`FLAT_NAMES`.
    """

    preset: str = "paper"
    generator: GeneratorConfig = field(default_factory=lambda: dataclasses.replace(MODEL_PRESETS["paper"]))
    discriminator: DiscriminatorConfig = field(default_factory=lambda: dataclasses.replace(DISC_PRESETS["paper"]))
    render: Dict[str, Any] = field(default_factory=ZHAO.to_dict)
    optim: Optimisation = field(default_factory=Optimisation)
    losses: Losses = field(default_factory=Losses)
    photo: PhotoModel = field(default_factory=PhotoModel)
    post: PostProcess = field(default_factory=lambda: NO_POST)
    monitor: Monitoring = field(default_factory=Monitoring)
    guard: Guard = field(default_factory=Guard)
    predict: Prediction = field(default_factory=Prediction)

    def __post_init__(self) -> None:
        for name, cls in GROUPS.items():
            if not isinstance(getattr(self, name), cls):
                raise ValueError(f"{name} must be a {cls.__name__}, got {type(getattr(self, name)).__name__}")
        if self.post.even_lighting is None:  # the runtime's "photo as it is"; 0 here, one value per meaning
            self.post = self.post.replace(even_lighting=0.0)
        self.validate()

    @property
    def render_config(self) -> RenderConfig:
        return RenderConfig(**self.render)

    @property
    def train_encoder(self) -> bool:
        return bool(self.generator.train_encoder)

    @property
    def even_lighting(self) -> float:
        """The width the generator's input is evenly lit at (``post.even_lighting``; 0: the photo as it is)."""
        return float(self.post.even_lighting or 0.0)

    @property
    def needs_anchor(self) -> bool:
        """Whether a fine-tune keeps its starting maps (the anchor): for ``losses.anchor``."""
        return self.losses.anchor > 0

    def iters(self, stage: str) -> int:
        """Iterations of ``stage`` ("pretrain", "finetune" or "fit")."""
        if stage not in STAGES:
            raise ValueError(f"unknown stage {stage!r}; expected one of {', '.join(STAGES)}")
        return getattr(self.optim, f"iters_{stage}")

    @property
    def min_tile(self) -> int:
        """Smallest training tile (and photo side), px: the discriminator's last instance norm sees
        ``tile // 2**n_layers`` px per side and needs at least 2; VGG-19 needs 16."""
        return max(16, 2 ** (self.discriminator.n_layers + 1))

    def validate(self) -> None:
        """Raise ValueError on an inconsistent setting (the one place settings are checked)."""
        def need(ok: bool, msg: str) -> None:
            if not ok:
                raise ValueError(msg)

        o, ls, m, pr = self.optim, self.losses, self.monitor, self.predict
        need(o.tile >= self.min_tile, f"optim.tile must be >= {self.min_tile} px, got {o.tile}")
        for group, name in (("optim", "nr_updates"), ("optim", "ds_updates"), ("optim", "d_updates"),
                            ("optim", "iters_pretrain"), ("optim", "iters_finetune"), ("optim", "iters_fit"),
                            ("optim", "gan_steps"), ("monitor", "checkpoint_every"), ("monitor", "maps_every"),
                            ("monitor", "eval_every")):
            value = getattr(getattr(self, group), name)
            need(value >= 0, f"{group}.{name} must be >= 0, got {value}")
        need(o.lr > 0 and o.camera_lr > 0, f"optim.lr and optim.camera_lr must be > 0, got {o.lr}, {o.camera_lr}")
        need(len(o.betas) == 2 and all(0 <= b < 1 for b in o.betas), f"optim.betas must be two values in [0, 1), "
             f"got {o.betas}")
        for name in ("gan", "fourier", "perceptual", "render", "flash", "specular_prior", "anchor", "diffuse"):
            need(getattr(ls, name) >= 0, f"losses.{name} must be >= 0, got {getattr(ls, name)}")
        need(len(ls.anchor_maps) > 0 and set(ls.anchor_maps) <= set(MAP_NAMES),
             f"losses.anchor_maps must be some of {', '.join(MAP_NAMES)}, got {list(ls.anchor_maps)}")
        need(0 <= ls.perceptual_min_clipped <= 1,
             f"losses.perceptual_min_clipped must be in [0, 1], got {ls.perceptual_min_clipped}")
        need(ls.fourier_mode in FOURIER_MODES, f"losses.fourier_mode must be one of {FOURIER_MODES}, "
             f"got {ls.fourier_mode!r}")
        need(ls.perceptual_backend in PERCEPTUAL_BACKENDS, f"losses.perceptual_backend must be one of "
             f"{PERCEPTUAL_BACKENDS}, got {ls.perceptual_backend!r}")
        need(ls.diffuse_target in DIFFUSE_TARGETS, f"losses.diffuse_target must be one of {DIFFUSE_TARGETS}, "
             f"got {ls.diffuse_target!r}")
        need(o.schedule in SCHEDULES, f"optim.schedule must be one of {SCHEDULES}, got {o.schedule!r}")
        need(o.schedule != "joint" or (o.nr_updates, o.ds_updates, o.d_updates) == (1, 1, 1),
             "optim.schedule 'joint' needs nr_updates = ds_updates = d_updates = 1")
        need(m.quality in QUALITY_MODES, f"monitor.quality must be one of {QUALITY_MODES}, got {m.quality!r}")
        need(m.eval_tiles >= 1 and m.plateau_window >= 1, "monitor.eval_tiles and monitor.plateau_window must be >= 1")
        need(m.quality == "fixed" or m.eval_every > 0, "monitor.quality 'auto' needs monitor.eval_every > 0")
        need(self.guard.rollback_after >= 1 and self.guard.snapshot_every >= 1,
             "guard.rollback_after and guard.snapshot_every must be >= 1")
        fp = self.photo.flash_position
        need(fp is None or (len(fp) == 2 and all(math.isfinite(v) for v in fp)),
             f"photo.flash_position must be two finite numbers (x, y), got {fp}")
        need(pr.context_every >= 1, f"predict.context_every must be >= 1, got {pr.context_every}")
        need(pr.max_side >= 8 and 0 <= 2 * pr.overlap <= pr.max_side,
             "predict.max_side must be >= 8 and predict.overlap in [0, predict.max_side / 2]")
        RenderConfig(**self.render)  # validates the renderer settings

    def to_dict(self) -> Dict[str, Any]:
        """JSON-safe nested dict: one dict per group and sub-config, tuples as lists."""
        def plain(v: Any) -> Any:
            if isinstance(v, tuple):
                return list(v)
            if isinstance(v, dict):
                return {k: plain(x) for k, x in v.items()}
            return v

        out: Dict[str, Any] = {"preset": self.preset, "generator": self.generator.to_dict(),
                               "discriminator": self.discriminator.to_dict(), "render": dict(self.render)}
        for name in GROUPS:
            out[name] = {f.name: plain(getattr(getattr(self, name), f.name)) for f in fields(GROUPS[name])}
        return out

    def flat_dict(self) -> Dict[str, Any]:
        """:meth:`to_dict` with one dotted name per setting of a group (``losses.fourier``); ``generator``,
        ``discriminator`` and ``render`` stay dicts."""
        return flat_settings(self.to_dict())

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "TrainConfig":
        """Inverse of :meth:`to_dict` and of :meth:`flat_dict`; also reads the flat dicts of earlier checkpoints and
        records (:data:`FLAT_NAMES`; :data:`RETIRED_SETTINGS` are dropped). Missing settings take the defaults
        (``post``'s: :data:`NO_POST`'s); unknown ones raise ValueError."""
        nested = nested_settings(d)
        kw: Dict[str, Any] = {}
        if "preset" in nested:
            kw["preset"] = nested.pop("preset")
        for name, conf in (("generator", GeneratorConfig), ("discriminator", DiscriminatorConfig)):
            if name in nested:
                given = nested.pop(name)
                kw[name] = given if isinstance(given, conf) else conf.from_dict(given)
        for name, group in GROUPS.items():
            given = nested.pop(name, {})
            base = dataclasses.asdict(NO_POST) if group is PostProcess else {}
            unknown = sorted(set(given) - {f.name for f in fields(group)})
            if unknown:
                raise ValueError(f"unknown training settings: {', '.join(f'{name}.{k}' for k in unknown)}")
            kw[name] = group(**{**base, **given})
        if "render" in nested:
            kw["render"] = RenderConfig(**nested.pop("render")).to_dict()
        if nested:
            raise ValueError(f"unknown training settings: {', '.join(sorted(nested))}")
        return cls(**kw)


def _as_mapping(value: Any) -> Any:
    """A sub-config or group given as an object -> its settings by name; anything else as it is."""
    if isinstance(value, (GeneratorConfig, DiscriminatorConfig, RenderConfig)):
        return value.to_dict()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: getattr(value, f.name) for f in fields(value)}
    return value


@dataclass(frozen=True)
class SettingsLayout:
    """How a settings class names its settings, one dotted name each (:class:`TrainConfig`,
    :class:`svbrdf.trainer.prior.config.PriorConfig`).

    Attributes:
        kind: what the settings are, in errors ("unknown training settings: ...").
        groups: the groups by attribute name (``losses`` -> ``losses.<field>``).
        components: the other top-level names; those in ``scalars`` are values, the others sub-configs (mappings of
            their fields, or their objects).
        scalars: the top-level names whose value is taken as it is (``preset``).
        flat_names: flat names of earlier records -> dotted names.
        retired: names of earlier records that are dropped when read.
    """

    kind: str
    groups: Mapping[str, type]
    components: Tuple[str, ...]
    scalars: Tuple[str, ...]
    flat_names: Mapping[str, str]
    retired: frozenset = frozenset()

    def name(self, key: str) -> str:
        """The dotted name of ``key``: a flat name of an earlier record -> its dotted name; any other unchanged."""
        return self.flat_names.get(key, key)

    def put(self, out: Dict[str, Any], name: str, value: Any) -> None:
        """Set dotted ``name`` in nested ``out``; a mapping given for a group or sub-config is merged field by
        field."""
        head, _, rest = name.partition(".")
        if head not in self.groups and head not in self.components:
            raise ValueError(f"unknown {self.kind} settings: {name}")
        if not rest:
            value = _as_mapping(value)
            if head in self.scalars:
                out[head] = value
                return
            if not isinstance(value, Mapping):
                raise ValueError(f"{head} must be a mapping of its settings, got {value!r}")
            for k, v in value.items():
                self.put(out, f"{head}.{k}", v)
            return
        if head in self.scalars:
            raise ValueError(f"unknown {self.kind} settings: {name}")
        sub = out.setdefault(head, {})
        if not isinstance(sub, dict):
            raise ValueError(f"{head} must be a mapping of its settings, got {sub!r}")
        sub[rest] = value

    def nested(self, d: Mapping[str, Any]) -> Dict[str, Any]:
        """Settings by any of their names (nested groups, dotted names, flat names of earlier records) as one nested
        dict, later entries over earlier ones. Raises ValueError for a name that is none of those."""
        out: Dict[str, Any] = {}
        for key, value in d.items():
            if key in self.retired:
                continue
            self.put(out, self.name(key), value)
        return out

    def flat(self, d: Mapping[str, Any]) -> Dict[str, Any]:
        """Settings (any form :meth:`nested` reads) as one dotted name per setting of a group; the components keep
        their values (sub-configs as dicts)."""
        out: Dict[str, Any] = {}
        for key, value in self.nested(d).items():
            if key in self.groups:
                out.update({f"{key}.{k}": v for k, v in value.items()})
            else:
                out[key] = value
        return out


#: The top-level names of :class:`TrainConfig` that are not a group.
COMPONENTS = ("preset", "generator", "discriminator", "render")
#: How :class:`TrainConfig` names its settings.
LAYOUT = SettingsLayout("training", GROUPS, COMPONENTS, ("preset",), FLAT_NAMES, RETIRED_SETTINGS)


def setting_name(key: str) -> str:
    """The dotted name of a training setting: a flat name of an earlier record or override (:data:`FLAT_NAMES`,
    e.g. ``lambda_fourier`` -> ``losses.fourier``, a post-processing field's bare name -> ``post.<field>``); any
    other name unchanged."""
    return LAYOUT.name(key)


def nested_settings(d: Mapping[str, Any]) -> Dict[str, Any]:
    """Settings by any of their names (nested groups as :meth:`TrainConfig.to_dict` gives them, dotted names,
    the flat names of :data:`FLAT_NAMES`) as one nested dict, later entries over earlier ones. Raises ValueError
    for a name that is none of those."""
    return LAYOUT.nested(d)


def flat_settings(d: Mapping[str, Any]) -> Dict[str, Any]:
    """Settings (any form :func:`nested_settings` reads) as one dotted name per setting of a group
    (``losses.fourier``, ``post.even_lighting``), as overrides, ``--set`` and ``refine`` records name them;
    ``preset``, ``generator``, ``discriminator`` and ``render`` keep their values (dicts)."""
    return LAYOUT.flat(d)


def _preset(name: str, model: str, settings: Mapping[str, Any] = ()) -> TrainConfig:
    """Preset ``name``: the defaults with the architecture of model preset ``model`` and ``settings`` (dotted)."""
    return TrainConfig.from_dict({"preset": name, "generator": MODEL_PRESETS[model].to_dict(),
                                  "discriminator": DISC_PRESETS[model].to_dict(), **dict(settings)})


#: The fast model's schedule with the paper's losses (``fast-v1``).
_FAST_V1 = {"optim.tile": 128, "optim.nr_updates": 1, "optim.ds_updates": 1, "optim.d_updates": 1,
            "optim.schedule": "joint", "optim.lr": 1e-4, "optim.bf16": True, "optim.iters_pretrain": 6000,
            "optim.iters_finetune": 600, "optim.iters_fit": 6000,
            "losses.perceptual_backend": "pyramid", "losses.perceptual_min_clipped": 5e-5,
            "monitor.eval_every": 50, "monitor.checkpoint_every": 250, "monitor.maps_every": 0}
#: The highlight-free flash model and losses of ``fast`` (docs/decisions/021-fast-highlight-free.md): inverse-square
#: fall-off, learned vignetting, renderings clipped like the photo, the re-render and flash-correlation terms (weight 1:
#: at 100 real photos collapsed), a scale-free L_d, learned output offsets, the dielectric specular prior, no Fourier
#: term; the final maps lose their radial trend (``post.flash_trend``) and keep one specular level
#: (``post.uniform_specular``, docs/decisions/005-uniform-specular.md).
_HIGHLIGHT_FREE = {"render": ZHAO.replace(falloff=True).to_dict(), "photo.saturate": True,
                   "photo.learn_vignetting": True, "photo.learn_offsets": True,
                   "losses.render": 1.0, "losses.flash": 1.0, "losses.specular_prior": 1.0, "losses.fourier": 0.0,
                   "losses.diffuse_target": "normalized",
                   "post.flash_trend": True, "post.uniform_specular": True}
#: ``fast``: 150 fine-tune iterations (docs/decisions/023-stage-one-v2.md), the normal map pulled towards the stage
#: one's (docs/decisions/021-fast-highlight-free.md), the GAN for those 150 iterations only
#: (docs/decisions/020-fast-schedule.md), the clipped highlight filled (docs/decisions/006-highlight-fill.md), the
#: generator shown the photo evenly lit at the preview's width (docs/decisions/024-refine-recipe-v2.md).
_FAST = {**_FAST_V1, **_HIGHLIGHT_FREE, "optim.iters_finetune": 150, "losses.anchor": 3.0,
         "losses.anchor_maps": ("normal",), "optim.gan_steps": 150, "post.highlight_fill": True,
         "post.even_lighting": EVEN_LIGHTING_WIDTH}


def _presets() -> Dict[str, TrainConfig]:
    return {
        "paper": _preset("paper", "paper"),
        "zhao": _preset("zhao", "paper", {"losses.fourier": 0.0, "losses.perceptual": 0.0}),
        "fast": _preset("fast", "fast", _FAST),
        "fast-v1": _preset("fast-v1", "fast", _FAST_V1),
        "fast-no-fourier": _preset("fast-no-fourier", "fast", {**_FAST_V1, "losses.fourier": 0.0}),
        "fast-no-perceptual": _preset("fast-no-perceptual", "fast", {**_FAST_V1, "losses.perceptual": 0.0}),
        "fast-zhao": _preset("fast-zhao", "fast", {**_FAST_V1, "losses.fourier": 0.0, "losses.perceptual": 0.0}),
        "fast-alternating": _preset("fast-alternating", "fast", {**_FAST, "optim.schedule": "alternating"}),
        "tiny": _preset("tiny", "tiny", {
            "optim.tile": 32, "optim.nr_updates": 1, "optim.ds_updates": 1, "optim.d_updates": 1, "optim.lr": 1e-3,
            "optim.iters_pretrain": 20, "optim.iters_finetune": 10, "optim.iters_fit": 20,
            "losses.perceptual_backend": "pyramid", "monitor.checkpoint_every": 10, "monitor.maps_every": 0,
            "monitor.eval_every": 5, "monitor.eval_tiles": 2, "monitor.plateau_window": 3,
            "guard.snapshot_every": 5, "predict.max_side": 64, "predict.overlap": 8}),
    }


#: The named starting points of :func:`resolve` (what each is: :data:`PRESET_DESCRIPTIONS`). Copies are handed out.
TRAIN_PRESETS: Dict[str, TrainConfig] = _presets()

#: Fine-tune settings measured for one stage one, by name: :func:`svbrdf.trainer.checkpoint.clean_checkpoint`
#: (``refine=NAME``) records them in the stage one's checkpoint (``refine``), and every fine-tune from it with a preset
#: that shows the generator an evenly lit photo (``fast``) takes them where the user left the preset's value
#: (:func:`svbrdf.trainer.stage.finetune_config`). ``"v2"``: no dielectric specular prior, every map pulled to the
#: stage one's. Decision: docs/decisions/024-refine-recipe-v2.md.
REFINE_RECIPES: Dict[str, Dict[str, Any]] = {
    "v2": {"losses.specular_prior": 0.0, "losses.anchor": 1.0, "losses.anchor_maps": list(MAP_NAMES)},
}

#: What each preset is, one line each (``svbrdf-train --help`` prints those of :data:`CLI_PRESETS`). Their costs per
#: iteration on a CPU: docs/decisions/020-fast-schedule.md.
PRESET_DESCRIPTIONS: Dict[str, str] = {
    "paper": "the published setup (Wen et al. 2022): paper-size generator and PatchGAN, 256 px tiles, 5 + 1 + 1 "
             "alternating updates, 0.1 GAN + L_d + 0.1 Fourier + 0.2 perceptual; a GPU job.",
    "zhao": "paper without the Fourier and perceptual losses (Zhao et al. 2020's objective).",
    "fast": "the default: quarter-width networks, 128 px tiles, one joint update, the highlight-free flash model; "
            "150 iterations from the stage one.",
    "fast-v1": "fast with the paper's losses and flash model (the comparison point).",
    "fast-alternating": "fast with the published alternating sub-steps: an ablation of fast's schedule.",
    "fast-no-fourier": "fast-v1 without the Fourier loss: an ablation of the paper's losses.",
    "fast-no-perceptual": "fast-v1 without the perceptual loss: an ablation of the paper's losses.",
    "fast-zhao": "fast-v1 without the Fourier and perceptual losses: an ablation of the paper's losses.",
    "tiny": "toy networks for tests (32 px tiles, 20 iterations).",
}
#: The benchmark's ablations: resolvable like the others (``svbrdf-bench --presets``, checkpoints that record
#: them, :func:`resolve`) but not offered by ``svbrdf-train --preset``.
BENCH_PRESETS: Tuple[str, ...] = ("fast-alternating", "fast-no-fourier", "fast-no-perceptual", "fast-zhao")
#: The presets ``svbrdf-train --preset`` offers, in the order its help describes them.
CLI_PRESETS: Tuple[str, ...] = tuple(n for n in TRAIN_PRESETS if n not in BENCH_PRESETS)



def resolve(preset: str = "paper", **overrides: Any) -> TrainConfig:
    """A copy of preset ``preset`` with ``overrides`` applied.

    Overrides name settings by their dotted names (``**{"losses.fourier": 0.5}``), by the flat names of earlier
    records (:data:`FLAT_NAMES`: ``lambda_fourier=0.5``, ``train_encoder``, ``fov_deg``, a post-processing field's
    bare name) or as a whole group or sub-config (``post=PostProcess(...)`` or a dict of some of its fields: applied
    field by field; ``render=RenderConfig(...)``); ``None`` values are ignored (CLI flags left unset).

    Raises:
        ValueError: unknown preset, unknown setting or invalid value.
    """
    if preset not in TRAIN_PRESETS:
        raise ValueError(f"unknown preset {preset!r}; expected one of {', '.join(TRAIN_PRESETS)}")
    d = TRAIN_PRESETS[preset].to_dict()
    for key, value in overrides.items():
        if value is None:
            continue
        LAYOUT.put(d, setting_name(key), value)
    return TrainConfig.from_dict(d)


def parse_settings(items: Iterable[str]) -> Dict[str, Any]:
    """Training settings as command lines give them (``--set``, ``before_after``'s presets):
    ``["optim.lr=1e-4", "post.even_lighting=0", "perceptual=pyramid"]`` -> ``{"optim.lr": 0.0001,
    "post.even_lighting": 0, "perceptual": "pyramid"}`` (values read as JSON, else kept as strings; the names, dotted
    or the flat ones of :data:`FLAT_NAMES`, are checked by :func:`resolve`, not here).

    Raises:
        ValueError: an item without ``=`` or without a name (``"'x': expected KEY=VALUE"``).
    """
    out: Dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key:
            raise ValueError(f"{item!r}: expected KEY=VALUE")
        try:
            out[key] = json.loads(text)
        except ValueError:
            out[key] = text
    return out


__all__ = ["TrainConfig", "Optimisation", "Losses", "PhotoModel", "Monitoring", "Guard", "Prediction", "GROUPS",
           "FLAT_NAMES", "COMPONENTS", "LAYOUT", "SettingsLayout", "NO_POST", "POST_FIELDS", "setting_name",
           "nested_settings", "flat_settings", "parse_settings", "TRAIN_PRESETS", "REFINE_RECIPES", "PRESET_DESCRIPTIONS", "BENCH_PRESETS", "CLI_PRESETS",
           "resolve", "STAGES", "FOURIER_MODES", "PERCEPTUAL_BACKENDS", "QUALITY_MODES", "SCHEDULES"]
