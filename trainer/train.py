"""The per-photo GAN training of Wen et al. 2022 (Zhao et al. 2020's schedule): pretrain, finetune, fit.

One :class:`Trainer` owns a photo, the generator G (frozen random encoder + two decoders), the PatchGAN D
and three Adam optimisers. Before the first iteration it computes, once for the whole photo, the guessed
diffuse map (:func:`svbrdf.trainer.losses.guessed_diffuse`) and the per-pixel view/light directions
(:class:`svbrdf.trainer.render.FlashGeometry`); every tile crops both, so a corner tile is lit obliquely as in
the photo. One iteration is, each sub-step on a fresh random tile:

* ``nr_updates`` x normal/roughness decoder: ``lambda_gan L_GAN + lambda_F L_F + lambda_P L_P``;
* ``ds_updates`` x diffuse/specular decoder (+ encoder if trained): ``lambda_gan L_GAN + L_d + lambda_F L_F
  + lambda_P L_P``;
* ``d_updates`` x discriminator: BCE on the photo tile (real) vs the rendering of G's maps (fake, detached).

``schedule="joint"`` runs the same losses on one tile per iteration: one generator pass, one backward pass that
updates both decoders, then the discriminator on that tile and rendering.

Numerical guard: a step whose loss or gradient is not finite is skipped (and counted); after
``guard.rollback_after`` such steps in a row, G, D and the optimisers return to the last good in-memory
snapshot. Runs are deterministic on the CPU for a given seed, including across checkpoint + resume.
"""

from __future__ import annotations

import hashlib
import math
import os
import time
from collections import defaultdict
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import torch

from svbrdf.trainer.camera_model import radius2
from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.jsonutil import finite_json
from svbrdf.runtime.quality.burn_in import photo_burn_in
from svbrdf.runtime.post import apply as apply_post
from svbrdf.runtime.post.flash_trend import even_lighting
from svbrdf.runtime.inference.manifest import DECODERS
from svbrdf.runtime.core.maps import MAP_NAMES, SLICES, Maps
from svbrdf.runtime.inference.tiling import tile_boxes, tile_weights
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer.config import STAGES, TrainConfig
from svbrdf.trainer.device import bf16_support, pick_device, set_threads
from svbrdf.trainer.guard import NumericalGuard
from svbrdf.trainer.loop import TrainingLoop
from svbrdf.trainer.losses import (CLIP_LEVEL, clipped_fraction, diffuse_loss, flash_basis,
                                   flash_correlation_loss, fourier_loss, gan_discriminator_loss, gan_generator_loss,
                                   guessed_diffuse, render_loss, specular_prior_loss, supervised_maps_loss,
                                   SUPERVISED_WEIGHTS)
from svbrdf.trainer.models import Discriminator, Generator, PhotoContext, pack_maps
from svbrdf.trainer.perceptual import PerceptualLoss
from svbrdf.trainer.render import FlashGeometry

PathLike = Union[str, os.PathLike]

_DECODER_BY_KEY = {d.key: d for d in DECODERS}

#: Start of the learned vignetting's logit: v = 0.9 sigmoid(t) = 0.05 (a mild lens darkening).
VIGNETTING_START_LOGIT = math.log(0.05 / 0.85)
#: ``callback(trainer, record)`` after every iteration; returning True stops the run (after this iteration).
Callback = Callable[["Trainer", Dict[str, Any]], Optional[bool]]


# ----------------------------------------------------------------------------------------------- photo / device
def photo_to_tensor(image: np.ndarray) -> torch.Tensor:
    """(H, W, 3) linear float image (e.g. from :func:`svbrdf.runtime.io.images.read_image`) -> (1, 3, H, W) float32."""
    arr = np.asarray(image, dtype=np.float32)
    if arr.ndim != 3 or arr.shape[-1] != 3:
        raise ImageError(f"photo must be an (H, W, 3) array, got shape {arr.shape}")
    return torch.from_numpy(np.ascontiguousarray(arr)).permute(2, 0, 1)[None].contiguous()


def load_photo(path: PathLike) -> Tuple[torch.Tensor, Dict[str, Any]]:
    """Read a photo file as a linear (1, 3, H, W) tensor and its identity ``{name, sha256, height, width}``.

    Raises:
        ImageError: unreadable file (see :func:`svbrdf.runtime.io.images.read_image`).
    """
    from svbrdf.runtime.io.images import read_image

    path = Path(path)
    photo = photo_to_tensor(read_image(path))
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    return photo, {"name": path.name, "sha256": digest, "height": photo.shape[-2], "width": photo.shape[-1]}


def tensor_photo_info(photo: torch.Tensor, name: str = "<tensor>") -> Dict[str, Any]:
    """Identity of an in-memory photo (sha256 of its float32 pixels)."""
    data = photo.detach().to("cpu", torch.float32).contiguous().numpy().tobytes()
    return {"name": name, "sha256": hashlib.sha256(data).hexdigest(), "height": photo.shape[-2],
            "width": photo.shape[-1]}


# ----------------------------------------------------------------------------------------------- inference
@torch.no_grad()
def predict_full(generator: Generator, photo: torch.Tensor, *, max_side: int = 1024,
                 overlap: int = 128, context: bool = True) -> torch.Tensor:
    """Maps of a whole photo: one pass, or overlapping tiles blended smoothly when a side exceeds ``max_side``.

    Args:
        generator: the trained generator (any device; run in float32).
        photo: (1, 3, H, W) linear RGB photo, H, W >= 8.
        max_side: largest side predicted in one pass; larger photos use ``max_side`` tiles.
        overlap: overlap between tiles, pixels (raised-cosine blend, :mod:`svbrdf.runtime.inference.tiling`).
        context: a U-Net's tiles take the whole photo's context (:meth:`Generator.photo_context`, one pass of the
            encoder over the whole photo), so they agree with each other; False: each tile alone.

    Returns:
        (1, 8, H, W) float32 packed maps on the photo's device (unit normals after blending).
    """
    h, w = photo.shape[-2:]
    boxes = tile_boxes(h, w, max_side, overlap) if max(h, w) > max_side else [(0, 0, h, w)]
    if len(boxes) == 1:
        return generator(photo).float()
    ctx = generator.photo_context(photo) if context and getattr(generator, "takes_context", False) else None
    acc = torch.zeros((1, 8, h, w), dtype=torch.float32, device=photo.device)
    wsum = torch.zeros((1, 1, h, w), dtype=torch.float32, device=photo.device)
    for box in boxes:
        y0, x0, th, tw = box
        wt = torch.from_numpy(tile_weights(box, h, w, overlap)).to(photo.device)[None, None]
        tile = photo[..., y0:y0 + th, x0:x0 + tw]
        maps = generator(tile) if ctx is None else generator(tile, ctx, torch.tensor([y0, x0]))
        acc[..., y0:y0 + th, x0:x0 + tw] += maps.float() * wt
        wsum[..., y0:y0 + th, x0:x0 + tw] += wt
    acc /= wsum
    n = acc[:, SLICES["normal"]]
    acc[:, SLICES["normal"]] = n / n.norm(dim=1, keepdim=True).clamp_min(1e-8)
    return acc


def to_maps(packed: torch.Tensor, meta: Optional[dict] = None) -> Maps:
    """(1, 8, H, W) packed maps -> :class:`~svbrdf.runtime.core.maps.Maps` (numpy, clipped to the valid ranges)."""
    arr = packed[0].detach().to("cpu", torch.float32).permute(1, 2, 0).numpy()
    return Maps.unpack(arr, meta).clipped()


# ----------------------------------------------------------------------------------------------- trainer
class Trainer(TrainingLoop):
    """Train G and D on one photo; :meth:`run` is the loop of :class:`~svbrdf.trainer.loop.TrainingLoop` (until
    ``iters``, or a plateau with ``quality="auto"``, or the callback or ``stop_requested`` asks to stop, or a time
    limit; a checkpoint every ``checkpoint_every`` iterations and at the end).

    Args:
        photo: (1, 3, H, W) linear RGB photo (values >= 0), H, W >= :meth:`min_tile` (32 px for the 4-layer
            PatchGAN).
        config: training settings.
        stage: "pretrain", "finetune" or "fit" (names the run; sets the default iteration count).
        iters: iterations to reach (default: ``config.iters(stage)``).
        device: torch device name (default CUDA if available, else CPU).
        threads: CPU threads (default: all cores).
        photo_info: ``{name, sha256, height, width}`` (default: computed from the pixels).
        checkpoint_path: where :meth:`run` saves checkpoints (None = never); a copy of the latest checkpoint
            written while no non-finite step occurred is kept next to it (``*_last_good.pt``, hard link).
        log_path: JSONL file, one line per iteration (None = no log).
        callback: see :data:`Callback`.

    Attributes:
        generator, discriminator, optimizers (``{"nr", "ds", "d"}``), history (one dict per iteration),
        step, iters, counters (``nonfinite_skips``, ``rollbacks``), notes (fallbacks), perceptual_backend,
        stopped_early (plateau), interrupted (callback or ``stop_requested``), timed_out (``run(max_seconds=)``).
    """

    def __init__(self, photo: torch.Tensor, config: TrainConfig, *, stage: str = "fit",
                 iters: Optional[int] = None, device: Optional[str] = None, threads: Optional[int] = None,
                 photo_info: Optional[Mapping[str, Any]] = None, checkpoint_path: Optional[PathLike] = None,
                 log_path: Optional[PathLike] = None, callback: Optional[Callback] = None):
        if stage not in STAGES:
            raise ValueError(f"unknown stage {stage!r}; expected one of {', '.join(STAGES)}")
        config.validate()
        self.config, self.stage = config, stage
        self.iters = config.iters(stage) if iters is None else int(iters)
        self.device = pick_device(device)
        if self.device.type == "cpu":
            set_threads(threads)
        self.notes: List[str] = []
        self.checkpoint_path = None if checkpoint_path is None else Path(checkpoint_path)
        self.log_path = None if log_path is None else Path(log_path)
        self.callback = callback

        photo = self._check_photo(photo, photo_info)
        self.photo_info = dict(photo_info) if photo_info else tensor_photo_info(photo)
        self.photo = photo.to(self.device, torch.float32)
        self.net_input = self.photo  # what the generator sees: the photo, or it evenly lit (config.post.even_lighting)
        if config.even_lighting > 0:
            even = even_lighting(self.photo[0].permute(1, 2, 0).cpu().numpy(), config.even_lighting)
            self.net_input = torch.from_numpy(even).permute(2, 0, 1)[None].to(self.device)
        h, w = self.photo.shape[-2:]
        self.tile = min(config.optim.tile, h, w)
        if self.tile < self.min_tile():  # the photo passed the same check, so config.optim.tile is too small
            raise ValueError(f"tile {config.optim.tile} px is too small: training needs tiles of at least "
                             f"{self.min_tile()} px")
        if self.tile < config.optim.tile:
            self.notes.append(f"tile {config.optim.tile} px clipped to the photo: {self.tile} px")

        self.bf16 = False
        if config.optim.bf16:
            self.bf16, note = bf16_support(self.device)
            if note:
                self.notes.append(note)

        torch.manual_seed(config.optim.seed)  # weights (and a random-VGG perceptual net) depend on the seed only
        self.generator = Generator(config.generator).to(self.device)
        self.discriminator = Discriminator(config.discriminator).to(self.device)
        self.perceptual: Optional[PerceptualLoss] = None
        self.perceptual_backend: Optional[str] = None
        self.clipped_fraction = clipped_fraction(self.photo)
        use_perceptual = config.losses.perceptual > 0
        if use_perceptual and self.clipped_fraction < config.losses.perceptual_min_clipped:
            use_perceptual = False
            self.notes.append(f"no clipped highlight ({100 * self.clipped_fraction:.3f} % of pixels >= {CLIP_LEVEL}):"
                              " perceptual loss skipped (it did not help on such photos: docs/decisions/021-fast-highlight-free.md)")
        if use_perceptual:
            self.perceptual = PerceptualLoss(config.losses.perceptual_backend, weights_path=config.losses.vgg_weights,
                                             seed=config.optim.seed).to(self.device)
            self.perceptual.requires_grad_(False)
            self.perceptual_backend = self.perceptual.backend_name
            if config.losses.perceptual_backend == "auto" or self.perceptual_backend != config.losses.perceptual_backend:
                self.notes.append(f"perceptual loss backend: {self.perceptual_backend}")
        # One optimiser per decoder (DECODERS' keys, "nr" then "ds"; the encoder trains with "ds"), one for D.
        self.params = {d.key: list(getattr(self.generator, d.module).parameters()) for d in DECODERS}
        if config.train_encoder:
            self.params["ds"] += list(self.generator.encoder.parameters())
        self.params["d"] = list(self.discriminator.parameters())
        # The photo's learned camera (per photo: never taken from a stage-one checkpoint) and the generator's output
        # offsets, trained by their own Adam at camera_lr.
        self.vignetting_logit: Optional[torch.Tensor] = None
        cam: List[torch.Tensor] = []
        if config.photo.learn_vignetting:
            self.vignetting_logit = torch.full((), VIGNETTING_START_LOGIT, device=self.device, requires_grad=True)
            cam.append(self.vignetting_logit)
        if config.photo.learn_offsets:
            cam.append(self.generator.out_offset)
        if cam:
            self.params["cam"] = cam
        self.optimizers = {k: self._adam(p) for k, p in self.params.items()}
        if "cam" in self.optimizers:
            for group in self.optimizers["cam"].param_groups:
                group["lr"] = config.optim.camera_lr
        #: The generator steps update these optimisers' parameters as well (camera, output offsets).
        self._camera_keys: Tuple[str, ...] = ("cam",) if cam else ()

        with torch.no_grad():
            self.guess = guessed_diffuse(self.photo).float()
        #: (x, y) of the flash over the photo in the renderer's units (``flash_position``; None: (0, 0)).
        self.flash_xy = config.photo.flash_position if config.photo.flash_position is not None else (0.0, 0.0)
        cam = None if self.flash_xy == (0.0, 0.0) else (*self.flash_xy, config.render_config.camera_distance)
        self.geometry = FlashGeometry(h, w, config.render_config, device=self.device, camera_pos=cam)
        self.radius2 = None if self.vignetting_logit is None else \
            torch.from_numpy(radius2(h, w)).to(self.device).permute(2, 0, 1)[None]  # (1, 1, H, W)
        self.flash_basis = flash_basis(self.geometry.light) if config.losses.flash > 0 else None
        self.tile_rng = torch.Generator().manual_seed(config.optim.seed)
        # Fixed tiles of the label-free progress signal: their own RNG, so they never shift the training tiles.
        eval_rng = torch.Generator().manual_seed(config.optim.seed + 1)
        self.eval_boxes = [self._draw_tile(eval_rng) for _ in range(config.monitor.eval_tiles)]
        self.eval_maps: Optional[torch.Tensor] = None
        #: (1, 8, H, W) the starting checkpoint's maps of the whole photo (``losses.anchor``; set by load_init).
        self.anchor: Optional[torch.Tensor] = None
        #: The whole photo's context for the tiles (U-Net generators with ``photo_context``; :meth:`_context`).
        self.context: Optional[PhotoContext] = None
        self._context_step = -1

        self.step = 0
        self.history: List[Dict[str, Any]] = []
        self.counters = {"nonfinite_skips": 0, "rollbacks": 0}
        self.init: Optional[Dict[str, Any]] = None
        self._init_loop()
        self._skips_at_last_save = 0  # nonfinite_skips at the last save (svbrdf.trainer.checkpoint.save_trainer)
        self.guard = NumericalGuard(self._guard_state, self._restore_guard_state, config.guard.rollback_after,
                                    self.counters)

    # ------------------------------------------------------------------ setup helpers
    def min_tile(self) -> int:
        """Smallest training tile (and photo side), px (see :attr:`TrainConfig.min_tile`)."""
        return self.config.min_tile

    def _check_photo(self, photo: torch.Tensor, info: Optional[Mapping[str, Any]]) -> torch.Tensor:
        name = (info or {}).get("name", "photo")
        if not isinstance(photo, torch.Tensor) or photo.ndim != 4 or photo.shape[:2] != (1, 3):
            raise ImageError(f"{name}: photo must be a (1, 3, H, W) tensor, got "
                             f"{tuple(photo.shape) if isinstance(photo, torch.Tensor) else type(photo).__name__}")
        need = self.min_tile()
        h, w = photo.shape[-2:]
        if min(h, w) < need:
            raise ImageError(f"{name}: photo is {w}x{h} px; training needs at least {need} px per side")
        if not torch.isfinite(photo).all():
            raise ImageError(f"{name}: photo has NaN/Inf values")
        if (photo < 0).any():
            raise ImageError(f"{name}: photo has negative values (expected linear RGB >= 0)")
        return photo

    def _adam(self, params) -> torch.optim.Adam:
        return torch.optim.Adam(params, lr=self.config.optim.lr, betas=tuple(self.config.optim.betas), eps=1e-8)

    def _amp(self):
        return torch.autocast(self.device.type, dtype=torch.bfloat16, enabled=self.bf16)

    def _draw_tile(self, rng: torch.Generator) -> Tuple[int, int]:
        h, w = self.photo.shape[-2:]
        y0 = int(torch.randint(h - self.tile + 1, (1,), generator=rng))
        x0 = int(torch.randint(w - self.tile + 1, (1,), generator=rng))
        return y0, x0

    def _crop(self, t: torch.Tensor, y0: int, x0: int) -> torch.Tensor:
        return t[..., y0:y0 + self.tile, x0:x0 + self.tile]

    def _context(self, refresh: bool = False) -> Optional[PhotoContext]:
        """The whole photo's context for this iteration's tiles (None: a generator that takes none, ``"wen"``, or
        ``photo_context`` off); recomputed without gradient every ``context_every`` iterations, or now with ``refresh``."""
        if not self.config.predict.photo_context or not self.generator.takes_context:
            return None
        due = self.step // self.config.predict.context_every
        if refresh or self.context is None or due != self._context_step:
            with torch.no_grad():
                self.context = self.generator.photo_context(self.net_input.to(torch.float32))
            self._context_step = due
        return self.context

    def _tile_maps(self, x: torch.Tensor, y0: int, x0: int) -> torch.Tensor:
        """(1, 8, t, t) maps of the photo tile ``x`` at (y0, x0) (with the photo's context; under autocast)."""
        return self.generator(x, self._context(), torch.tensor([y0, x0]))

    def _radiance(self, maps: torch.Tensor, y0: int, x0: int) -> torch.Tensor:
        """The rendering of ``maps`` on the tile at (y0, x0) as it reaches the sensor: the flash model of
        :attr:`geometry`, times the learned vignetting ``1 - v r^2`` when ``photo.learn_vignetting`` (not yet clipped)."""
        out = self.geometry.render(maps, y0, x0)
        if self.vignetting_logit is not None:
            r2 = self.radius2[..., y0:y0 + maps.shape[-2], x0:x0 + maps.shape[-1]]
            out = out * (1.0 - self.vignetting() * r2)
        return out

    def vignetting(self) -> torch.Tensor:
        """The learned vignetting strength v = 0.9 sigmoid(t), a 0-d tensor (needs ``photo.learn_vignetting``)."""
        return 0.9 * torch.sigmoid(self.vignetting_logit)

    def _seen(self, rendering: torch.Tensor) -> torch.Tensor:
        """What the camera would record of a rendering: clipped to [0, 1] with ``saturate``, else unchanged."""
        return rendering.clamp(0.0, 1.0) if self.config.photo.saturate else rendering

    # ------------------------------------------------------------------ checkpoints (svbrdf.trainer.checkpoint)
    def load_init(self, ckpt: Mapping[str, Any], source: PathLike = "checkpoint") -> None:
        """Start from a pretrained checkpoint (see :func:`svbrdf.trainer.checkpoint.load_init`)."""
        ckpt_io.load_init(self, ckpt, source)

    def load_resume(self, ckpt: Mapping[str, Any], source: PathLike = "checkpoint") -> None:
        """Continue exactly where ``ckpt`` stood (see :func:`svbrdf.trainer.checkpoint.load_resume`)."""
        ckpt_io.load_resume(self, ckpt, source)

    def checkpoint(self) -> Dict[str, Any]:
        """The current state as a checkpoint dict (see :func:`svbrdf.trainer.checkpoint.trainer_checkpoint`)."""
        return ckpt_io.trainer_checkpoint(self)

    def save(self, path: Optional[PathLike] = None) -> Path:
        """Write a checkpoint to ``path`` (default ``checkpoint_path``) and refresh the last-good copy
        (:func:`svbrdf.trainer.checkpoint.save_trainer`)."""
        path = Path(path) if path is not None else self.checkpoint_path
        if path is None:
            raise ValueError("no checkpoint path")
        return ckpt_io.save_trainer(self, path)

    # ------------------------------------------------------------------ the learned camera
    def camera_state(self) -> Optional[Dict[str, torch.Tensor]]:
        """The learned camera of this photo (``{"vignetting_logit", "vignetting"}``: 0-d tensors), or None."""
        if self.vignetting_logit is None:
            return None
        return {"vignetting_logit": self.vignetting_logit.detach().clone(),
                "vignetting": self.vignetting().detach().clone()}

    def load_camera(self, state: Optional[Mapping[str, torch.Tensor]]) -> None:
        """Set the learned camera from :meth:`camera_state` (no-op without ``photo.learn_vignetting`` or state)."""
        if self.vignetting_logit is not None and state and "vignetting_logit" in state:
            with torch.no_grad():
                self.vignetting_logit.copy_(state["vignetting_logit"].to(self.device))

    # ------------------------------------------------------------------ the numerical guard (svbrdf.trainer.guard)
    def _guard_state(self) -> Dict[str, Any]:
        """What a rollback restores: G, D, the optimiser states and the camera."""
        return {"generator": self.generator.state_dict(), "discriminator": self.discriminator.state_dict(),
                "optimizers": {k: o.state_dict() for k, o in self.optimizers.items()}, "camera": self.camera_state()}

    def _restore_guard_state(self, snap: Dict[str, Any]) -> None:
        self.generator.load_state_dict(snap["generator"])
        self.discriminator.load_state_dict(snap["discriminator"])
        for k, o in self.optimizers.items():
            o.load_state_dict(snap["optimizers"][k])
        self.load_camera(snap["camera"])

    def _apply(self, keys: Union[str, Tuple[str, ...]], loss: torch.Tensor) -> bool:
        """Backward + step of optimiser(s) ``keys`` through the guard (:meth:`NumericalGuard.step`). True =
        stepped."""
        keys = (keys,) if isinstance(keys, str) else tuple(keys)
        return self.guard.step([self.optimizers[k] for k in keys], [p for k in keys for p in self.params[k]], loss)

    # ------------------------------------------------------------------ one iteration
    def _g_step(self, key: str, terms: Dict[str, List[torch.Tensor]]) -> None:
        y0, x0 = self._draw_tile(self.tile_rng)
        x, guess = self._crop(self.photo, y0, x0), self._crop(self.guess, y0, x0)
        x_in = self._crop(self.net_input, y0, x0)
        trained = _DECODER_BY_KEY[key].maps
        frozen = tuple(n for n in MAP_NAMES if n not in trained)
        size = (x.shape[-2], x.shape[-1])
        with self._amp():
            latent = self.generator.forward_features(x_in, self._context(), torch.tensor([y0, x0]))
            out = self.generator.decode(latent, trained, size)
            with torch.no_grad():
                out.update(self.generator.decode(latent, frozen, size))
        maps = pack_maps(out).float()
        _, total = self._generator_losses((key,), x, guess, maps, y0, x0, terms)
        self._apply((key,) + self._camera_keys, total)

    def _generator_losses(self, keys: Tuple[str, ...], x: torch.Tensor, guess: torch.Tensor, maps: torch.Tensor,
                          y0: int, x0: int, terms: Dict[str, List[torch.Tensor]]) -> Tuple[torch.Tensor, torch.Tensor]:
        """Render ``maps`` of the tile at (y0, x0) and compute the decoder losses, logged under each of ``keys``
        ("nr", "ds"): ``lambda_gan L_GAN + lambda_F L_F + lambda_P L_P + lambda_render L_render + lambda_flash
        L_flash`` (the terms with a non-zero weight), plus ``L_d`` when "ds" is among them.

        Returns:
            (rendering, total loss): the rendering (B, 3, h, w) linear as the camera sees it (:meth:`_seen`), and
            the loss to minimise (with ``L_d`` if "ds" is in ``keys``).
        """
        cfg = self.config
        radiance = self._radiance(maps, y0, x0)
        rendering = self._seen(radiance)
        logged, weighted = {}, []
        if self.gan_active:
            with self._amp():
                fake_logits = self.discriminator(rendering)
            logged["gan"] = gan = gan_generator_loss(fake_logits.float())
            weighted.append(cfg.losses.gan * gan)
        if cfg.losses.fourier > 0:
            logged["fourier"] = lf = fourier_loss(maps, guess, mode=cfg.losses.fourier_mode)
            weighted.append(cfg.losses.fourier * lf)
        if self.perceptual is not None:
            with self._amp():
                logged["perceptual"] = lp = self.perceptual(x, rendering).float()
            weighted.append(cfg.losses.perceptual * lp)
        if cfg.losses.render > 0:
            logged["render"] = lr = render_loss(radiance, x, CLIP_LEVEL)
            weighted.append(cfg.losses.render * lr)
        if cfg.losses.specular_prior > 0:
            logged["specular_prior"] = lsp = specular_prior_loss(maps)
            weighted.append(cfg.losses.specular_prior * lsp)
        if self.flash_basis is not None:
            logged["flash"] = lfl = flash_correlation_loss(maps, self._crop(self.flash_basis, y0, x0))
            weighted.append(cfg.losses.flash * lfl)
        if self.anchor is not None and cfg.losses.anchor > 0:
            weights = {k: (w if k in cfg.losses.anchor_maps else 0.0) for k, w in SUPERVISED_WEIGHTS.items()}
            logged["anchor"] = la = supervised_maps_loss(maps, self._crop(self.anchor, y0, x0), weights)["total"]
            weighted.append(cfg.losses.anchor * la)
        shared = weighted[0] if weighted else maps.new_zeros(())  # without L_d: the nr decoder's loss
        for term in weighted[1:]:
            shared = shared + term
        total = shared
        if "ds" in keys and cfg.losses.diffuse > 0:
            logged["diffuse"] = ld = diffuse_loss(maps[:, SLICES["diffuse"]], guess, cfg.losses.diffuse_target)
            total = shared + cfg.losses.diffuse * ld
        for key in keys:
            for name, value in logged.items():
                if name != "diffuse" or key == "ds":
                    terms[f"{key}/{name}"].append(value.detach())
            terms[f"{key}/total"].append((total if key == "ds" else shared).detach())
        return rendering, total

    def _d_step(self, terms: Dict[str, List[torch.Tensor]], x: Optional[torch.Tensor] = None,
                fake: Optional[torch.Tensor] = None) -> None:
        """Discriminator update on photo tile ``x`` vs rendering ``fake`` (default: a fresh tile and its rendering)."""
        if x is None or fake is None:
            y0, x0 = self._draw_tile(self.tile_rng)
            x = self._crop(self.photo, y0, x0)
            with torch.no_grad():
                with self._amp():
                    maps = self._tile_maps(self._crop(self.net_input, y0, x0), y0, x0).float()
                fake = self._seen(self._radiance(maps, y0, x0))
        with self._amp():
            real_logits, fake_logits = self.discriminator(x), self.discriminator(fake.detach())
        loss = gan_discriminator_loss(real_logits.float(), fake_logits.float())
        terms["d/loss"].append(loss.detach())
        self._apply("d", loss)

    def _joint_step(self, terms: Dict[str, List[torch.Tensor]]) -> None:
        """``schedule="joint"``: both decoders and then D on one tile (see :class:`TrainConfig`)."""
        y0, x0 = self._draw_tile(self.tile_rng)
        x, guess = self._crop(self.photo, y0, x0), self._crop(self.guess, y0, x0)
        with self._amp():
            maps = self._tile_maps(self._crop(self.net_input, y0, x0), y0, x0)
        rendering, total = self._generator_losses(("nr", "ds"), x, guess, maps.float(), y0, x0, terms)
        self._apply(("nr", "ds") + self._camera_keys, total)
        if self.gan_active:
            self._d_step(terms, x, rendering)

    @property
    def gan_active(self) -> bool:
        """Whether this iteration runs the GAN (``config.optim.gan_steps``: only the first N iterations, 0 = all)."""
        return self.config.optim.gan_steps == 0 or self.step < self.config.optim.gan_steps

    def iteration(self) -> Dict[str, Any]:
        """Run one iteration of the schedule; returns its record (mean of each loss term over its sub-steps)."""
        t0 = time.perf_counter()
        skips0 = self.counters["nonfinite_skips"]
        terms: Dict[str, List[torch.Tensor]] = defaultdict(list)
        if self.config.optim.schedule == "joint":
            self._joint_step(terms)
        else:
            for _ in range(self.config.optim.nr_updates):
                self._g_step("nr", terms)
            for _ in range(self.config.optim.ds_updates):
                self._g_step("ds", terms)
            for _ in range(self.config.optim.d_updates if self.gan_active else 0):
                self._d_step(terms)
        self.step += 1
        rec: Dict[str, Any] = {"step": self.step}
        for k, v in terms.items():
            rec[k] = finite_json(float(torch.stack(v).mean()))
        rec["skipped"] = self.counters["nonfinite_skips"] - skips0
        if self.vignetting_logit is not None:
            rec["camera/vignetting"] = float(self.vignetting().detach())
        if self.config.monitor.eval_every and self.step % self.config.monitor.eval_every == 0:
            rec.update(self.evaluate())
        rec["seconds"] = time.perf_counter() - t0
        return rec

    @torch.no_grad()
    def evaluate(self) -> Dict[str, Optional[float]]:
        """Label-free progress signal on the fixed evaluation tiles (float32, no autocast).

        Returns:
            ``{"eval/render_l1": mean |render(G(tile)) - tile|, "eval/map_change": mean |maps - maps at the
            previous evaluation| (None at the first)}``.
        """
        maps, l1 = [], []
        self._context(refresh=True)
        for y0, x0 in self.eval_boxes:
            x = self._crop(self.photo, y0, x0)
            m = self._tile_maps(self._crop(self.net_input, y0, x0), y0, x0).float()
            l1.append((self._seen(self._radiance(m, y0, x0)) - x).abs().mean())
            maps.append(m)
        maps_t = torch.cat(maps)
        change = None if self.eval_maps is None else float((maps_t - self.eval_maps).abs().mean())
        self.eval_maps = maps_t
        return {"eval/render_l1": finite_json(float(torch.stack(l1).mean())),
                "eval/map_change": None if change is None else finite_json(change)}


    def plateaued(self) -> bool:
        """The ``quality="auto"`` stopping rule on this run's evaluations (:func:`plateau_reached`)."""
        l1 = [h["eval/render_l1"] for h in self.history if h.get("eval/render_l1") is not None]
        return plateau_reached(l1, self.config.monitor.plateau_window, self.config.monitor.plateau_render_tol)

    # ------------------------------------------------------------------ the loop's hooks (svbrdf.trainer.loop)
    def _on_start(self) -> Dict[str, Any]:
        self.guard.take_snapshot()
        return {"event": "start" if self.step == 0 else "resume", "stage": self.stage, "step": self.step,
                "iters": self.iters, "notes": self.notes}

    def _next_record(self) -> Dict[str, Any]:
        return self.iteration()

    def _on_record(self, record: Dict[str, Any]) -> None:
        if record["skipped"] == 0 and self.step % self.config.guard.snapshot_every == 0:
            self.guard.take_snapshot()

    def _stop_early(self, record: Dict[str, Any]) -> bool:
        return self.config.monitor.quality == "auto" and "eval/render_l1" in record and self.plateaued()

    def _on_end(self) -> Dict[str, Any]:
        return {"event": "stop", "step": self.step, "stopped_early": self.stopped_early,
                "interrupted": self.interrupted, **({"timed_out": True} if self.timed_out else {}), **self.counters}

    def predict(self) -> torch.Tensor:
        """(1, 8, H, W) maps of the whole photo as the generator predicts them (see :func:`predict_full`)."""
        return predict_full(self.generator, self.net_input, max_side=self.config.predict.max_side,
                            overlap=self.config.predict.overlap, context=self.config.predict.photo_context)

    def predict_maps(self, meta: Optional[dict] = None) -> Maps:
        """The final texture set of the whole photo: :meth:`predict` with the map corrections of ``config.post``
        (:func:`svbrdf.runtime.post.apply`, as the preview applies them: the photo's colour balance, the highlight
        fill, the radial trend around the photo's flash highlight removed, one specular level; ``meta`` then records
        what each step did and ``meta["burn_in_model"]`` the burn-in of the maps before,
        :func:`svbrdf.runtime.quality.burn_in.photo_burn_in`). ``meta["burn_in"]`` is the burn-in of the maps
        returned, always."""
        maps = to_maps(self.predict(), meta)
        post = self.config.post
        photo = self.photo[0].detach().to("cpu", torch.float32).permute(1, 2, 0).numpy()
        if post.colour_from_photo or post.highlight_fill or post.flash_trend or post.uniform_specular:
            return apply_post(maps, photo, post)
        maps.meta["burn_in"] = photo_burn_in(maps, photo)
        return maps


def plateau_reached(render_l1: Sequence[float], window: int, tol: float) -> bool:
    """Patience rule on the label-free re-render L1 (one value per evaluation, oldest first): True when the best
    of the last ``window`` values is not lower than ``1 - tol`` times the best before them.

    The GAN makes the signal noisy (about +-10 % between evaluations), so the best of a window is compared, not
    single values. The map change between evaluations is logged but not used: it settles at the GAN's jitter
    level (0.005-0.03 mean absolute change) instead of falling. Window 4 and tolerance 5 % (the defaults of
    :class:`~svbrdf.trainer.config.TrainConfig`) were chosen on 8 synthetic cases: docs/decisions/022-early-stop.md.
    """
    if len(render_l1) <= window:
        return False
    return min(render_l1[-window:]) >= (1.0 - tol) * min(render_l1[:-window])


__all__ = ["Trainer", "plateau_reached", "predict_full", "to_maps", "load_photo", "photo_to_tensor",
           "tensor_photo_info", "pick_device", "bf16_support", "set_threads"]
