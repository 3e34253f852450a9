"""The settings of the stage one learned from procedural materials: :class:`PriorConfig`, grouped, one dotted name
per setting (``optim.lr``, ``photos.fov_deg``, ``losses.render``); :func:`override` applies settings by name.
The flat names of earlier records (``lambda_render``, ``fov_deg``) map to the dotted ones in :data:`FLAT_NAMES`."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Dict, Mapping, Optional, Tuple

from svbrdf.runtime.core.maps import SLICES
from svbrdf.runtime.inference.manifest import PRIOR_STAGE
from svbrdf.trainer.camera_model import REALISTIC
from svbrdf.trainer.config import SettingsLayout, resolve
from svbrdf.trainer.losses import DETAIL_WINDOWS
from svbrdf.trainer.models import GeneratorConfig
from svbrdf.trainer.procedural import FAMILIES

#: The checkpoints' ``stage`` of a prior run.
STAGE = PRIOR_STAGE
#: Where the stream of materials and photos is drawn (``materials.stream``).
STREAMS = ("host", "device")


@dataclass(frozen=True)
class Optimisation:
    """How the network is optimised.

    Attributes:
        batch: materials per iteration (per process when data parallel).
        iters: iterations; the length of the learning rate's cosine.
        lr, lr_min: Adam's learning rate decays from ``lr`` (> 0) to ``lr_min`` (in [0, ``lr``]) on a cosine over
            ``iters``.
        betas: Adam's betas.
        seed: seeds the weights and the stream of materials.
        bf16: run the generator under bfloat16 autocast where the device has it (the losses stay float32).
        ema: decay of the weights' exponential moving average, in [0, 1); 0 = none. With one, the average is the
            model (the evaluations, :attr:`~svbrdf.trainer.prior.trainer.PriorTrainer.model`, every consumer of the
            checkpoint); a resume that turns it on starts the average at the weights it resumes.
    """

    batch: int = 8
    iters: int = 5000
    lr: float = 5e-4
    lr_min: float = 2e-5
    betas: Tuple[float, float] = (0.9, 0.999)
    seed: int = 0
    bf16: bool = False
    ema: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "betas", tuple(float(b) for b in self.betas))


@dataclass(frozen=True)
class Photos:
    """How a material becomes the training photo the network sees.

    Attributes:
        size: side of the training images, px (>= 32, a multiple of the generator's ``2 ** decoder_blocks``).
        photo_size: side of the photos the crops come from, px (>= ``size``).
        crop_share: fraction of batches that are ``size`` crops of ``photo_size`` photos (the rest: whole ``size``
            photos), in [0, 1].
        fov_deg: range of the photos' horizontal field of view, degrees (uniform; within [1, 170]).
        light_offset: the flash sits up to this far from the lens, in each of x and y (half photo widths; >= 0).
        physical_share: fraction of photos rendered with :func:`~svbrdf.runtime.core.render.physical_config`, in
            [0, 1].
        camera: ranges ``(lo, hi)`` of the camera model, by the keys of
            :data:`svbrdf.trainer.camera_model.REALISTIC` (its values by default). ``white`` (the highlight
            roll-off's white point, :func:`svbrdf.trainer.camera_model.roll_off`, >= 1) may be left out: (1, 1), a
            linear camera; it is drawn only when its range is not (1, 1), so that the stream of draws is then
            unchanged.
        block_mean: the network is shown photos as the preview shows a full-size photo: materials drawn and
            photographed at ``block_mean`` times the side, photo and maps averaged in ``block_mean`` x
            ``block_mean`` blocks (normals renormalised); 1, 2 or 4; 1 = no averaging. Device stream only.
        block_share: fraction of the batches shown as block means when ``block_mean`` > 1, in [0, 1] (the others
            as they are).
    """

    size: int = 128
    photo_size: int = 256
    crop_share: float = 0.5
    fov_deg: Tuple[float, float] = (45.0, 75.0)
    light_offset: float = 0.08
    physical_share: float = 0.5
    camera: Dict[str, Tuple[float, float]] = field(default_factory=lambda: dict(REALISTIC))
    block_mean: int = 1
    block_share: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "fov_deg", tuple(float(f) for f in self.fov_deg))
        object.__setattr__(self, "camera", {k: tuple(float(x) for x in v)
                                            for k, v in {"white": (1.0, 1.0), **self.camera}.items()})


@dataclass(frozen=True)
class Materials:
    """The stream of training materials: which are drawn, how often, what is changed on them, and where and how the
    stream (materials, photos and relighting geometry) is built.

    Each share is a fraction of the drawn materials; at 0 nothing is drawn for it, so that the stream is the one
    without it. The validation batch never has any of them (its figures stay comparable along a run).

    Attributes:
        families: procedural families to draw from (names of :data:`svbrdf.trainer.procedural.FAMILIES`; None =
            all).
        reuse: iterations that photograph the same materials anew (new flash, field of view, camera and crop each
            time) before new ones are drawn (>= 1); > 1 where drawing materials bounds the speed. The time limit
            stops a run only where a new draw starts, so that it resumes exactly; make ``monitor.log_every`` and
            ``monitor.checkpoint_every`` multiples of it for the same after an interrupt or a crash.
        flat_share: share whose normals are made flat (0, 0, 1) before they are photographed (polished stone,
            lacquer, glossy paint, paper: every procedural family has some relief), in [0, 1).
        black_share: share of the dielectric materials whose base colour is darkened to a near-black mean
            (:data:`~svbrdf.trainer.prior.photos.BLACK_LEVEL`, log-uniform: black plastic, lacquer, polished black
            stone), in [0, 1).
        coarse_share: share given a coarse relief on top of their own
            (:func:`~svbrdf.trainer.prior.photos.add_coarse_relief`: uneven stones or a smooth warp a few features
            across), in [0, 1]; applied before ``flat_share``, so a flat material stays flat.
        print_share: share given a print or inlay (:func:`svbrdf.trainer.prior.device_stream.add_prints`: inside a
            smooth blob or band mask the base colour, specular and roughness are a second finish's own; the relief
            is kept), in [0, 1). Device stream only.
        stream: "host" (every random number from the CPU generator, material by material: the same stream on every
            device) or "device" (families vectorised over the batch, random numbers from a generator on the
            training device seeded per draw, :mod:`svbrdf.trainer.prior.device_stream`: reproducible on one device
            type only; needs ``batched``).
        batched: build materials, photos and relighting geometry with torch on the training device, batch at a
            time (:func:`~svbrdf.trainer.prior.photos.simulate_photos_batched`), instead of photo by photo with
            numpy (False). Another stream of photos.
    """

    families: Optional[Tuple[str, ...]] = None
    reuse: int = 1
    flat_share: float = 0.0
    black_share: float = 0.0
    coarse_share: float = 0.0
    print_share: float = 0.0
    stream: str = "host"
    batched: bool = False

    def __post_init__(self) -> None:
        if self.families is not None:
            object.__setattr__(self, "families", tuple(self.families))


@dataclass(frozen=True)
class Losses:
    """The loss terms besides the per-map L1 (always on): each weight (>= 0; 0 = off) and its options.

    Attributes:
        render: weight of the relighting loss (:func:`~svbrdf.trainer.losses.relit_loss`: log radiance under the
            flash and ``render_lights`` random point lights, with the fine-tune preset's renderer settings).
        render_lights: random point lights of the relighting loss besides the flash (>= 0).
        render_views: further renderings of the relighting loss, each under a random distant view and a random
            distant light (:func:`~svbrdf.trainer.prior.photos.view_light_directions`; >= 0; 0 = none).
        grazing_share: fraction of those views and lights drawn at ``grazing_deg`` from the normal, in [0, 1].
        grazing_deg: polar-angle range of a grazing view or light, degrees (within (0, 90)); the others are drawn
            up to its start.
        grad: weight of :func:`~svbrdf.trainer.losses.gradient_loss` on the normal and roughness maps.
        amount: weight of :func:`~svbrdf.trainer.losses.detail_amount_loss` on ``amount_maps`` (asks for as much
            local variation as the truth has).
        amount_maps: the maps of that term (names of :data:`svbrdf.runtime.core.maps.SLICES`).
        amount_windows: its window sides, px (>= 2; :data:`~svbrdf.trainer.losses.DETAIL_WINDOWS` by default; a
            window the image's size or more lets blobs stand in for detail).
        slope: weight of :func:`~svbrdf.trainer.losses.slope_correlation_loss` (the pattern of the normals'
            slopes at any scale).
    """

    render: float = 1.0
    render_lights: int = 3
    render_views: int = 0
    grazing_share: float = 0.5
    grazing_deg: Tuple[float, float] = (60.0, 75.0)
    grad: float = 0.0
    amount: float = 0.0
    amount_maps: Tuple[str, ...] = ("normal", "roughness")
    amount_windows: Tuple[int, ...] = DETAIL_WINDOWS
    slope: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "grazing_deg", tuple(float(f) for f in self.grazing_deg))
        object.__setattr__(self, "amount_maps", tuple(self.amount_maps))
        object.__setattr__(self, "amount_windows", tuple(int(w) for w in self.amount_windows))


@dataclass(frozen=True)
class Monitoring:
    """How a run is kept: checkpoints, evaluations, the log. None of it changes what is learned.

    Attributes:
        checkpoint_every: iterations between checkpoints (>= 0; 0 = only at the end).
        eval_every: iterations between evaluations on a fixed validation batch (>= 0; 0 = never).
        eval_batch: materials in that batch (its own seed, never trained on; whole ``photos.size`` photos from
            the host stream).
        log_every: iterations per log record, their mean (>= 1; 1 = every iteration).
        compact_checkpoint: store the weights in float16 and Adam's moments in bfloat16, and only the log records
            in the history (about a third of the float32 size; resuming casts them back).
    """

    checkpoint_every: int = 100
    eval_every: int = 100
    eval_batch: int = 16
    log_every: int = 1
    compact_checkpoint: bool = False


#: The groups of :class:`PriorConfig`, by attribute name; each is frozen (change one with :func:`override`).
GROUPS: Dict[str, type] = {"optim": Optimisation, "photos": Photos, "materials": Materials, "losses": Losses,
                           "monitor": Monitoring}

#: Flat names of the settings as checkpoints' ``prior_config``, recipes' records and overrides named them before the
#: groups (``PriorConfig.to_dict()`` was one flat dict) -> their dotted names now. Read by
#: :meth:`PriorConfig.from_dict`, :func:`override` and :func:`setting_name`. ``height_activation`` is a recipe's
#: name for the generator's.
FLAT_NAMES: Dict[str, str] = {
    **{n: f"optim.{n}" for n in ("batch", "iters", "lr", "lr_min", "betas", "seed", "bf16", "ema")},
    **{n: f"photos.{n}" for n in ("size", "photo_size", "crop_share", "fov_deg", "light_offset", "physical_share",
                                  "camera", "block_mean", "block_share")},
    **{n: f"materials.{n}" for n in ("families", "flat_share", "black_share", "coarse_share", "print_share",
                                     "stream", "batched")},
    "material_reuse": "materials.reuse",
    "lambda_render": "losses.render", "lambda_grad": "losses.grad", "lambda_amount": "losses.amount",
    "lambda_slope": "losses.slope",
    **{n: f"losses.{n}" for n in ("render_lights", "render_views", "grazing_share", "grazing_deg", "amount_maps",
                                  "amount_windows")},
    **{n: f"monitor.{n}" for n in ("checkpoint_every", "eval_every", "eval_batch", "log_every",
                                   "compact_checkpoint")},
    "height_activation": "generator.height_activation",
}

#: The top-level names of :class:`PriorConfig` that are not a group.
COMPONENTS = ("generator", "finetune_preset")
#: How :class:`PriorConfig` names its settings (:class:`svbrdf.trainer.config.SettingsLayout`).
LAYOUT = SettingsLayout("prior", GROUPS, COMPONENTS, ("finetune_preset",), FLAT_NAMES)


def _plain(v: Any) -> Any:
    """JSON-safe: tuples as lists, inside dicts too."""
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    return v


@dataclass
class PriorConfig:
    """Settings of :class:`~svbrdf.trainer.prior.trainer.PriorTrainer`, grouped (JSON-safe through :meth:`to_dict`
    / :meth:`from_dict`; validated when made).

    Attributes:
        generator: the architecture trained (default: the ``fast`` width, 0.25, encoder trained).
        finetune_preset: the :data:`~svbrdf.trainer.config.TRAIN_PRESETS` entry whose fine-tune starts from this
            stage one: its renderer settings are those of the photos and of the relighting loss, and it is stored as
            the checkpoint's ``train_config``.
        optim: :class:`Optimisation`: batch, iterations, Adam and its cosine, seed, bf16, the weights' average.
        photos: :class:`Photos`: how a material becomes a training photo (sizes and crops, field of view, flash,
            renderer mix, camera, block means).
        materials: :class:`Materials`: the stream of materials (families, reuse, the shares of flat, near-black,
            coarse-relief and printed materials) and where and how it is drawn.
        losses: :class:`Losses`: the weights and options of the relighting, gradient, detail-amount and slope terms.
        monitor: :class:`Monitoring`: checkpoints, evaluations, log records; how a run is kept, not what it learns.

    Every setting has one dotted name (``optim.lr``, ``losses.render``): :meth:`flat_dict`, :func:`override`,
    ``svbrdf-train prior --set``. The flat names of earlier records are :data:`FLAT_NAMES`.
    """

    generator: GeneratorConfig = field(default_factory=lambda: GeneratorConfig(width=0.25, train_encoder=True))
    finetune_preset: str = "fast"
    optim: Optimisation = field(default_factory=Optimisation)
    photos: Photos = field(default_factory=Photos)
    materials: Materials = field(default_factory=Materials)
    losses: Losses = field(default_factory=Losses)
    monitor: Monitoring = field(default_factory=Monitoring)

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ValueError on an inconsistent setting (the one place settings are checked)."""
        def need(ok: bool, msg: str) -> None:
            if not ok:
                raise ValueError(msg)

        o, p, m, ls, mo = self.optim, self.photos, self.materials, self.losses, self.monitor
        multiple = self.generator_multiple()
        need(p.size >= 32 and p.size % multiple == 0,
             f"photos.size must be >= 32 and a multiple of {multiple}, got {p.size}")
        need(p.photo_size >= p.size, f"photos.photo_size {p.photo_size} must be >= photos.size {p.size}")
        for group, name in (("photos", "crop_share"), ("photos", "physical_share"), ("photos", "block_share"),
                            ("losses", "grazing_share"), ("materials", "coarse_share")):
            value = getattr(getattr(self, group), name)
            need(0.0 <= value <= 1.0, f"{group}.{name} must be in [0, 1], got {value}")
        for name in ("flat_share", "black_share", "print_share"):
            need(0.0 <= getattr(m, name) < 1.0, f"materials.{name} must be in [0, 1), got {getattr(m, name)}")
        need(o.batch >= 1 and o.iters >= 1, "optim.batch and optim.iters must be >= 1")
        need(o.lr > 0 and 0 <= o.lr_min <= o.lr,
             f"need optim.lr > 0 and 0 <= optim.lr_min <= optim.lr, got {o.lr}, {o.lr_min}")
        need(0.0 <= o.ema < 1.0, f"optim.ema must be in [0, 1), got {o.ema}")
        need(1.0 <= p.fov_deg[0] <= p.fov_deg[1] <= 170.0, f"bad photos.fov_deg range {p.fov_deg}")
        need(p.light_offset >= 0, f"photos.light_offset must be >= 0, got {p.light_offset}")
        need(set(p.camera) == set(REALISTIC), f"photos.camera ranges need exactly the keys {sorted(REALISTIC)}")
        need(all(len(v) == 2 and v[0] <= v[1] for v in p.camera.values()),
             "photos.camera ranges must be (lo, hi), lo <= hi")
        need(p.camera["white"][0] >= 1.0, f"the camera's white range must be >= 1, got {p.camera['white']}")
        need(p.block_mean in (1, 2, 4), f"photos.block_mean must be 1, 2 or 4, got {p.block_mean}")
        for name in ("render", "render_lights", "render_views", "grad", "amount", "slope"):
            need(getattr(ls, name) >= 0, f"losses.{name} must be >= 0, got {getattr(ls, name)}")
        need(bool(ls.amount_maps) and set(ls.amount_maps) <= set(SLICES),
             f"losses.amount_maps must be some of {', '.join(SLICES)}, got {ls.amount_maps}")
        need(bool(ls.amount_windows) and min(ls.amount_windows) >= 2,
             f"losses.amount_windows must be sides >= 2 px, got {ls.amount_windows}")
        need(0.0 < ls.grazing_deg[0] <= ls.grazing_deg[1] < 90.0, f"bad losses.grazing_deg range {ls.grazing_deg}")
        need(mo.log_every >= 1, f"monitor.log_every must be >= 1, got {mo.log_every}")
        need(mo.checkpoint_every >= 0 and mo.eval_every >= 0, f"monitor.checkpoint_every and monitor.eval_every "
             f"must be >= 0, got {mo.checkpoint_every}, {mo.eval_every}")
        need(m.reuse >= 1, f"materials.reuse must be >= 1, got {m.reuse}")
        need(m.stream in STREAMS, f"materials.stream must be 'host' or 'device', got {m.stream!r}")
        need(m.stream == "host" or m.batched, "materials.stream 'device' needs materials.batched")
        need(m.stream == "device" or (m.print_share == 0 and p.block_mean == 1),
             "materials.print_share and photos.block_mean need materials.stream 'device'")
        unknown = set(m.families or ()) - set(FAMILIES)
        need(not unknown, f"unknown families {sorted(unknown)}; expected some of {', '.join(FAMILIES)}")
        resolve(self.finetune_preset)  # raises on an unknown preset

    def generator_multiple(self) -> int:
        """What ``photos.size`` must be a multiple of: ``2 ** generator.decoder_blocks``."""
        return 2 ** self.generator.decoder_blocks

    def to_dict(self) -> Dict[str, Any]:
        """JSON-safe nested dict: the generator's settings, ``finetune_preset`` and one dict per group (tuples as
        lists)."""
        out: Dict[str, Any] = {"generator": self.generator.to_dict(), "finetune_preset": self.finetune_preset}
        for name, group in GROUPS.items():
            out[name] = {f.name: _plain(getattr(getattr(self, name), f.name)) for f in fields(group)}
        return out

    def flat_dict(self) -> Dict[str, Any]:
        """:meth:`to_dict` with one dotted name per setting of a group (``optim.lr``); ``generator`` stays a dict."""
        return LAYOUT.flat(self.to_dict())

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "PriorConfig":
        """Inverse of :meth:`to_dict` and of :meth:`flat_dict`; also reads the flat dicts of earlier checkpoints
        (:data:`FLAT_NAMES`). Missing settings take the defaults; unknown ones raise ValueError."""
        nested = LAYOUT.nested(d)
        kw: Dict[str, Any] = {}
        if "finetune_preset" in nested:
            kw["finetune_preset"] = nested.pop("finetune_preset")
        if "generator" in nested:
            kw["generator"] = GeneratorConfig.from_dict(nested.pop("generator"))
        for name, group in GROUPS.items():
            given = nested.pop(name, {})
            unknown = sorted(set(given) - {f.name for f in fields(group)})
            if unknown:
                raise ValueError(f"unknown prior settings: {', '.join(f'{name}.{k}' for k in unknown)}")
            kw[name] = group(**given)
        return cls(**kw)


def setting_name(key: str) -> str:
    """The dotted name of a prior setting: a flat name of an earlier record or override (:data:`FLAT_NAMES`, e.g.
    ``lambda_render`` -> ``losses.render``); any other name unchanged."""
    return LAYOUT.name(key)


def override(config: PriorConfig, settings: Mapping[str, Any]) -> PriorConfig:
    """``config`` with ``settings`` applied (a new, validated config): names are dotted (``optim.lr``,
    ``generator.width``), the flat names of :data:`FLAT_NAMES` (``lr``), or a whole group or the generator (an
    object or a mapping of some of its settings, applied setting by setting); ``None`` is a value
    (``materials.families``). ``--set`` gives them (:func:`svbrdf.trainer.config.parse_settings`).

    Raises:
        ValueError: an unknown setting or an invalid value.
    """
    d = config.to_dict()
    for key, value in settings.items():
        LAYOUT.put(d, setting_name(key), value)
    return PriorConfig.from_dict(d)


__all__ = ["PriorConfig", "Optimisation", "Photos", "Materials", "Losses", "Monitoring", "GROUPS", "FLAT_NAMES",
           "COMPONENTS", "LAYOUT", "STAGE", "STREAMS", "setting_name", "override"]
