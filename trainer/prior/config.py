"""The settings of the stage one learned from procedural materials: :class:`PriorConfig`."""

from __future__ import annotations

import dataclasses
from dataclasses import asdict, dataclass, field
from typing import Any, Dict, Mapping, Optional, Tuple

from svbrdf.trainer.camera_model import REALISTIC
from svbrdf.runtime.inference.manifest import PRIOR_STAGE
from svbrdf.runtime.core.maps import SLICES
from svbrdf.trainer.config import resolve
from svbrdf.trainer.losses import DETAIL_WINDOWS
from svbrdf.trainer.models import GeneratorConfig
from svbrdf.trainer.procedural import FAMILIES

#: The checkpoints' ``stage`` of a prior run.
STAGE = PRIOR_STAGE


@dataclass
class PriorConfig:
    """Settings of :class:`PriorTrainer` (JSON-safe through :meth:`to_dict` / :meth:`from_dict`).

    Attributes:
        generator: architecture (the ``fast`` width, encoder trained).
        finetune_preset: the :data:`~svbrdf.trainer.config.TRAIN_PRESETS` entry whose fine-tune starts from this
            prior; its renderer settings are the relighting loss's, and it is stored as the checkpoint's
            ``train_config``.
        size: side of the training images, px.
        photo_size: side of the photos the crops come from, px (>= ``size``).
        crop_share: fraction of batches that are crops of ``photo_size`` photos (the rest: whole ``size`` photos).
        batch: materials per iteration.
        iters: iterations.
        lr, lr_min, betas: Adam; the learning rate decays from ``lr`` to ``lr_min`` on a cosine over ``iters``.
        seed: seeds the weights and the material stream.
        fov_deg: range of the photos' horizontal field of view, degrees (uniform).
        light_offset: the flash sits up to this far from the lens, in each of x and y (half photo widths).
        physical_share: fraction of photos rendered with :func:`~svbrdf.runtime.core.render.physical_config`.
        camera: ranges of the camera model (default :data:`svbrdf.trainer.camera_model.REALISTIC`). ``white`` (the
            highlight roll-off's white point, :func:`svbrdf.trainer.camera_model.roll_off`) may be left out: (1, 1), a
            linear camera, as every run before it existed; it is drawn only when its range is not (1, 1), so such
            a run's stream of draws is unchanged.
        lambda_render: weight of the relighting loss.
        render_lights: random point lights of the relighting loss (besides the flash).
        render_views: further renderings of the relighting loss, each under a random distant view and a random
            distant light (:func:`view_light_directions`; 0 = none, the v1 loss).
        grazing_share: fraction of those views and lights drawn at ``grazing_deg`` from the normal.
        grazing_deg: polar-angle range of a grazing view or light, degrees; the others are drawn up to its start.
        lambda_grad: weight of :func:`~svbrdf.trainer.losses.gradient_loss` on the normal and roughness maps.
        lambda_amount: weight of :func:`~svbrdf.trainer.losses.detail_amount_loss` on the ``amount_maps`` (asks
            for as much local variation as the truth has; 0 = off, the v1 and first v2 loss).
        amount_maps: the maps of that term (names of :data:`svbrdf.runtime.core.maps.SLICES`).
        lambda_slope: weight of :func:`~svbrdf.trainer.losses.slope_correlation_loss` (the pattern of the normals'
            slopes at any scale; 0 = off, the loss before the eighth session of 2026-11-26).
        amount_windows: its window sides, px (:data:`~svbrdf.trainer.losses.DETAIL_WINDOWS` by default; a window
            the image's size or more lets blobs stand in for detail).
        families: procedural families to draw from (None = all).
        checkpoint_every: iterations between checkpoints (0 = only at the end).
        eval_every: iterations between evaluations on a fixed validation batch (0 = never).
        eval_batch: materials in that batch (its own seed, never trained on).
        batched: build materials, photos and relighting geometry with torch on the training device
            (:func:`simulate_photos_batched`) instead of photo by photo with numpy (v1). Another stream of photos.
        bf16: run the generator under bfloat16 autocast where the device has it (losses stay float32).
        log_every: iterations per log record (their mean); 1 = every iteration (v1).
        compact_checkpoint: store the weights in float16 and Adam's moments in bfloat16, and only the log
            records in the history (about a third of the float32 size; resuming casts them back).
        ema: decay of the weights' exponential moving average (0 = none, v1 and v2 before the ninth session of
            2026-11-26): the average is the model (see the module docstring). A resume that turns it on starts the
            average at the weights it resumes.
        material_reuse: iterations that photograph the same materials anew (new flash, field of view, camera and
            crop each time) before new ones are drawn; > 1 where drawing materials bounds the speed (a GPU waiting
            for the host's many small kernel launches). The time limit stops a run only where a new draw starts,
            so that it resumes exactly (the materials in use are not stored); make ``log_every`` and
            ``checkpoint_every`` multiples of it for the same after an interrupt or a crash.
        flat_share: fraction of the drawn materials whose normals are made flat (0, 0, 1) before they are
            photographed: polished stone, lacquer, glossy paint and paper have no relief, and every procedural family
            has some (its mean normal angle drawn in :data:`svbrdf.trainer.procedural.PARAMS` ``normal_angle_deg``,
            2-25 degrees), so a network trained on them alone gives every photo a relief (CHANGELOG.md, study
            prior-v2). 0 = none (every run before 2026-11-27): no draw is made, the stream is
            unchanged. The validation batch never has them (its figures stay comparable along a run).
        black_share: fraction of the drawn dielectric materials whose base colour is darkened to a near-black mean
            (:data:`BLACK_LEVEL`, log-uniform): black plastic, lacquer and polished black stone. Without them a
            near-black base colour means a metal in the procedural stream (22 of 23 such materials in 512 draws),
            and v2 reads every black material as one (CHANGELOG.md, study prior-v2, chunk 11). 0 =
            none (every run before 2026-11-27, fourth session): no draw is made, the stream is unchanged. The
            validation batch never has them.
        coarse_share: fraction of the drawn materials given a coarse relief on top of their own
            (:func:`add_coarse_relief`: uneven stones or a smooth warp a few features across,
            :func:`svbrdf.trainer.procedural.coarse_height`): flagstones, brick walls, warped tiles, dented sheets. Every procedural family's relief
            is fine (94 % of its slope variance within a 4 px band at 256 px, against 50 % in the shared sets'
            materials), and the v2 stage one reads coarse relief at a slope correlation of 0.08 on those
            (CHANGELOG.md, study prior-v2). Applied before ``flat_share``, so a flat material stays flat.
            0 = none (every run before 2026-11-27, eighth session): no draw is made, the stream is unchanged. The
            validation batch never has them.
        stream: where the stream is drawn: "host" (every random number from the CPU generator, material by
            material: the same stream on every device; every run before issue 64) or "device" (families vectorised
            over the batch, random numbers from a generator on the training device seeded per draw:
            :mod:`svbrdf.trainer.prior.device_stream`; reproducible on one device only; needs ``batched``).
        print_share: fraction of the drawn materials given a print or inlay (device stream only,
            :func:`svbrdf.trainer.prior.device_stream.add_prints`): inside a smooth blob or band mask the base colour,
            the specular and the roughness are a second finish's own (ink, lacquer, inlaid veneer, worn varnish), so
            the specular varies within the material independently of its family's classes; the relief is kept.
            0 = none (every run before issue 64): nothing is drawn. The validation batch never has them.
        block_mean: the network is shown photos as the preview shows a full-size photo, as ``block_mean`` x
            ``block_mean`` block means (device stream only): the materials are drawn and photographed at
            ``block_mean`` times the side and the photo and the maps are averaged in blocks (normals renormalised).
            1 = no averaging (every run before issue 64).
        block_share: fraction of the batches shown as block means when ``block_mean`` > 1 (the others as they are:
            the preview shows photos up to its working size unaveraged).
    """

    generator: GeneratorConfig = field(default_factory=lambda: GeneratorConfig(width=0.25, train_encoder=True))
    finetune_preset: str = "fast"
    size: int = 128
    photo_size: int = 256
    crop_share: float = 0.5
    batch: int = 8
    iters: int = 5000
    lr: float = 5e-4
    lr_min: float = 2e-5
    betas: Tuple[float, float] = (0.9, 0.999)
    seed: int = 0
    fov_deg: Tuple[float, float] = (45.0, 75.0)
    light_offset: float = 0.08
    physical_share: float = 0.5
    camera: Dict[str, Tuple[float, float]] = field(default_factory=lambda: dict(REALISTIC))
    lambda_render: float = 1.0
    render_lights: int = 3
    families: Optional[Tuple[str, ...]] = None
    checkpoint_every: int = 100
    eval_every: int = 100
    eval_batch: int = 16
    render_views: int = 0
    grazing_share: float = 0.5
    grazing_deg: Tuple[float, float] = (60.0, 75.0)
    lambda_grad: float = 0.0
    lambda_amount: float = 0.0
    amount_maps: Tuple[str, ...] = ("normal", "roughness")
    amount_windows: Tuple[int, ...] = DETAIL_WINDOWS
    batched: bool = False
    bf16: bool = False
    log_every: int = 1
    compact_checkpoint: bool = False
    material_reuse: int = 1
    lambda_slope: float = 0.0
    ema: float = 0.0
    flat_share: float = 0.0
    black_share: float = 0.0
    coarse_share: float = 0.0
    stream: str = "host"
    print_share: float = 0.0
    block_mean: int = 1
    block_share: float = 1.0

    def __post_init__(self) -> None:
        self.betas = tuple(float(b) for b in self.betas)
        self.fov_deg = tuple(float(f) for f in self.fov_deg)
        self.grazing_deg = tuple(float(f) for f in self.grazing_deg)
        self.amount_maps = tuple(self.amount_maps)
        self.amount_windows = tuple(int(w) for w in self.amount_windows)
        self.camera = {k: tuple(float(x) for x in v) for k, v in {"white": (1.0, 1.0), **self.camera}.items()}
        if self.families is not None:
            self.families = tuple(self.families)
        self.validate()

    def validate(self) -> None:
        def need(ok: bool, msg: str) -> None:
            if not ok:
                raise ValueError(msg)

        need(self.size >= 32 and self.size % self.generator_multiple() == 0,
             f"size must be >= 32 and a multiple of {self.generator_multiple()}, got {self.size}")
        need(self.photo_size >= self.size, f"photo_size {self.photo_size} must be >= size {self.size}")
        need(0.0 <= self.crop_share <= 1.0, f"crop_share must be in [0, 1], got {self.crop_share}")
        need(0.0 <= self.physical_share <= 1.0, f"physical_share must be in [0, 1], got {self.physical_share}")
        need(self.batch >= 1 and self.iters >= 1, "batch and iters must be >= 1")
        need(self.lr > 0 and 0 <= self.lr_min <= self.lr, f"need lr > 0 and 0 <= lr_min <= lr, got {self.lr}, "
                                                          f"{self.lr_min}")
        need(1.0 <= self.fov_deg[0] <= self.fov_deg[1] <= 170.0, f"bad fov_deg range {self.fov_deg}")
        need(self.light_offset >= 0 and self.render_lights >= 0 and self.lambda_render >= 0,
             "light_offset, render_lights and lambda_render must be >= 0")
        need(set(self.camera) == set(REALISTIC), f"camera ranges need exactly the keys {sorted(REALISTIC)}")
        need(all(len(v) == 2 and v[0] <= v[1] for v in self.camera.values()),
             "camera ranges must be (lo, hi), lo <= hi")
        need(self.camera["white"][0] >= 1.0, f"the camera's white range must be >= 1, got {self.camera['white']}")
        need(self.render_views >= 0 and self.lambda_grad >= 0 and self.lambda_amount >= 0 and self.lambda_slope >= 0,
             "render_views, lambda_grad, lambda_amount and lambda_slope must be >= 0")
        need(bool(self.amount_maps) and set(self.amount_maps) <= set(SLICES),
             f"amount_maps must be some of {', '.join(SLICES)}, got {self.amount_maps}")
        need(bool(self.amount_windows) and min(self.amount_windows) >= 2,
             f"amount_windows must be sides >= 2 px, got {self.amount_windows}")
        need(0.0 <= self.grazing_share <= 1.0, f"grazing_share must be in [0, 1], got {self.grazing_share}")
        need(0.0 < self.grazing_deg[0] <= self.grazing_deg[1] < 90.0, f"bad grazing_deg range {self.grazing_deg}")
        need(self.log_every >= 1, f"log_every must be >= 1, got {self.log_every}")
        need(self.checkpoint_every >= 0 and self.eval_every >= 0,
             f"checkpoint_every and eval_every must be >= 0, got {self.checkpoint_every}, {self.eval_every}")
        need(self.material_reuse >= 1, f"material_reuse must be >= 1, got {self.material_reuse}")
        need(0.0 <= self.ema < 1.0, f"ema must be in [0, 1), got {self.ema}")
        need(0.0 <= self.flat_share < 1.0, f"flat_share must be in [0, 1), got {self.flat_share}")
        need(0.0 <= self.black_share < 1.0, f"black_share must be in [0, 1), got {self.black_share}")
        need(0.0 <= self.coarse_share <= 1.0, f"coarse_share must be in [0, 1], got {self.coarse_share}")
        need(self.stream in ("host", "device"), f"stream must be 'host' or 'device', got {self.stream!r}")
        need(self.stream == "host" or self.batched, "stream 'device' needs batched")
        need(0.0 <= self.print_share < 1.0, f"print_share must be in [0, 1), got {self.print_share}")
        need(self.block_mean in (1, 2, 4), f"block_mean must be 1, 2 or 4, got {self.block_mean}")
        need(0.0 <= self.block_share <= 1.0, f"block_share must be in [0, 1], got {self.block_share}")
        need(self.stream == "device" or (self.print_share == 0 and self.block_mean == 1),
             "print_share and block_mean need stream 'device'")
        unknown = set(self.families or ()) - set(FAMILIES)
        need(not unknown, f"unknown families {sorted(unknown)}; expected some of {', '.join(FAMILIES)}")
        resolve(self.finetune_preset)  # raises on an unknown preset

    def generator_multiple(self) -> int:
        return 2 ** self.generator.decoder_blocks

    def to_dict(self) -> Dict[str, Any]:
        d = asdict(self)
        d["generator"] = self.generator.to_dict()
        d["betas"], d["fov_deg"], d["grazing_deg"] = list(self.betas), list(self.fov_deg), list(self.grazing_deg)
        d["camera"] = {k: list(v) for k, v in self.camera.items()}
        d["families"] = None if self.families is None else list(self.families)
        d["amount_maps"], d["amount_windows"] = list(self.amount_maps), list(self.amount_windows)
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "PriorConfig":
        d = dict(d)
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(d) - names
        if unknown:
            raise ValueError(f"unknown PriorConfig keys: {', '.join(sorted(unknown))}")
        if "generator" in d:
            d["generator"] = GeneratorConfig.from_dict(d["generator"])
        return cls(**d)


def override(config: PriorConfig, settings: Mapping[str, Any]) -> PriorConfig:
    """``config`` with ``settings`` applied (a new, validated config): names are :class:`PriorConfig` fields or
    ``generator.<field>`` (``--set``, :func:`svbrdf.trainer.config.parse_settings`).

    Raises:
        ValueError: an unknown setting or an invalid value.
    """
    d = config.to_dict()
    for key, value in settings.items():
        head, _, rest = key.partition(".")
        if rest and head == "generator":
            d["generator"][rest] = value
        elif rest or head not in d:
            raise ValueError(f"unknown prior settings: {key}")
        else:
            d[head] = value
    return PriorConfig.from_dict(d)


__all__ = ["PriorConfig", "STAGE", "override"]
