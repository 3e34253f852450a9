"""Stage one learned from many materials: supervised pretraining of the generator on procedural materials.

The paper pretrains stage one on a single photo with its unsupervised losses; that prior has only ever seen one
material. Here the same generator (same architecture, so the fine-tune, the ONNX export and the runtime are
unchanged) is trained on an endless, seeded stream of procedural materials
(:func:`svbrdf.trainer.procedural.sample_materials`), each turned into a *realistic* flash photo:

1. rendered by the one renderer (:func:`svbrdf.trainer.render.render_maps`) with inverse-square fall-off, a
   random field of view (``fov_deg``) and a flash a little off the lens axis (``light_offset``), half of the
   photos with the physical settings of the benchmark's Mitsuba inputs
   (:func:`svbrdf.runtime.core.render.physical_config`: exact Smith masking, F = F0);
2. recorded by a random camera of :mod:`svbrdf.runtime.core.camera` (exposure that clips bright highlights,
   vignetting, Poisson-Gaussian noise, 8-bit sRGB);
3. half of the batches are ``size`` px crops of ``photo_size`` px photos (the highlight anywhere in the tile, or
   outside it, as in the fine-tune's tiles), the other half whole ``size`` px photos.

Loss: :func:`~svbrdf.trainer.losses.supervised_maps_loss` (per-map L1) + ``lambda_render`` times
:func:`~svbrdf.trainer.losses.relit_loss` (log radiance under the flash and ``render_lights`` random point
lights, rendered with the fine-tune's renderer settings; with ``render_views``, also under random distant views and
lights, grazing ones included) + ``lambda_grad`` times :func:`~svbrdf.trainer.losses.gradient_loss` (detail of the
normal and roughness maps) + ``lambda_amount`` times :func:`~svbrdf.trainer.losses.detail_amount_loss` (their
amount of local variation). Adam with a cosine learning-rate decay.

GPU scale (issue 26): with ``batched`` the materials, photos and relighting geometry of a batch are built with torch
on the training device (:func:`simulate_photos_batched`, :func:`svbrdf.trainer.camera.expose_batch`), ``bf16``
runs the generator under bfloat16 autocast, ``log_every`` averages the log over that many iterations (one read-back
per record), and ``compact_checkpoint`` stores weights in float16 and Adam's moments in bfloat16.
:meth:`PriorTrainer.run` takes a wall-clock limit (``max_seconds``) after which it saves and stops; the next run
resumes the checkpoint on any device. :data:`PRIOR_PRESETS` names the settings: ``v1`` (the shipped recipe) and
``v2`` (the U-Net candidate with all of the above, for a GPU).

Weight averaging (``ema`` > 0): beside the weights it trains, the trainer keeps an exponential moving average of
them (:class:`torch.optim.swa_utils.AveragedModel`, updated after every optimiser step); that average is the model:
the held-out evaluations, :attr:`PriorTrainer.model`, and every consumer of the checkpoint
(:func:`svbrdf.trainer.checkpoint.generator_from_checkpoint`, the fine-tune's ``--init``, the export,
:func:`~svbrdf.trainer.checkpoint.clean_checkpoint`) use it; the checkpoint keeps the trained weights too
(``generator``, what a resume continues) and the average as ``generator_ema``.

:class:`PriorTrainer` writes resumable, atomic checkpoints in the project's checkpoint format
(:mod:`svbrdf.trainer.checkpoint`): ``stage="prior"``, no discriminator, ``train_config`` = the fine-tune preset
that starts from it (so ``svbrdf-train finetune --init``, ``svbrdf-preview --refine`` and the benchmark use it as
any stage-one checkpoint), and the prior's own settings under ``prior_config``. ``svbrdf-train prior`` is its CLI.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np
import torch

from svbrdf.runtime.core.camera import CAMERA_KEYS, REALISTIC, Camera, expose
from svbrdf.runtime.inference.manifest import PRIOR_STAGE
from svbrdf.runtime.core.maps import SLICES
from svbrdf.runtime.core.render import RenderConfig, light_vectors, physical_config
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer.config import resolve
from svbrdf.runtime.core.render import camera_position
from svbrdf.trainer.camera import expose_batch, frame_radius2
from svbrdf.trainer.device import bf16_support, pick_device, set_threads, to_device
from svbrdf.trainer.losses import (DETAIL_WINDOWS, detail_amount_loss, gradient_loss, relit_loss, slope_correlation_loss,
                                    supervised_maps_loss)
from svbrdf.trainer.models import Generator, GeneratorConfig, height_to_normal, linearise_height
from svbrdf.trainer.procedural import FAMILIES, PARAMS, coarse_height, normal_scale, sample_materials
from svbrdf.trainer.render import direction_vectors, plane_grid, point_light_vectors, render_maps

PathLike = Union[str, Path]
STAGE = PRIOR_STAGE
#: Callback ``(trainer, record) -> stop?`` called after every iteration.
Callback = Callable[["PriorTrainer", Dict[str, Any]], bool]


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
        crop_context: a U-Net (``generator.arch="unet"``) sees each crop with its whole photo's context
            (:meth:`~svbrdf.trainer.models.Generator.photo_context`, without gradient), as the fine-tune's tiles
            (:attr:`svbrdf.trainer.config.TrainConfig.photo_context`) and the prediction's windows do. Costs a
            forward pass of the encoder over the ``photo_size`` photos per crop batch. Off in both presets:
            continuing the CPU v2 candidate with it for 1,500 iterations made the stage one worse on its held-out
            whole photos (roughness RMSE 0.226 -> 0.446; docs/benchmarks/refine-detail/photo-context).
        batch: materials per iteration.
        iters: iterations.
        lr, lr_min, betas: Adam; the learning rate decays from ``lr`` to ``lr_min`` on a cosine over ``iters``.
        seed: seeds the weights and the material stream.
        fov_deg: range of the photos' horizontal field of view, degrees (uniform).
        light_offset: the flash sits up to this far from the lens, in each of x and y (half photo widths).
        physical_share: fraction of photos rendered with :func:`~svbrdf.runtime.core.render.physical_config`.
        camera: ranges of the camera model (default :data:`svbrdf.runtime.core.camera.REALISTIC`). ``white`` (the
            highlight roll-off's white point, :func:`svbrdf.runtime.core.camera.roll_off`) may be left out: (1, 1), a
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
            2-25 degrees), so a network trained on them alone gives every photo a relief (docs/benchmarks/prior-v2/
            flat/). 0 = none (every run before 2026-11-27): no draw is made, the stream is
            unchanged. The validation batch never has them (its figures stay comparable along a run).
        black_share: fraction of the drawn dielectric materials whose base colour is darkened to a near-black mean
            (:data:`BLACK_LEVEL`, log-uniform): black plastic, lacquer and polished black stone. Without them a
            near-black base colour means a metal in the procedural stream (22 of 23 such materials in 512 draws),
            and v2 reads every black material as one (docs/benchmarks/prior-v2/chunks/README.md, chunk 11). 0 =
            none (every run before 2026-11-27, fourth session): no draw is made, the stream is unchanged. The
            validation batch never has them.
        coarse_share: fraction of the drawn materials given a coarse relief on top of their own
            (:func:`add_coarse_relief`: uneven stones or a smooth warp a few features across,
            :func:`svbrdf.trainer.procedural.coarse_height`): flagstones, brick walls, warped tiles, dented sheets. Every procedural family's relief
            is fine (94 % of its slope variance within a 4 px band at 256 px, against 50 % in the shared sets'
            materials), and the v2 stage one reads coarse relief at a slope correlation of 0.08 on those
            (docs/benchmarks/prior-v2/relief-gap/). Applied before ``flat_share``, so a flat material stays flat.
            0 = none (every run before 2026-11-27, eighth session): no draw is made, the stream is unchanged. The
            validation batch never has them.
    """

    generator: GeneratorConfig = field(default_factory=lambda: GeneratorConfig(width=0.25, train_encoder=True))
    finetune_preset: str = "fast"
    size: int = 128
    photo_size: int = 256
    crop_share: float = 0.5
    crop_context: bool = False
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
        need(not self.crop_context or self.generator.arch == "unet", "crop_context needs generator.arch='unet'")
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
        need(self.material_reuse >= 1, f"material_reuse must be >= 1, got {self.material_reuse}")
        need(0.0 <= self.ema < 1.0, f"ema must be in [0, 1), got {self.ema}")
        need(0.0 <= self.flat_share < 1.0, f"flat_share must be in [0, 1), got {self.flat_share}")
        need(0.0 <= self.black_share < 1.0, f"black_share must be in [0, 1), got {self.black_share}")
        need(0.0 <= self.coarse_share <= 1.0, f"coarse_share must be in [0, 1], got {self.coarse_share}")
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


def _uniform(rng: torch.Generator, lo: float, hi: float) -> float:
    return float(lo + (hi - lo) * torch.rand((), generator=rng).item())


def _draw_camera(config: PriorConfig, rng: torch.Generator) -> Dict[str, float]:
    """One photo's camera parameters from ``config.camera``'s ranges (:data:`~svbrdf.runtime.core.camera.CAMERA_KEYS`,
    in order); ``white`` is drawn only when its range is not (1, 1), else it is 1 and nothing is drawn for it."""
    keys = CAMERA_KEYS if config.camera["white"] != (1.0, 1.0) else CAMERA_KEYS[:-1]
    return {"white": 1.0, **{k: _uniform(rng, *config.camera[k]) for k in keys}}


def lights_for(config: RenderConfig, n: int, rng: torch.Generator) -> List[Tuple[float, float, float]]:
    """``n`` random point lights for relighting: x, y uniform in [-0.8, 0.8] half-widths, height the camera's
    times [0.7, 1.3]."""
    d = config.camera_distance
    return [(_uniform(rng, -0.8, 0.8), _uniform(rng, -0.8, 0.8), d * _uniform(rng, 0.7, 1.3)) for _ in range(n)]


def view_light_directions(n: int, config: "PriorConfig", rng: torch.Generator) -> torch.Tensor:
    """``n`` random (view, light) pairs of distant directions for the relighting loss: (n, 2, 3) unit vectors.

    Each direction's polar angle from the normal (+z) is in ``config.grazing_deg`` with probability
    ``config.grazing_share``, else uniform in cosine up to the start of that range; azimuths are uniform. Half of
    the pairs (every other one) put the light in the mirror direction of the view, so the highlight is in view.
    """
    lo, hi = (math.radians(a) for a in config.grazing_deg)
    out = torch.empty(n, 2, 3)
    for i in range(n):
        dirs = []
        for _ in range(2):
            if _uniform(rng, 0.0, 1.0) < config.grazing_share:
                theta = _uniform(rng, lo, hi)
            else:
                theta = math.acos(_uniform(rng, math.cos(lo), 1.0))
            phi = _uniform(rng, 0.0, 2.0 * math.pi)
            dirs.append((math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)))
        if i % 2 == 1:  # mirror configuration: the light reflected about the normal
            dirs[1] = (-dirs[0][0], -dirs[0][1], dirs[0][2])
        out[i] = torch.tensor(dirs)
    return out


def _geometry(h: int, w: int, light_pos, config: RenderConfig) -> Tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    v, l, d2 = light_vectors(h, w, light_pos, config)
    return tuple(torch.from_numpy(a).permute(2, 0, 1)[None] for a in (v, l, d2))


def simulate_photos(maps: torch.Tensor, config: PriorConfig, rng: torch.Generator,
                    crop: Optional[int] = None) -> Tuple[torch.Tensor, torch.Tensor, List[Dict[str, Any]]]:
    """Realistic flash photos of ``maps`` (see the module docstring, steps 1-3).

    Args:
        maps: (B, 8, P, P) ground-truth maps (CPU).
        config: the prior settings (field of view, flash offset, renderer mix, camera ranges).
        rng: the stream's generator (all draws come from it, so the stream is reproducible and resumable).
        crop: side of a random crop taken from each photo (and its maps); None = the whole photo.

    Returns:
        ``(photos, maps, draws)``: (B, 3, S, S) linear photos in [0, 1], the (B, 8, S, S) maps under them, and
        per photo ``{"fov_deg", "light", "physical", "camera"}``.
    """
    b, _, h, w = maps.shape
    base = resolve(config.finetune_preset).render_config.replace(falloff=True)
    photos, crops, draws = [], [], []
    for i in range(b):
        fov = _uniform(rng, *config.fov_deg)
        physical = _uniform(rng, 0.0, 1.0) < config.physical_share
        rc = base.replace(fov_deg=fov)
        rc = physical_config(rc) if physical else rc
        o = config.light_offset
        light = (_uniform(rng, -o, o), _uniform(rng, -o, o), rc.camera_distance)
        v, l, d2 = _geometry(h, w, light, rc)
        with torch.no_grad():
            radiance = render_maps(maps[i:i + 1].float(), v, l, rc, d2)[0].permute(1, 2, 0).numpy()
        cam = Camera(**_draw_camera(config, rng), quantize=True)
        seed = int(torch.randint(0, 2 ** 31 - 1, (), generator=rng))
        photo = torch.from_numpy(expose(radiance, cam, seed=seed)).permute(2, 0, 1)
        m = maps[i]
        if crop is not None and crop < h:
            y0 = int(torch.randint(0, h - crop + 1, (), generator=rng))
            x0 = int(torch.randint(0, w - crop + 1, (), generator=rng))
            photo, m = photo[:, y0:y0 + crop, x0:x0 + crop], m[:, y0:y0 + crop, x0:x0 + crop]
        photos.append(photo)
        crops.append(m)
        draws.append({"fov_deg": fov, "light": light, "physical": physical, "camera": cam.to_dict()})
    return torch.stack(photos).contiguous(), torch.stack(crops).contiguous(), draws


def simulate_photos_batched(maps: torch.Tensor, config: PriorConfig, rng: torch.Generator,
                            crop: Optional[int] = None) -> Tuple[torch.Tensor, torch.Tensor, List[Dict[str, Any]]]:
    """:func:`simulate_photos` for a whole batch at once, with torch on ``maps``' device (``config.batched``).

    The same draws per photo (field of view, renderer mix, flash offset, camera, crop) from ``rng`` on the host;
    the geometry (:func:`svbrdf.trainer.render.point_light_vectors`), the rendering and the camera
    (:func:`svbrdf.trainer.camera.expose_batch`, its noise from a generator on the device seeded from ``rng``)
    run on the device, with nothing read back. Returns what :func:`simulate_photos` returns.
    """
    b, _, h, w = maps.shape
    dev = maps.device
    base = resolve(config.finetune_preset).render_config.replace(falloff=True)
    cams, lights, physical, cam_draws, draws, boxes = [], [], [], [], [], []
    for _ in range(b):
        fov = _uniform(rng, *config.fov_deg)
        phys = _uniform(rng, 0.0, 1.0) < config.physical_share
        rc = base.replace(fov_deg=fov)
        o = config.light_offset
        light = (_uniform(rng, -o, o), _uniform(rng, -o, o), rc.camera_distance)
        cam = _draw_camera(config, rng)
        cams.append(camera_position(rc))
        lights.append(light)
        physical.append(phys)
        cam_draws.append(cam)
        draws.append({"fov_deg": fov, "light": light, "physical": phys,
                      "camera": Camera(**cam, quantize=True).to_dict()})
    seed = int(torch.randint(0, 2 ** 31 - 1, (), generator=rng))
    pos, r2, maps = plane_grid(h, w, dev), None, maps.float()
    if crop is not None and crop < h:
        for _ in range(b):
            boxes.append((int(torch.randint(0, h - crop + 1, (), generator=rng)),
                          int(torch.randint(0, w - crop + 1, (), generator=rng))))
        # Only the crops are photographed: their pixels' positions in the whole photo (flash geometry) and in the
        # frame (vignetting) are kept, so they equal crops of the whole photographs up to the noise's draw.
        rows, cols = (to_device(torch.tensor(boxes)[:, k, None] + torch.arange(crop), dev) for k in (0, 1))
        pos, r2, maps = (_windows(t, rows, cols) for t in (pos, frame_radius2(h, w, dev), maps))
    v, l, d2 = point_light_vectors(pos, to_device(np.stack(cams), dev),
                                   to_device(np.asarray(lights, dtype=np.float32), dev))
    with torch.no_grad():
        radiance = torch.empty(b, 3, *maps.shape[-2:], device=dev)
        for flag in (False, True):
            idx = [i for i in range(b) if physical[i] == flag]
            if idx:
                rc = physical_config(base) if flag else base
                sel = to_device(torch.tensor(idx), dev)
                radiance[sel] = render_maps(maps[sel], v[sel], l[sel], rc, d2[sel])
        noise = torch.Generator(device=dev).manual_seed(seed)
        param = {k: torch.tensor([c[k] for c in cam_draws]) for k in CAMERA_KEYS}
        photos = expose_batch(radiance, generator=noise, radius2_map=r2, **param)
    return photos.contiguous(), maps.contiguous(), draws


def _windows(t: torch.Tensor, rows: torch.Tensor, cols: torch.Tensor) -> torch.Tensor:
    """(B, C, c, c) contiguous windows of ``t`` (B or 1, C, H, W), window i on rows ``rows[i]`` and columns
    ``cols[i]`` ((B, c) index tensors on ``t``'s device), gathered in one op (the crops of :func:`photograph` and
    :func:`simulate_photos_batched`)."""
    b = rows.shape[0]
    idx = torch.arange(b, device=t.device) if t.shape[0] > 1 else torch.zeros(b, dtype=torch.long, device=t.device)
    return t[idx[:, None, None], :, rows[:, :, None], cols[:, None, :]].permute(0, 3, 1, 2).contiguous()


def sample_batch(config: PriorConfig, rng: torch.Generator, batch: Optional[int] = None,
                 device: Optional[Union[str, torch.device]] = None
                 ) -> Tuple[torch.Tensor, torch.Tensor, Dict[str, Any]]:
    """One training batch: ``(photos (B, 3, S, S), maps (B, 8, S, S), info)`` with ``S = config.size``.

    With ``config.batched`` it is built on ``device`` (default CPU) by :func:`simulate_photos_batched`; otherwise
    on the CPU photo by photo (:func:`simulate_photos`, v1), whatever ``device``.
    """
    return photograph(config, rng, *draw_materials(config, rng, batch, device))


def draw_materials(config: PriorConfig, rng: torch.Generator, batch: Optional[int] = None,
                   device: Optional[Union[str, torch.device]] = None) -> Tuple[torch.Tensor, List[str], bool]:
    """The materials of one batch (first half of :func:`sample_batch`): ``(maps, families, crop)``, the maps at
    ``photo_size`` when the batch is cropped (``crop``), else at ``size``."""
    n = config.batch if batch is None else batch
    crop = _uniform(rng, 0.0, 1.0) < config.crop_share
    side = config.photo_size if crop else config.size
    maps, families = sample_materials(n, side, rng, config.families, device=device if config.batched else None)
    if config.coarse_share > 0:
        maps = add_coarse_relief(maps, torch.rand(n, generator=rng) < config.coarse_share, rng)
    if config.flat_share > 0:
        maps = flatten_normals(maps, torch.rand(n, generator=rng) < config.flat_share)
    if config.black_share > 0:
        chosen = torch.rand(n, generator=rng) < config.black_share
        lo, hi = (math.log(v) for v in BLACK_LEVEL)
        level = torch.exp(lo + (hi - lo) * torch.rand(n, generator=rng))
        maps = blacken_dielectrics(maps, chosen, level)
    return maps, families, crop


#: (lo, hi) of the mean linear base colour a ``black_share`` material is darkened to (log-uniform): below the
#: procedural dielectric classes' darkest (``PARAMS["value_srgb"]`` 0.1, 0.01 linear), where only metals were.
BLACK_LEVEL = (0.001, 0.01)


def blacken_dielectrics(maps: torch.Tensor, chosen: torch.Tensor, level: torch.Tensor) -> torch.Tensor:
    """``maps`` (B, 8, H, W) with the base colour of each ``chosen`` dielectric material ((B,) bool, on the host;
    dielectric: a median specular below the middle of the gap between the dielectric and metal ranges of
    :data:`svbrdf.trainer.procedural.PARAMS`) scaled so that its mean is at most ``level`` ((B,) linear, on the
    host); the others unchanged. Tensor ops on ``maps``' device only (nothing read back from a GPU)."""
    if not bool(chosen.any()):
        return maps
    metal_from = (PARAMS["spec_dielectric_tail"][1] + PARAMS["spec_metal"][0]) / 2.0
    d, sp = SLICES["diffuse"], SLICES["specular"]
    dielectric = (maps[:, sp].flatten(1).median(1).values < metal_from).to(maps.dtype)
    pick = to_device(chosen.to(torch.float32), maps.device).to(maps.dtype) * dielectric
    mean = maps[:, d].mean((1, 2, 3)).clamp_min(1e-6)
    factor = torch.clamp(to_device(level.to(torch.float32), maps.device).to(maps.dtype) / mean, max=1.0)
    scale = (1.0 - pick + pick * factor)[:, None, None, None]
    return torch.cat([maps[:, :d.start], maps[:, d] * scale, maps[:, d.stop:]], 1)


def add_coarse_relief(maps: torch.Tensor, chosen: torch.Tensor, rng: torch.Generator) -> torch.Tensor:
    """``maps`` (B, 8, H, W), square, with a coarse relief added to the normals of the ``chosen`` materials ((B,)
    bool, on the host); the others unchanged.

    Per chosen material, in order: :func:`~svbrdf.trainer.procedural.coarse_height` (uneven stones or a smooth
    warp, drawn from ``rng``) turned into normals of its mean tilt (:func:`~svbrdf.trainer.procedural.normal_scale`,
    :func:`~svbrdf.trainer.models.height_to_normal`), whose slopes are added to the material's own (``n_x / n_z``,
    ``n_y / n_z``: the two heights summed). Nothing is drawn for a material that is not chosen. Built on ``maps``'
    device (the random tables are drawn on the host).
    """
    if not bool(chosen.any()):
        return maps
    sl = SLICES["normal"]
    side = maps.shape[-1]
    normals = []
    for i in range(maps.shape[0]):
        n = maps[i:i + 1, sl]
        if bool(chosen[i]):
            with torch.device(maps.device):
                height, tilt = coarse_height(side, rng)
            height = height[None, None].to(maps.dtype)
            c = height_to_normal(height, normal_scale(height, tilt).to(maps.dtype))
            z = n[:, 2:].clamp_min(1e-3)
            m = torch.cat([n[:, :2] / z + c[:, :2] / c[:, 2:], torch.ones_like(z)], 1)
            n = m / m.norm(dim=1, keepdim=True)
        normals.append(n)
    return torch.cat([maps[:, :sl.start], torch.cat(normals), maps[:, sl.stop:]], 1)


def flatten_normals(maps: torch.Tensor, chosen: torch.Tensor) -> torch.Tensor:
    """``maps`` (B, 8, H, W) with the normals of the ``chosen`` materials ((B,) bool, on the host) made flat
    (0, 0, 1); the others unchanged. Tensor ops on ``maps``' device only (nothing read back from a GPU)."""
    if not bool(chosen.any()):
        return maps
    pick = to_device(chosen.to(torch.float32), maps.device)[:, None, None, None]
    up = to_device(torch.tensor([0.0, 0.0, 1.0]), maps.device)[None, :, None, None]
    sl = SLICES["normal"]
    normal = maps[:, sl] * (1.0 - pick) + up * pick
    return torch.cat([maps[:, :sl.start], normal, maps[:, sl.stop:]], 1)


def photograph(config: PriorConfig, rng: torch.Generator, maps: torch.Tensor, families: List[str], crop: bool
               ) -> Tuple[torch.Tensor, torch.Tensor, Dict[str, Any]]:
    """Photos of materials from :func:`draw_materials` (second half of :func:`sample_batch`).

    With ``config.crop_context`` a crop batch's ``info`` also holds ``"whole"``, the (B, 3, P, P) photos the crops
    come from, and ``"origins"``, the (B, 2) top-left (row, column) of each crop in its photo.
    """
    simulate = simulate_photos_batched if config.batched else simulate_photos
    info: Dict[str, Any] = {"families": families, "crop": crop}
    if crop and config.crop_context and config.size < maps.shape[-1]:
        whole, maps, draws = simulate(maps, config, rng)
        s, n = config.size, maps.shape[-1] - config.size + 1
        origins = torch.tensor([[int(torch.randint(0, n, (), generator=rng)) for _ in range(2)] for _ in draws])
        rows, cols = (to_device(origins[:, k, None] + torch.arange(s), whole.device) for k in (0, 1))
        photos, maps = _windows(whole, rows, cols), _windows(maps, rows, cols)
        info.update(whole=whole, origins=origins)
        return photos, maps, {**info, "draws": draws}
    photos, maps, draws = simulate(maps, config, rng, crop=config.size if crop else None)
    return photos, maps, {**info, "draws": draws}


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
    (``amount``, with ``config.lambda_amount > 0``: :func:`~svbrdf.trainer.losses.detail_amount_loss`), pattern of
    the normals' slopes (``slope``, with ``config.lambda_slope > 0``: :func:`~svbrdf.trainer.losses.slope_correlation_loss`)
    and ``total``.

    Relighting renders both map sets with the fine-tune's renderer settings under the flash and
    ``config.render_lights`` random lights (:func:`lights_for`), on the training image as a whole photo, and
    under ``config.render_views`` random distant (view, light) pairs (:func:`view_light_directions`, no fall-off);
    ``render`` is the mean over all these renderings, each pair compared by ``relit`` (:func:`relit_pair`, or its
    :class:`CompiledRelit`). ``grad`` (with ``config.lambda_grad > 0``) is
    :func:`~svbrdf.trainer.losses.gradient_loss` on the normal and roughness maps. With ``config.batched`` the
    geometry is computed with torch on ``pred``'s device (the same formula as the numpy one).
    """
    terms = supervised_maps_loss(pred, target)
    out = {f"maps/{k}": v for k, v in terms.items() if k != "total"}
    total = terms["total"]
    if config.lambda_render > 0:
        rc = resolve(config.finetune_preset).render_config.replace(falloff=True)
        h, w = pred.shape[-2:]
        rel = []
        lights = [None] + lights_for(rc, config.render_lights, rng)
        if config.batched:
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
        if config.render_views:
            distant = rc.replace(falloff=False)
            pairs = to_device(view_light_directions(config.render_views, config, rng), pred.device)
            for pair in pairs:
                v, l = (direction_vectors(d[None], h, w) for d in pair)
                rel.append(relit(pred, target, v, l, distant))
        out["render"] = torch.stack(rel).mean()
        total = total + config.lambda_render * out["render"]
    if config.lambda_grad > 0:
        out["grad"] = gradient_loss(pred, target)
        total = total + config.lambda_grad * out["grad"]
    if config.lambda_amount > 0:
        out["amount"] = detail_amount_loss(pred, target, config.amount_maps, config.amount_windows)
        total = total + config.lambda_amount * out["amount"]
    if config.lambda_slope > 0:
        out["slope"] = slope_correlation_loss(pred, target)
        total = total + config.lambda_slope * out["slope"]
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


class PriorTrainer:
    """Train the stage-one generator on the procedural stream.

    Args:
        config: settings.
        device: torch device name (default CUDA if available, else CPU).
        threads: CPU threads (default: all cores).
        checkpoint_path: where :meth:`run` saves checkpoints (None = never).
        log_path: JSONL log, one line per iteration (None = none).
        callback: :data:`Callback`.
        compile: compare the relit renderings through :class:`CompiledRelit` (faster on a CPU; same loss to float
            rounding).
    """

    def __init__(self, config: PriorConfig, *, device: Optional[str] = None, threads: Optional[int] = None,
                 checkpoint_path: Optional[PathLike] = None, log_path: Optional[PathLike] = None,
                 callback: Optional[Callback] = None, compile: bool = False):
        config.validate()
        self.config = config
        self.device = pick_device(device)
        if self.device.type == "cpu":
            set_threads(threads)
        self.checkpoint_path = None if checkpoint_path is None else Path(checkpoint_path)
        self.log_path = None if log_path is None else Path(log_path)
        self.callback = callback
        torch.manual_seed(config.seed)
        #: The networks' memory layout: channels-last on a CPU, where oneDNN's convolutions (forward and backward)
        #: take half the time in it (one thread, v2 batch: 5.6-6.2 -> 3.2 s a step, profiled); as is on a GPU (not measured).
        self.memory_format = torch.channels_last if self.device.type == "cpu" else torch.contiguous_format
        self.generator = Generator(config.generator).to(self.device, memory_format=self.memory_format)
        self.optimizer = torch.optim.Adam([p for p in self.generator.parameters() if p.requires_grad],
                                          lr=config.lr, betas=config.betas)
        self.rng = torch.Generator().manual_seed(config.seed)
        self.step = 0
        self.history: List[Dict[str, Any]] = []
        self.evals: List[Dict[str, Any]] = []
        self.seconds = 0.0
        self.interrupted = False
        #: Set (by a signal handler, another thread) to end :meth:`run` after the current iteration: it writes the
        #: (possibly short) log record and the checkpoint, sets ``interrupted`` and returns; resume continues.
        self.stop_requested = False
        #: True when the last :meth:`run` stopped at its wall-clock limit (checkpoint saved, resumable).
        self.timed_out = False
        self.bf16, self.bf16_note = (bf16_support(self.device) if config.bf16 else (False, None))
        self._relit: Callable[..., torch.Tensor] = CompiledRelit() if compile else relit_pair
        self._eval_set: Optional[Tuple[torch.Tensor, torch.Tensor]] = None
        self._materials: Optional[Tuple[torch.Tensor, List[str], bool]] = None
        self.averaged: Optional[torch.optim.swa_utils.AveragedModel] = None
        self._average()

    def _average(self) -> None:
        """(Re)start the weights' moving average at the current weights (``config.ema`` > 0), else none."""
        from torch.optim.swa_utils import AveragedModel, get_ema_multi_avg_fn

        self.averaged = (AveragedModel(self.generator, multi_avg_fn=get_ema_multi_avg_fn(self.config.ema),
                                       use_buffers=True) if self.config.ema > 0 else None)

    @property
    def model(self) -> Generator:
        """The model this run has learned: the weights' moving average with ``ema`` > 0 (once it has been updated),
        else the trained weights."""
        if self.averaged is None or int(self.averaged.n_averaged) == 0:
            return self.generator
        return self.averaged.module

    # ------------------------------------------------------------------ schedule
    def lr_at(self, step: int) -> float:
        """Cosine decay from ``lr`` (step 0) to ``lr_min`` (step ``iters``)."""
        c = self.config
        t = min(max(step, 0), c.iters) / c.iters
        return c.lr_min + 0.5 * (c.lr - c.lr_min) * (1.0 + math.cos(math.pi * t))

    # ------------------------------------------------------------------ training
    def _step(self) -> Tuple[Dict[str, torch.Tensor], Dict[str, Any]]:
        """One optimiser step on a fresh batch: the (detached, on-device) loss terms and the host-side facts."""
        t0 = time.perf_counter()
        if self._materials is None or self.step % self.config.material_reuse == 0:
            self._materials = draw_materials(self.config, self.rng, device=self.device)
        photos, maps, info = photograph(self.config, self.rng, *self._materials)
        t_data = time.perf_counter() - t0
        photos, maps = photos.to(self.device, memory_format=self.memory_format), maps.to(self.device)
        for group in self.optimizer.param_groups:
            group["lr"] = self.lr_at(self.step)
        self.generator.train()
        with torch.autocast(self.device.type, dtype=torch.bfloat16, enabled=self.bf16):
            if "whole" in info:  # crop_context: the crops see their whole photos' flash spot and global vectors
                with torch.no_grad():
                    ctx = self.generator.photo_context(info["whole"].to(self.device))
                pred = self.generator(photos, ctx, info["origins"].to(self.device))
            else:
                pred = self.generator(photos)
        terms = prior_loss(pred.float(), maps, self.config, self.rng, relit=self._relit)
        self.optimizer.zero_grad(set_to_none=True)
        if self.config.batched:
            # No read-back: a non-finite loss zeroes its gradients on the device (Adam then takes a step with a
            # zero gradient) and is counted at the next log record.
            finite = torch.isfinite(terms["total"])
            terms["total"].backward()
            for p in self.generator.parameters():
                if p.grad is not None:
                    p.grad = torch.where(finite, p.grad, torch.zeros_like(p.grad))
            self.optimizer.step()
            skipped: Any = ~finite
        else:
            skipped = not torch.isfinite(terms["total"])
            if not skipped:
                terms["total"].backward()
                self.optimizer.step()
        if self.averaged is not None:
            self.averaged.update_parameters(self.generator)
        self.step += 1
        facts = {"step": self.step, "lr": self.lr_at(self.step - 1), "crop": info["crop"], "data_seconds": t_data,
                 "seconds": time.perf_counter() - t0, "skipped": skipped}
        return {k: v.detach() for k, v in terms.items()}, facts

    def iteration(self) -> Dict[str, Any]:
        """One optimiser step on a fresh batch; returns the log record."""
        terms, facts = self._step()
        rec: Dict[str, Any] = {k: facts[k] for k in ("step", "lr", "crop", "data_seconds", "seconds")}
        rec.update({k: (float(v) if torch.isfinite(v) else None) for k, v in terms.items()})
        if facts["skipped"]:
            rec["skipped"] = True
        return rec

    def _record(self, window: List[Tuple[Dict[str, torch.Tensor], Dict[str, Any]]], seconds: float
                ) -> Dict[str, Any]:
        """The mean log record of ``window`` (``log_every`` > 1): terms averaged over its finite iterations,
        ``iters`` in it, ``samples`` seen so far, ``seconds`` of wall time and ``s_per_iter``."""
        last = window[-1][1]
        rec: Dict[str, Any] = {"step": last["step"], "lr": last["lr"], "iters": len(window),
                               "samples": last["step"] * self.config.batch, "seconds": seconds,
                               "s_per_iter": seconds / len(window),
                               "data_seconds": sum(f["data_seconds"] for _, f in window) / len(window),
                               "crop_share": sum(bool(f["crop"]) for _, f in window) / len(window)}
        keys = window[0][0].keys()
        stacked = {k: torch.stack([t[k] for t, _ in window]) for k in keys}
        for k, v in stacked.items():
            ok = torch.isfinite(v)
            rec[k] = float(v[ok].mean()) if bool(ok.any()) else None
        skips = int(sum(int(f["skipped"]) for _, f in window))
        if skips:
            rec["skipped"] = skips
        return rec

    def eval_set(self) -> Tuple[torch.Tensor, torch.Tensor]:
        """The fixed validation batch: whole ``size`` px photos from their own seed (never a training batch)."""
        if self._eval_set is None:
            rng = torch.Generator().manual_seed(10_000_019 + self.config.seed)
            cfg = dataclasses.replace(self.config, crop_share=0.0, flat_share=0.0, black_share=0.0, coarse_share=0.0)
            photos, maps, _ = sample_batch(cfg, rng, batch=self.config.eval_batch, device=self.device)
            self._eval_set = photos.to(self.device), maps.to(self.device)
        return self._eval_set

    @property
    def compile_note(self) -> Optional[str]:
        """Why ``compile`` fell back to eager (None when it was not asked for or works)."""
        return getattr(self._relit, "note", None)

    @torch.no_grad()
    def evaluate(self) -> Dict[str, float]:
        """Map errors of :attr:`model` on the validation batch (:func:`map_errors`)."""
        photos, maps = self.eval_set()
        self.model.eval()
        return map_errors(self.model(photos), maps)

    def run(self, max_seconds: Optional[float] = None) -> List[Dict[str, Any]]:
        """Train up to ``config.iters`` (resumes from ``step``); checkpoints, log, evaluations, callback.

        Args:
            max_seconds: wall-clock limit of this call. Checked after every iteration that starts a new draw of
                materials (every ``material_reuse`` iterations): past it, the run writes the (possibly short) log
                record, saves its checkpoint and stops with ``timed_out`` set; a later ``resume`` continues the
                same schedule. Log records fall on multiples of ``log_every``, so a resumed run realigns its
                records after a short one.
        """
        c = self.config
        log = None if self.log_path is None else open(self.log_path, "a", encoding="utf-8")
        start = time.perf_counter()
        self.timed_out = False
        window: List[Tuple[Dict[str, torch.Tensor], Dict[str, Any]]] = []
        window_start = time.perf_counter()
        try:
            while self.step < c.iters:
                if c.log_every == 1:
                    rec = self.iteration()
                else:
                    window.append(self._step())
                    due = (self.step % c.log_every == 0 or self.step >= c.iters
                           or (max_seconds is not None and self.step % c.material_reuse == 0
                               and time.perf_counter() - start >= max_seconds)
                           or (c.eval_every and self.step % c.eval_every == 0)
                           or (c.checkpoint_every and self.step % c.checkpoint_every == 0)
                           or self.stop_requested)
                    if not due:
                        continue
                    rec = self._record(window, time.perf_counter() - window_start)
                    window, window_start = [], time.perf_counter()
                self.seconds += rec["seconds"]
                if c.eval_every and (self.step % c.eval_every == 0 or self.step == c.iters):
                    ev = {"step": self.step, **self.evaluate()}
                    self.evals.append(ev)
                    rec["eval"] = ev
                self.history.append({k: v for k, v in rec.items() if k != "eval"})
                if log is not None:
                    import json

                    log.write(json.dumps(rec) + "\n")
                    log.flush()
                stop = (bool(self.callback(self, rec)) if self.callback else False) or self.stop_requested
                at_end = self.step == c.iters
                late = (max_seconds is not None and time.perf_counter() - start >= max_seconds and not at_end
                        and self.step % c.material_reuse == 0)
                if self.checkpoint_path is not None and (
                        at_end or stop or late or (c.checkpoint_every and self.step % c.checkpoint_every == 0)):
                    self.save()
                if stop:
                    self.interrupted = True
                    break
                if late:
                    self.timed_out = True
                    break
        finally:
            if log is not None:
                log.close()
        return self.history

    # ------------------------------------------------------------------ checkpoints
    def checkpoint(self) -> Dict[str, Any]:
        """The state as a project checkpoint (see the module docstring)."""
        finetune = resolve(self.config.finetune_preset)
        ckpt = ckpt_io.build_checkpoint(
            generator=self.generator, discriminator=None, train_config=finetune.to_dict(), stage=STAGE,
            step=self.step, iters=self.config.iters, optimizers={"g": self.optimizer}, history=self.history,
            photo={"name": "procedural materials", "sha256": None, "height": self.config.size,
                   "width": self.config.size},
            rng={"torch": torch.get_rng_state(), "stream": self.rng.get_state()},
            notes=[f"stage one learned from procedural materials ({self.step} iterations of {self.config.batch})"])
        ckpt["prior_config"] = self.config.to_dict()
        ckpt["evals"] = [dict(e) for e in self.evals]
        ckpt["seconds"] = float(self.seconds)
        if self.averaged is not None:
            ckpt["generator_ema"] = {k: v.detach().float().cpu().clone() if v.is_floating_point() else v.cpu().clone()
                                     for k, v in self.averaged.module.state_dict().items()}
            ckpt["ema_updates"] = int(self.averaged.n_averaged)
        if self.config.compact_checkpoint:
            compact(ckpt)
        return ckpt

    def save(self, path: Optional[PathLike] = None) -> Path:
        """Write a checkpoint atomically to ``path`` (default ``checkpoint_path``)."""
        path = Path(path) if path is not None else self.checkpoint_path
        if path is None:
            raise ValueError("no checkpoint path")
        return ckpt_io.save_checkpoint(path, self.checkpoint())

    def linearise_height(self) -> float:
        """Switch the generator's height to ``"linear"`` where it stands (:func:`~svbrdf.trainer.models.linearise_height`
        at the validation batch) and record it in ``config.generator``, so checkpoints resume linear. Returns the slope
        ratio ``k``. For a run resumed from a checkpoint whose tanh height saturated (the v2 run at 4745 iterations)."""
        k = linearise_height(self.generator, self.eval_set()[0])
        self.config = dataclasses.replace(self.config, generator=self.generator.cfg)
        self._average()  # the average restarts at the converted weights
        return k

    def load_resume(self, ckpt: Mapping[str, Any], source: PathLike = "checkpoint") -> None:
        """Continue exactly where ``ckpt`` stood (weights, Adam, step, history, stream and torch RNG states)."""
        from svbrdf.runtime.errors import ModelError

        if ckpt.get("stage") != STAGE or "prior_config" not in ckpt:
            raise ModelError(f"{source}: not a prior checkpoint (stage {ckpt.get('stage')!r})")
        if not ckpt.get("optimizers") or not ckpt.get("rng"):
            raise ModelError(f"{source}: cleaned checkpoint (no optimiser/RNG state); cannot resume")
        try:
            self.generator.load_state_dict({k: v.float() if v.is_floating_point() else v
                                            for k, v in ckpt["generator"].items()})
            self.optimizer.load_state_dict(ckpt["optimizers"]["g"])
        except (KeyError, ValueError, RuntimeError) as e:
            raise ModelError(f"{source}: does not fit this configuration ({str(e).splitlines()[0][:120]})") from None
        if self.averaged is not None and ckpt.get("generator_ema") is not None:
            try:
                self.averaged.module.load_state_dict({k: v.float() if v.is_floating_point() else v
                                                      for k, v in ckpt["generator_ema"].items()})
            except (KeyError, ValueError, RuntimeError) as e:
                first = str(e).splitlines()[0][:120]
                raise ModelError(f"{source}: its averaged weights do not fit ({first})") from None
            self.averaged.n_averaged.fill_(int(ckpt.get("ema_updates", 1)))
        elif self.averaged is not None:  # turned on at this resume: the average starts at the resumed weights
            self._average()
        self.step = int(ckpt["step"])
        self.history = [dict(h) for h in ckpt.get("history", [])]
        self.evals = [dict(e) for e in ckpt.get("evals", [])]
        self.seconds = float(ckpt.get("seconds", 0.0))
        torch.set_rng_state(ckpt["rng"]["torch"])
        self.rng.set_state(ckpt["rng"]["stream"])


def compact(ckpt: Dict[str, Any]) -> Dict[str, Any]:
    """Shrink a prior checkpoint in place for ``compact_checkpoint``: float32 weights (and their average) -> float16,
    Adam's moments (``exp_avg``, ``exp_avg_sq``) -> bfloat16 (float16 would flush small second moments to zero).
    Loading casts them back to the parameters' float32 (``load_state_dict`` of the module and of Adam). About 6 bytes
    per parameter instead of 12 (8 with the average): the resumed run differs from an uninterrupted one by these
    roundings only."""
    for key in ("generator", "generator_ema"):
        if ckpt.get(key) is not None:
            ckpt[key] = {k: (v.half() if v.dtype == torch.float32 else v) for k, v in ckpt[key].items()}
    for opt in (ckpt.get("optimizers") or {}).values():
        for state in opt["state"].values():
            for k in ("exp_avg", "exp_avg_sq"):
                if k in state:
                    state[k] = state[k].to(torch.bfloat16)
    ckpt["format_notes"] = "compact: generator float16, Adam moments bfloat16"
    return ckpt


def train_prior(config: PriorConfig, **kw) -> PriorTrainer:
    """Train a prior from scratch (``kw``: see :class:`PriorTrainer`)."""
    trainer = PriorTrainer(config, **kw)
    trainer.run()
    return trainer


def resume_prior(checkpoint: Union[PathLike, Mapping[str, Any]], *, iters: Optional[int] = None,
                 **kw) -> PriorTrainer:
    """Continue a prior run where ``checkpoint`` stood (its settings; ``iters`` may extend it)."""
    source = checkpoint if not isinstance(checkpoint, Mapping) else "checkpoint"
    ckpt = ckpt_io.load_checkpoint(checkpoint) if not isinstance(checkpoint, Mapping) else checkpoint
    cfg = PriorConfig.from_dict(ckpt["prior_config"])
    if iters is not None:
        cfg = dataclasses.replace(cfg, iters=int(iters))
    trainer = PriorTrainer(cfg, **kw)
    trainer.load_resume(ckpt, source)
    trainer.run()
    return trainer


#: Named prior settings (``svbrdf-train prior --preset``): ``v1`` is the shipped recipe (the defaults); ``v2`` the
#: GPU recipe of issue 26: the U-Net candidate (``arch="unet"``, 4 levels, width 0.25: 0.71 M parameters), batches
#: of 32 built on the device, 256 px photos (crops of 512 px ones), bf16, relighting under 3 point lights and 6
#: random views and lights (half of them grazing), the detail term, one log record per 50 iterations, compact
#: checkpoints (about 4.3 MB). ``iters`` is the length of its cosine schedule (extend it with ``--iters`` on resume).
#: The detail-amount term on the roughness (weight 2, 32 px windows at 256 px): without it the recipe's roughness
#: collapsed to its mean (detail 0.05 on held-out procedural materials); continued on one CPU core at 128 px with
#: 16 px windows it placed the roughness pattern (detail 0.46); with 64 px windows too it made blobs and rings at
#: the highlight (docs/benchmarks/prior-v2/cpu-continued/).
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


__all__ = ["PriorConfig", "PriorTrainer", "train_prior", "resume_prior", "sample_batch", "simulate_photos",
           "simulate_photos_batched", "draw_materials", "photograph", "prior_loss", "relit_pair", "CompiledRelit", "map_errors", "lights_for", "view_light_directions", "compact",
           "PRIOR_PRESETS", "prior_preset", "STAGE"]
