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
class TrainConfig:
    """Training settings (JSON-safe through :meth:`to_dict` / :meth:`from_dict`).

    Attributes:
        preset: name of the preset these settings started from (informative).
        generator: generator architecture (``train_encoder`` lives there: a frozen random encoder by default).
        discriminator: PatchGAN architecture.
        tile: side of the random square training tiles, pixels (clipped to the photo).
        nr_updates, ds_updates, d_updates: optimiser steps per iteration of the normal/roughness decoder,
            the diffuse/specular decoder (plus the encoder if trained) and the discriminator, each on a
            fresh random tile (``schedule="alternating"``).
        schedule: "alternating" (the published schedule above: every sub-step runs the generator on its own
            tile) or "joint" (needs 1:1:1): one tile per iteration, one generator pass with both decoders
            trained by one backward pass of ``L_GAN + L_d + L_F + L_P`` (the gradient each decoder receives is
            that of its own published loss, since L_d does not depend on the normal/roughness decoder), then
            the discriminator step on the same tile and the rendering already made. Same losses, two generator
            passes per iteration instead of three (``git show 0b5a711:./trainer/bench/speed.py``, ``--variants
            alternating,joint``).
        lr, betas: Adam settings shared by the three optimisers.
        lambda_gan: weight of the generator GAN term in both decoder losses.
        gan_steps: the GAN (the generator's term and the discriminator's update) runs for the first ``gan_steps``
            iterations of a run only, then the run goes on without it (0 = every iteration, as in the paper). The
            GAN term is what makes a fine-tune's maps drift after its first 150 iterations
            (docs/decisions/020-fast-schedule.md); without it the later iterations are also faster.
        lambda_fourier: weight of the Fourier loss L_F (0 = off); ``fourier_mode``: "complex" | "magnitude".
        lambda_perceptual: weight of the perceptual loss L_P (0 = off); ``perceptual``: its backend;
            ``vgg_weights``: optional VGG-19 state-dict file.
        diffuse_target: "absolute" (the paper's L_d) or "normalized" (L_d on standardised tiles: the guessed
            diffuse gives the pattern, not the level; :func:`svbrdf.trainer.losses.diffuse_loss`).
        lambda_diffuse: weight of L_d (1 = the paper's; 0 = off: the diffuse map is then shaped by the photo terms
            and the anchor alone).
        lambda_render: weight of the per-pixel re-render loss (:func:`svbrdf.trainer.losses.render_loss`; 0 = off,
            as in the paper).
        lambda_specular_prior: weight of the dielectric prior on the specular albedo
            (:func:`svbrdf.trainer.losses.specular_prior_loss`; 0 = off, as in the paper).
        lambda_anchor: weight of the pull of a fine-tune towards its starting point: the initial checkpoint's
            prediction of the whole photo (the preview), compared per map as the prior is trained
            (:func:`svbrdf.trainer.losses.supervised_maps_loss`); keeps what the photo does not constrain where a
            learned stage one put it (0 = off, as in the paper; only a fine-tune has a starting point).
        anchor_maps: the maps that pull (names of :data:`svbrdf.runtime.core.maps.MAP_NAMES`, each with its
            :data:`~svbrdf.trainer.losses.SUPERVISED_WEIGHTS` weight); the others are left to the photo.
        lambda_flash: weight of the flash-correlation stationarity loss on both decoders
            (:func:`svbrdf.trainer.losses.flash_correlation_loss`; 0 = off, as in the paper).
        learn_vignetting: fit the photo's vignetting (a darkening ``1 - v r^2`` towards the corners, one scalar
            ``v = 0.9 sigmoid(t)`` per photo, starting at 0.05) as part of the flash model of the photo terms, so
            a radial darkening the maps must not explain is not painted into them.
        learn_offsets: train the generator's six pre-tanh output offsets
            (:attr:`svbrdf.trainer.models.Generator.out_offset`) at ``camera_lr``: the level of each map (and the
            normal strength) can then move within a fine-tune even where the tanh output is saturated.
        camera_lr: learning rate (own Adam) of the learned camera and of the output offsets.
        post: what is done around the generator, as the runtime does it (:class:`svbrdf.runtime.post.PostProcess`,
            the runtime's own type; :data:`NO_POST` by default, as in the paper). ``post.even_lighting``: the
            generator sees the photo divided by its own smooth lighting
            (:attr:`svbrdf.runtime.post.PostProcess.even_lighting`: a low pass of this width, a fraction of the photo
            width) in training and prediction, while the losses compare its renderings with the photo itself (0: the
            photo). The map corrections (the photo's colour balance, the highlight fill, the flash-trend removal, one
            specular level) apply to the final maps of :meth:`svbrdf.trainer.train.Trainer.predict_maps`
            (:func:`svbrdf.runtime.post.apply`), as the preview applies them to its own. Overrides and records name
            them ``post.<field>`` or, as before this field existed, by the field's name alone (:func:`resolve`,
            :meth:`from_dict`).
        flash_position: where the flash (with the camera, co-located) is over the photo, (x, y) in the renderer's
            units (:func:`svbrdf.runtime.core.render.plane_positions`: x right, y up, 1 = half the photo width), at the
            render config's camera distance; None = above the photo's centre (the paper's geometry).
        saturate: the camera model of the photo terms: renderings are clipped to [0, 1] before the
            discriminator, the perceptual loss and the progress signal, as the photo was by the sensor
            (False: the paper's unclipped renderings).
        perceptual_min_clipped: photos with a smaller fraction of clipped pixels
            (:func:`svbrdf.trainer.losses.clipped_fraction`) train without L_P (0 = never skipped). ``fast``:
            5e-5, i.e. photos without a saturated highlight, where L_P brought no gain for 21 % of the time
            (docs/decisions/021-fast-highlight-free.md); L_F is kept there: it lowered error and burn-in.
        iters_pretrain, iters_finetune, iters_fit: iterations of each stage.
        seed: seeds weights and the tile sequence.
        bf16: bfloat16 autocast around the networks (falls back to fp32 where unsupported).
        render: :class:`~svbrdf.runtime.core.render.RenderConfig` as a dict (see :attr:`render_config`).
        checkpoint_every: iterations between checkpoints (0 = only at the end).
        maps_every: iterations between full-photo map dumps by the CLI (0 = only at the end).
        reset_optimizers: finetune with fresh Adam states instead of the pretrained ones.
        eval_every, eval_tiles: cadence and number of fixed tiles of the label-free progress signal
            (re-render L1 vs the photo, mean map change between evaluations); 0 = off.
        quality: "fixed" (run all iterations) or "auto" (stop early when the re-render L1 stops improving).
        plateau_window, plateau_render_tol: the ``quality="auto"`` rule
            (:meth:`svbrdf.trainer.train.Trainer.plateaued`): stop when the best re-render L1 of the last
            ``plateau_window`` evaluations is not ``plateau_render_tol`` (relative) below the best before them.
        guard_rollback_after: consecutive non-finite optimiser steps before rolling back to the last good
            in-memory snapshot; ``guard_snapshot_every``: iterations between snapshots.
        predict_max_side: photos with a longer side are predicted in overlapping tiles of this size;
            ``predict_overlap``: their overlap.
        photo_context: a U-Net generator (``generator.arch="unet"``) sees every training tile and every
            prediction tile with the whole photo's flash spot and global vectors
            (:class:`svbrdf.trainer.models.PhotoContext`), so what it learns on tiles is what it predicts for the
            whole photo; refreshed (without gradient) every ``context_every`` iterations (5: 1.12x the time of an
            iteration without the context, 1: 1.43x, the same maps on held-out procedural materials,
            docs/decisions/066-unet-photo-context.md). No effect on ``"wen"``.
    """

    preset: str = "paper"
    generator: GeneratorConfig = field(default_factory=lambda: dataclasses.replace(MODEL_PRESETS["paper"]))
    discriminator: DiscriminatorConfig = field(default_factory=lambda: dataclasses.replace(DISC_PRESETS["paper"]))
    tile: int = 256
    nr_updates: int = 5
    ds_updates: int = 1
    d_updates: int = 1
    schedule: str = "alternating"
    lr: float = 2e-5
    betas: Tuple[float, float] = (0.0, 0.9)
    lambda_gan: float = 0.1
    gan_steps: int = 0
    lambda_fourier: float = 0.1
    fourier_mode: str = "complex"
    lambda_perceptual: float = 0.2
    perceptual: str = "auto"
    vgg_weights: Optional[str] = None
    perceptual_min_clipped: float = 0.0
    diffuse_target: str = "absolute"
    lambda_diffuse: float = 1.0
    lambda_render: float = 0.0
    lambda_flash: float = 0.0
    lambda_specular_prior: float = 0.0
    lambda_anchor: float = 0.0
    anchor_maps: Tuple[str, ...] = MAP_NAMES
    saturate: bool = False
    learn_vignetting: bool = False
    learn_offsets: bool = False
    camera_lr: float = 5e-3
    post: PostProcess = field(default_factory=lambda: NO_POST)
    flash_position: Optional[Tuple[float, float]] = None
    iters_pretrain: int = 10000
    iters_finetune: int = 3000
    iters_fit: int = 20000
    seed: int = 24
    bf16: bool = False
    render: Dict[str, Any] = field(default_factory=ZHAO.to_dict)
    checkpoint_every: int = 500
    maps_every: int = 500
    reset_optimizers: bool = False
    eval_every: int = 100
    eval_tiles: int = 4
    quality: str = "fixed"
    plateau_window: int = 4
    plateau_render_tol: float = 0.05
    guard_rollback_after: int = 5
    guard_snapshot_every: int = 50
    predict_max_side: int = 1024
    predict_overlap: int = 128
    photo_context: bool = True
    context_every: int = 5

    def __post_init__(self) -> None:
        self.betas = tuple(float(b) for b in self.betas)
        self.anchor_maps = tuple(self.anchor_maps)
        if self.flash_position is not None:
            self.flash_position = tuple(float(v) for v in self.flash_position)
        if not isinstance(self.post, PostProcess):
            raise ValueError(f"post must be a PostProcess, got {type(self.post).__name__}")
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
        """Whether a fine-tune keeps its starting maps (the anchor): for ``lambda_anchor``."""
        return self.lambda_anchor > 0

    def iters(self, stage: str) -> int:
        """Iterations of ``stage`` ("pretrain", "finetune" or "fit")."""
        if stage not in STAGES:
            raise ValueError(f"unknown stage {stage!r}; expected one of {', '.join(STAGES)}")
        return getattr(self, f"iters_{stage}")

    @property
    def min_tile(self) -> int:
        """Smallest training tile (and photo side), px: the discriminator's last instance norm sees
        ``tile // 2**n_layers`` px per side and needs at least 2; VGG-19 needs 16."""
        return max(16, 2 ** (self.discriminator.n_layers + 1))

    def validate(self) -> None:
        """Raise ValueError on an inconsistent setting."""
        def need(ok: bool, msg: str) -> None:
            if not ok:
                raise ValueError(msg)

        need(self.tile >= self.min_tile, f"tile must be >= {self.min_tile} px, got {self.tile}")
        for name in ("nr_updates", "ds_updates", "d_updates", "iters_pretrain", "iters_finetune", "iters_fit",
                     "checkpoint_every", "maps_every", "eval_every", "gan_steps"):
            need(getattr(self, name) >= 0, f"{name} must be >= 0, got {getattr(self, name)}")
        need(self.lr > 0 and self.camera_lr > 0, f"lr and camera_lr must be > 0, got {self.lr}, {self.camera_lr}")
        need(len(self.betas) == 2 and all(0 <= b < 1 for b in self.betas), f"betas must be two values in [0, 1), "
             f"got {self.betas}")
        for name in ("lambda_gan", "lambda_fourier", "lambda_perceptual", "lambda_render", "lambda_flash",
                     "lambda_specular_prior", "lambda_anchor", "lambda_diffuse"):
            need(getattr(self, name) >= 0, f"{name} must be >= 0, got {getattr(self, name)}")
        need(len(self.anchor_maps) > 0 and set(self.anchor_maps) <= set(MAP_NAMES),
             f"anchor_maps must be some of {', '.join(MAP_NAMES)}, got {list(self.anchor_maps)}")
        need(0 <= self.perceptual_min_clipped <= 1,
             f"perceptual_min_clipped must be in [0, 1], got {self.perceptual_min_clipped}")
        need(self.fourier_mode in FOURIER_MODES, f"fourier_mode must be one of {FOURIER_MODES}, "
             f"got {self.fourier_mode!r}")
        need(self.perceptual in PERCEPTUAL_BACKENDS, f"perceptual must be one of {PERCEPTUAL_BACKENDS}, "
             f"got {self.perceptual!r}")
        need(self.diffuse_target in DIFFUSE_TARGETS, f"diffuse_target must be one of {DIFFUSE_TARGETS}, "
             f"got {self.diffuse_target!r}")
        need(self.schedule in SCHEDULES, f"schedule must be one of {SCHEDULES}, got {self.schedule!r}")
        need(self.schedule != "joint" or (self.nr_updates, self.ds_updates, self.d_updates) == (1, 1, 1),
             "schedule 'joint' needs nr_updates = ds_updates = d_updates = 1")
        need(self.quality in QUALITY_MODES, f"quality must be one of {QUALITY_MODES}, got {self.quality!r}")
        need(self.eval_tiles >= 1 and self.plateau_window >= 1, "eval_tiles and plateau_window must be >= 1")
        need(self.quality == "fixed" or self.eval_every > 0, "quality 'auto' needs eval_every > 0")
        need(self.guard_rollback_after >= 1 and self.guard_snapshot_every >= 1,
             "guard_rollback_after and guard_snapshot_every must be >= 1")
        need(self.flash_position is None or (len(self.flash_position) == 2
                                              and all(math.isfinite(v) for v in self.flash_position)),
             f"flash_position must be two finite numbers (x, y), got {self.flash_position}")
        need(self.context_every >= 1, f"context_every must be >= 1, got {self.context_every}")
        need(self.predict_max_side >= 8 and 0 <= 2 * self.predict_overlap <= self.predict_max_side,
             "predict_max_side must be >= 8 and predict_overlap in [0, predict_max_side / 2]")
        RenderConfig(**self.render)  # validates the renderer settings

    def to_dict(self) -> Dict[str, Any]:
        """JSON-safe dict (nested configs as dicts, tuples as lists)."""
        out: Dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, (GeneratorConfig, DiscriminatorConfig)):
                v = v.to_dict()
            elif isinstance(v, PostProcess):
                v = dataclasses.asdict(v)
            elif isinstance(v, tuple):
                v = list(v)
            elif isinstance(v, dict):
                v = dict(v)
            out[f.name] = v
        return out

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> "TrainConfig":
        """Inverse of :meth:`to_dict`; unknown keys raise ValueError (:data:`RETIRED_SETTINGS` are dropped), missing
        ones take the defaults. The post-processing settings may also come as ``post.<field>`` or under the field's
        name alone (the records before ``post`` existed): they apply on top of ``post``, whose missing fields are
        :data:`NO_POST`'s."""
        known = {f.name for f in fields(cls)}
        d = _with_post({k: v for k, v in d.items() if k not in RETIRED_SETTINGS})
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"unknown training settings: {', '.join(unknown)}")
        kw = dict(d)
        if "generator" in kw and isinstance(kw["generator"], dict):
            kw["generator"] = GeneratorConfig.from_dict(kw["generator"])
        if "discriminator" in kw and isinstance(kw["discriminator"], dict):
            kw["discriminator"] = DiscriminatorConfig.from_dict(kw["discriminator"])
        if "render" in kw:
            kw["render"] = RenderConfig(**kw["render"]).to_dict()
        return cls(**kw)


def setting_name(key: str) -> str:
    """The name of a training setting as records compare it: a post-processing field's bare name (an old record's
    or override's) -> ``post.<field>``; any other name unchanged."""
    return f"post.{key}" if key in POST_FIELDS else key


def flat_settings(d: Mapping[str, Any]) -> Dict[str, Any]:
    """A :meth:`TrainConfig.to_dict` with its ``post`` dict spread out as ``post.<field>`` names: one name per
    setting, as overrides, ``--set`` and ``refine`` records name them (:func:`setting_name`)."""
    out = {k: v for k, v in d.items() if k != "post"}
    out.update({f"post.{k}": v for k, v in (d.get("post") or {}).items()})
    return out


def _with_post(d: Mapping[str, Any]) -> Dict[str, Any]:
    """``d`` (settings by name) with its post-processing settings gathered into one :class:`PostProcess` under
    ``post``: the ``post`` entry (a PostProcess or a dict of its fields), then ``post.<field>`` and bare field names
    on top; missing fields are :data:`NO_POST`'s. Raises ValueError for an unknown ``post`` field."""
    out: Dict[str, Any] = {}
    merged = dataclasses.asdict(NO_POST)
    given = d.get("post")
    if isinstance(given, PostProcess):
        given = dataclasses.asdict(given)
    if given is not None and not isinstance(given, Mapping):
        raise ValueError(f"post must be a mapping of {', '.join(POST_FIELDS)}, got {given!r}")
    changes = {f"post.{k}": v for k, v in (given or {}).items()}
    for key, value in d.items():
        if key == "post":
            continue
        name = setting_name(key)
        if name.startswith("post."):
            changes[name] = value
        else:
            out[key] = value
    unknown = sorted(n for n in changes if n[len("post."):] not in POST_FIELDS)
    if unknown:
        raise ValueError(f"unknown training settings: {', '.join(unknown)}")
    merged.update({n[len("post."):]: v for n, v in changes.items()})
    out["post"] = PostProcess(**merged)
    return out


#: Settings of earlier versions that checkpoints may still carry; ignored when read.
RETIRED_SETTINGS = frozenset({"plateau_change_tol"})


def _preset(name: str, model: str, **kw) -> TrainConfig:
    return TrainConfig(preset=name, generator=dataclasses.replace(MODEL_PRESETS[model]),
                       discriminator=dataclasses.replace(DISC_PRESETS[model]), **kw)


_FAST_V1 = dict(tile=128, nr_updates=1, ds_updates=1, d_updates=1, schedule="joint", lr=1e-4, perceptual="pyramid",
                perceptual_min_clipped=5e-5, bf16=True,
                iters_pretrain=6000, iters_finetune=600, iters_fit=6000, eval_every=50, checkpoint_every=250,
                maps_every=0)
#: The highlight-free flash model and losses of ``fast``, chosen by the ablation in docs/decisions/021-fast-highlight-free.md
#: (4 tuning cases, realistic inputs) and checked on a real photo: inverse-square fall-off and a learned
#: vignetting, renderings clipped like the photo, a per-pixel re-render term, the flash-correlation stationarity
#: term, a scale-free L_d, learned output offsets, the dielectric specular prior, and no Fourier term. The flash
#: term's weight is 1: at 100 (best on the synthetic cases) real photos, whose field of view differs from the
#: model's, collapsed to near-black or off-colour maps (docs/decisions/021-fast-highlight-free.md). The final maps lose their
#: radial trend around the highlight (``post.flash_trend``), the hard form of that term, and their specular is one level
#: (``post.uniform_specular``): its spatial variation measured as noise (docs/decisions/005-uniform-specular.md).
_HIGHLIGHT_FREE = dict(render=ZHAO.replace(falloff=True).to_dict(), saturate=True, learn_vignetting=True,
                       learn_offsets=True, lambda_render=1.0, lambda_flash=1.0, lambda_specular_prior=1.0,
                       lambda_fourier=0.0, diffuse_target="normalized",
                       post=NO_POST.replace(flash_trend=True, uniform_specular=True))
#: 150 fine-tune iterations: from the procedural stage one (models/svbrdf_prior_v1) the re-render error of the 38
#: realistic synthetic cases is lowest at 150 iterations and rises after (0.086, 0.088, 0.095 at 150, 300, 600),
#: as do the roughness and normal errors (docs/decisions/023-stage-one-v2.md). The normal map is pulled towards the
#: stage one's (``lambda_anchor`` 3 on ``normal`` only): one photo does not tell the fine-tune the normals (its own
#: correlate 0.015 with the truth), so it keeps the learned prior's unless the photo's losses outweigh the pull
#: (4 tuning cases at weights 0 / 1 / 3 / 10, docs/decisions/021-fast-highlight-free.md).
#: The GAN runs for those first 150 iterations only (``gan_steps``): it is what drifts after them. Without it the
#: shared subset's re-render error stays flat from 150 to 600 iterations (0.0850 / 0.0832 / 0.0839 at 150 / 300 /
#: 600; with it 0.0850 / 0.0875 / 0.0924), the capture relighting and the burn-in keep improving; on held-out
#: procedural materials 600 iterations are still worse than 150 (0.180 vs 0.164; with the GAN 0.218):
#: docs/decisions/020-fast-schedule.md. A default run (150) is unchanged.
#: The region of a clipped highlight is filled from the material elsewhere in the final maps (``post.highlight_fill``):
#: the synthetic cases' burn-in 0.484 -> 0.359 at 150 iterations (docs/decisions/006-highlight-fill.md); with the
#: highlight's shoulder in the region 0.332 (docs/decisions/006-highlight-fill.md).
#: The generator sees the photo evenly lit (``post.even_lighting``, the preview's width), the losses the photo itself:
#: on 16 held-out procedural materials re-render 0.1361 -> 0.1269, burn-in 0.711 -> 0.581. A narrower 0.125 ties on
#: the re-render error and halves the burn-in score, but its roughness turns to irregular blotches the score does
#: not see (detail 1.57 of the truth's on the shared sets): docs/decisions/024-refine-recipe-v2.md.
_FAST = {**_FAST_V1, **_HIGHLIGHT_FREE, "iters_finetune": 150, "lambda_anchor": 3.0, "anchor_maps": ("normal",),
         "gan_steps": 150,
         "post": _HIGHLIGHT_FREE["post"].replace(highlight_fill=True, even_lighting=EVEN_LIGHTING_WIDTH)}


def _presets() -> Dict[str, TrainConfig]:
    return {
        "paper": _preset("paper", "paper"),
        "zhao": _preset("zhao", "paper", lambda_fourier=0.0, lambda_perceptual=0.0),
        "fast": _preset("fast", "fast", **_FAST),
        # ``fast`` before the highlight-free flash model (the paper's losses on the fast model), for comparison.
        "fast-v1": _preset("fast-v1", "fast", **_FAST_V1),
        # Ablations of the paper's losses on the fast model (fast-v1), and of fast's schedule.
        "fast-no-fourier": _preset("fast-no-fourier", "fast", **{**_FAST_V1, "lambda_fourier": 0.0}),
        "fast-no-perceptual": _preset("fast-no-perceptual", "fast", **{**_FAST_V1, "lambda_perceptual": 0.0}),
        "fast-zhao": _preset("fast-zhao", "fast", **{**_FAST_V1, "lambda_fourier": 0.0, "lambda_perceptual": 0.0}),
        "fast-alternating": _preset("fast-alternating", "fast", **{**_FAST, "schedule": "alternating"}),
        "tiny": _preset("tiny", "tiny", tile=32, nr_updates=1, ds_updates=1, d_updates=1, lr=1e-3,
                        perceptual="pyramid", iters_pretrain=20, iters_finetune=10, iters_fit=20,
                        checkpoint_every=10, maps_every=0, eval_every=5, eval_tiles=2, plateau_window=3,
                        guard_snapshot_every=5, predict_max_side=64, predict_overlap=8),
    }


#: The named starting points of :func:`resolve` (see the module docstring). Copies are handed out.
TRAIN_PRESETS: Dict[str, TrainConfig] = _presets()

#: Fine-tune settings measured for one stage one, by name: :func:`svbrdf.trainer.checkpoint.clean_checkpoint`
#: (``refine=NAME``) records the settings in the stage one's checkpoint (``refine``), and every fine-tune from it with
#: a preset that shows the generator an evenly lit photo (``fast``) takes them where the user left the preset's
#: value (:func:`svbrdf.trainer.stage.finetune_config`). ``fast`` itself was chosen from v1 (``models/svbrdf_prior_v1``,
#: which records none).
#:
#: ``"v2"``: from the v2 stage one (issue 26's run, checkpoint 14315), ``fast`` made the maps worse than the preview
#: (12 held-out procedural materials, 150 iterations: re-render 0.0865 -> 0.0906, specular 0.093 -> 0.126, roughness
#: 0.171 -> 0.229): its dielectric specular prior pulls metals to a dielectric level (one brushed metal's re-render
#: 0.071 -> 0.215) and the free roughness drifts. Without the prior and with every map pulled to the stage one's at
#: weight 1 it is better than the preview on every measure (re-render 0.0756, diffuse 0.0846 -> 0.0735, specular
#: 0.093, roughness 0.169, burn-in 0.153 -> 0.125). On every shared set it keeps the preview's capture relighting
#: (0.139 -> 0.140) and lowers the re-render (0.0790 -> 0.0737) and the normal angle (9.51 -> 9.44);
#: docs/decisions/024-refine-recipe-v2.md.
REFINE_RECIPES: Dict[str, Dict[str, Any]] = {
    "v2": {"lambda_specular_prior": 0.0, "lambda_anchor": 1.0, "anchor_maps": list(MAP_NAMES)},
}

#: What each preset is, once (``svbrdf-train --help`` prints those of :data:`CLI_PRESETS`). Costs: seconds per
#: iteration on one thread ("AMX": a shared Xeon core with bf16, "AMD": a shared EPYC core without bf16, where
#: everything runs fp32; ``git show 0b5a711:./trainer/bench/speed.py``).
PRESET_DESCRIPTIONS: Dict[str, str] = {
    "paper": "the published setup (Wen et al. 2022 on top of Zhao et al. 2020): paper-size generator and "
             "PatchGAN, 256 px tiles, per iteration 5 normal/roughness-decoder + 1 diffuse/specular-decoder + 1 "
             "discriminator updates, each on a fresh random tile, Adam 2e-5 (0, 0.9), loss 0.1 GAN + L_d + 0.1 "
             "Fourier + 0.2 perceptual; 10k / 3k / 20k iterations (pretrain / finetune / fit); seed 24. AMX: ~45 "
             "s/it fp32, ~15 s/it --bf16 (10 / 4 s/it with --tile 128); AMD: 76-139 s/it: a GPU job.",
    "zhao": "paper without the Fourier and perceptual losses (Zhao et al. 2020's objective): AMX ~31 s/it fp32, "
            "~12 s/it --bf16.",
    "fast": "quarter-width networks, 128 px tiles, the \"joint\" 1:1:1 schedule (one tile, one generator pass and "
            "one backward pass for both decoders, then the discriminator on the same rendering), lr 1e-4, "
            "multi-scale filter-bank perceptual loss (\"pyramid\", skipped on photos without a clipped highlight), "
            "bf16 autocast where the CPU has it; 6k / 150 / 6k iterations (150: from the procedural stage one, "
            "docs/decisions/023-stage-one-v2.md); and the highlight-free flash model: inverse-square fall-off, learned "
            "vignetting, renderings clipped like the photo, a per-pixel re-render term, the flash-correlation "
            "stationarity term, a scale-free L_d, learned output offsets and a dielectric specular prior instead "
            "of the Fourier term (docs/decisions/021-fast-highlight-free.md). AMD: 0.27 s/it (0.43 s/it with the alternating "
            "schedule). The shipped model was pretrained with the alternating schedule and the paper's losses on "
            "AMX: 6000 it in 1111 s.",
    "fast-v1": "fast with the paper's losses (GAN, L_d, Fourier, perceptual) and flash model, as before the "
               "highlight-free flash model (the comparison point).",
    "fast-alternating": "fast with the published alternating sub-steps (a fresh tile and generator pass per "
                        "update): an ablation of fast's schedule.",
    "fast-no-fourier": "fast-v1 without the Fourier loss: an ablation of the paper's losses.",
    "fast-no-perceptual": "fast-v1 without the perceptual loss: an ablation of the paper's losses.",
    "fast-zhao": "fast-v1 without the Fourier and perceptual losses: an ablation of the paper's losses.",
    "tiny": "toy networks for tests (32 px tiles, 20 iterations, pyramid perceptual loss).",
}
#: The benchmark's ablations: resolvable like the others (``svbrdf-bench --presets``, checkpoints that record
#: them, :func:`resolve`) but not offered by ``svbrdf-train --preset``.
BENCH_PRESETS: Tuple[str, ...] = ("fast-alternating", "fast-no-fourier", "fast-no-perceptual", "fast-zhao")
#: The presets ``svbrdf-train --preset`` offers, in the order its help describes them.
CLI_PRESETS: Tuple[str, ...] = tuple(n for n in TRAIN_PRESETS if n not in BENCH_PRESETS)


def resolve(preset: str = "paper", **overrides: Any) -> TrainConfig:
    """A copy of preset ``preset`` with ``overrides`` applied.

    Overrides are :class:`TrainConfig` field names; ``None`` values are ignored (convenient for CLI flags
    left unset); ``train_encoder`` sets ``generator.train_encoder``; ``fov_deg`` sets ``render["fov_deg"]``;
    ``post`` (a :class:`~svbrdf.runtime.post.PostProcess` or a dict of some of its fields) changes the preset's
    post-processing field by field, and so does ``post.<field>`` or the field's name alone (``**{"post.even_lighting":
    0}``, ``even_lighting=0``).

    Raises:
        ValueError: unknown preset, unknown setting or invalid value.
    """
    if preset not in TRAIN_PRESETS:
        raise ValueError(f"unknown preset {preset!r}; expected one of {', '.join(TRAIN_PRESETS)}")
    d = TRAIN_PRESETS[preset].to_dict()
    for key, value in overrides.items():
        if value is None:
            continue
        if key == "train_encoder":
            d["generator"]["train_encoder"] = bool(value)
        elif key == "fov_deg":
            d["render"]["fov_deg"] = float(value)
        elif key in ("generator", "discriminator", "render") and not isinstance(value, dict):
            d[key] = value.to_dict()
        elif key == "post":
            given = dataclasses.asdict(value) if isinstance(value, PostProcess) else value
            if not isinstance(given, Mapping):
                raise ValueError(f"post must be a PostProcess or a mapping of its fields, got {value!r}")
            d["post"] = {**d["post"], **given}
        else:
            d[key] = value
    return TrainConfig.from_dict(d)


def parse_settings(items: Iterable[str]) -> Dict[str, Any]:
    """Training settings as command lines give them (``svbrdf-bench --set``, ``before_after``'s presets):
    ``["lr=1e-4", "post.even_lighting=0", "perceptual=pyramid"]`` -> ``{"lr": 0.0001, "post.even_lighting": 0,
    "perceptual": "pyramid"}`` (values read as JSON, else kept as strings; the names are checked by :func:`resolve`,
    not here: a post-processing setting is ``post.<field>`` or the field's name alone).

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


__all__ = ["TrainConfig", "NO_POST", "POST_FIELDS", "setting_name", "flat_settings", "parse_settings", "TRAIN_PRESETS", "REFINE_RECIPES", "PRESET_DESCRIPTIONS", "BENCH_PRESETS", "CLI_PRESETS", "resolve", "STAGES", "FOURIER_MODES", "PERCEPTUAL_BACKENDS",
           "QUALITY_MODES", "SCHEDULES"]
