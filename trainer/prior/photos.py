"""The procedural stream as flash photos: materials drawn, augmented (coarse relief, flat, near-black) and
photographed by a random camera (steps 1-3 of :mod:`svbrdf.trainer.prior`)."""

from __future__ import annotations

import math
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
import torch

from svbrdf.trainer.camera_model import CAMERA_KEYS, Camera, expose
from svbrdf.runtime.core.maps import SLICES
from svbrdf.runtime.core.render import RenderConfig, camera_position, light_vectors, physical_config
from svbrdf.trainer.camera import expose_batch, frame_radius2
from svbrdf.trainer.config import resolve
from svbrdf.trainer.device import to_device
from svbrdf.trainer.models import height_to_normal
from svbrdf.trainer.prior.config import PriorConfig
from svbrdf.trainer.procedural import PARAMS, coarse_height, normal_scale, sample_materials
from svbrdf.trainer.render import plane_grid, point_light_vectors, render_maps


def _uniform(rng: torch.Generator, lo: float, hi: float) -> float:
    return float(lo + (hi - lo) * torch.rand((), generator=rng).item())


def _draw_camera(config: PriorConfig, rng: torch.Generator) -> Dict[str, float]:
    """One photo's camera parameters from ``config.photos.camera``'s ranges
    (:data:`~svbrdf.trainer.camera_model.CAMERA_KEYS`, in order); ``white`` is drawn only when its range is not (1, 1),
    else it is 1 and nothing is drawn for it."""
    keys = CAMERA_KEYS if config.photos.camera["white"] != (1.0, 1.0) else CAMERA_KEYS[:-1]
    return {"white": 1.0, **{k: _uniform(rng, *config.photos.camera[k]) for k in keys}}


def lights_for(config: RenderConfig, n: int, rng: torch.Generator) -> List[Tuple[float, float, float]]:
    """``n`` random point lights for relighting: x, y uniform in [-0.8, 0.8] half-widths, height the camera's
    times [0.7, 1.3]."""
    d = config.camera_distance
    return [(_uniform(rng, -0.8, 0.8), _uniform(rng, -0.8, 0.8), d * _uniform(rng, 0.7, 1.3)) for _ in range(n)]


def view_light_directions(n: int, config: "PriorConfig", rng: torch.Generator) -> torch.Tensor:
    """``n`` random (view, light) pairs of distant directions for the relighting loss: (n, 2, 3) unit vectors.

    Each direction's polar angle from the normal (+z) is in ``config.losses.grazing_deg`` with probability
    ``config.losses.grazing_share``, else uniform in cosine up to the start of that range; azimuths are uniform. Half of
    the pairs (every other one) put the light in the mirror direction of the view, so the highlight is in view.
    """
    lo, hi = (math.radians(a) for a in config.losses.grazing_deg)
    out = torch.empty(n, 2, 3)
    for i in range(n):
        dirs = []
        for _ in range(2):
            if _uniform(rng, 0.0, 1.0) < config.losses.grazing_share:
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
        fov = _uniform(rng, *config.photos.fov_deg)
        physical = _uniform(rng, 0.0, 1.0) < config.photos.physical_share
        rc = base.replace(fov_deg=fov)
        rc = physical_config(rc) if physical else rc
        o = config.photos.light_offset
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
    """:func:`simulate_photos` for a whole batch at once, with torch on ``maps``' device (``config.materials.batched``).

    The same draws per photo (field of view, renderer mix, flash offset, camera, crop) from ``rng`` on the host;
    the geometry (:func:`svbrdf.trainer.render.point_light_vectors`), the rendering and the camera
    (:func:`svbrdf.trainer.camera.expose_batch`, its noise from a generator on the device seeded from ``rng``)
    run on the device, with nothing read back. Returns what :func:`simulate_photos` returns.

    The flash falls off with the fine-tune preset's camera distance (the renderer's normalisation of the ``base``
    configuration) while each photo's camera and flash sit at its own, so a photo's brightness depends on its field
    of view, unlike :func:`simulate_photos`'s (docs/decisions/061-cpu-proxy-fov.md).
    """
    b, _, h, w = maps.shape
    dev = maps.device
    base = resolve(config.finetune_preset).render_config.replace(falloff=True)
    cams, lights, physical, cam_draws, draws, boxes = [], [], [], [], [], []
    for _ in range(b):
        fov = _uniform(rng, *config.photos.fov_deg)
        phys = _uniform(rng, 0.0, 1.0) < config.photos.physical_share
        rc = base.replace(fov_deg=fov)
        o = config.photos.light_offset
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
    ``cols[i]`` ((B, c) index tensors on ``t``'s device), gathered in one op (the crops of :func:`simulate_photos_batched`)."""
    b = rows.shape[0]
    idx = torch.arange(b, device=t.device) if t.shape[0] > 1 else torch.zeros(b, dtype=torch.long, device=t.device)
    return t[idx[:, None, None], :, rows[:, :, None], cols[:, None, :]].permute(0, 3, 1, 2).contiguous()


def sample_batch(config: PriorConfig, rng: torch.Generator, batch: Optional[int] = None,
                 device: Optional[Union[str, torch.device]] = None
                 ) -> Tuple[torch.Tensor, torch.Tensor, Dict[str, Any]]:
    """One training batch: ``(photos (B, 3, S, S), maps (B, 8, S, S), info)`` with ``S = config.photos.size``.

    With ``config.materials.batched`` it is built on ``device`` (default CPU) by :func:`simulate_photos_batched`;
    otherwise on the CPU photo by photo (:func:`simulate_photos`, v1), whatever ``device``. With
    ``config.materials.stream`` "device" everything is drawn and built on ``device``
    (:mod:`svbrdf.trainer.prior.device_stream`).
    """
    return photograph(config, rng, *draw_materials(config, rng, batch, device))


def draw_materials(config: PriorConfig, rng: torch.Generator, batch: Optional[int] = None,
                   device: Optional[Union[str, torch.device]] = None) -> Tuple[torch.Tensor, List[str], bool]:
    """The materials of one batch (first half of :func:`sample_batch`): ``(maps, families, crop)``, the maps at
    ``photos.photo_size`` when the batch is cropped (``crop``), else at ``photos.size``. With
    ``config.materials.stream`` "device": :func:`svbrdf.trainer.prior.device_stream.draw_materials_device` (one seed
    from ``rng``, the rest drawn on ``device``; its maps are ``photos.block_mean`` times larger in a block-mean
    batch)."""
    if config.materials.stream == "device":
        from svbrdf.trainer.prior.device_stream import draw_materials_device

        return draw_materials_device(config, rng, batch, device)
    n = config.optim.batch if batch is None else batch
    crop = _uniform(rng, 0.0, 1.0) < config.photos.crop_share
    side = config.photos.photo_size if crop else config.photos.size
    maps, families = sample_materials(n, side, rng, config.materials.families,
                                      device=device if config.materials.batched else None)
    if config.materials.coarse_share > 0:
        maps = add_coarse_relief(maps, torch.rand(n, generator=rng) < config.materials.coarse_share, rng)
    if config.materials.flat_share > 0:
        maps = flatten_normals(maps, torch.rand(n, generator=rng) < config.materials.flat_share)
    if config.materials.black_share > 0:
        chosen = torch.rand(n, generator=rng) < config.materials.black_share
        lo, hi = (math.log(v) for v in BLACK_LEVEL)
        level = torch.exp(lo + (hi - lo) * torch.rand(n, generator=rng))
        maps = blacken_dielectrics(maps, chosen, level)
    return maps, families, crop


#: (lo, hi) of the mean linear base colour a ``materials.black_share`` material is darkened to (log-uniform): below the
#: procedural dielectric classes' darkest (``PARAMS["value_srgb"]`` 0.1, 0.01 linear), where only metals were.
BLACK_LEVEL = (0.001, 0.01)


def blacken_dielectrics(maps: torch.Tensor, chosen: torch.Tensor, level: torch.Tensor, check: bool = True
                        ) -> torch.Tensor:
    """``maps`` (B, 8, H, W) with the base colour of each ``chosen`` dielectric material ((B,) bool, on the host;
    dielectric: a median specular below the middle of the gap between the dielectric and metal ranges of
    :data:`svbrdf.trainer.procedural.PARAMS`) scaled so that its mean is at most ``level`` ((B,) linear, on the
    host); the others unchanged. Tensor ops on ``maps``' device only (nothing read back from a GPU). ``check``
    False: ``chosen`` and ``level`` may be on the device (the device stream) and are not tested for "none chosen"."""
    if check and not bool(chosen.any()):
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
    """Photos of materials from :func:`draw_materials` (second half of :func:`sample_batch`): ``(photos (B, 3, S,
    S), maps (B, 8, S, S), info)`` with ``info`` = ``{"families", "crop", "draws"}``. With ``config.materials.stream``
    "device": :func:`svbrdf.trainer.prior.device_stream.photograph_device` (``draws`` then holds device tensors)."""
    if config.materials.stream == "device":
        from svbrdf.trainer.prior.device_stream import photograph_device

        return photograph_device(config, rng, maps, families, crop)
    simulate = simulate_photos_batched if config.materials.batched else simulate_photos
    photos, maps, draws = simulate(maps, config, rng, crop=config.photos.size if crop else None)
    return photos, maps, {"families": families, "crop": crop, "draws": draws}


__all__ = ["simulate_photos", "simulate_photos_batched", "sample_batch", "draw_materials", "photograph",
           "lights_for", "view_light_directions", "BLACK_LEVEL", "blacken_dielectrics", "add_coarse_relief",
           "flatten_normals"]
