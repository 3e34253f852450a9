"""Torch layout around the one renderer formula (:func:`svbrdf.runtime.core.render.shade`).

Maps are packed channel-first ``(B, 8, H, W)`` in the order of :mod:`svbrdf.runtime.core.maps`; the view and light
directions come from :func:`svbrdf.runtime.core.render.light_vectors`, computed once for the whole photo and cropped
with each tile (:class:`FlashGeometry`).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Dict, Optional, Sequence, Tuple, Union

import torch

from svbrdf.runtime.core.maps import MAP_CHANNELS
from svbrdf.runtime.core.render import ZHAO, RenderConfig, light_vectors, plane_positions, shade
from svbrdf.trainer.device import to_device


def render_maps(
    maps: torch.Tensor,
    view: torch.Tensor,
    light: torch.Tensor,
    config: RenderConfig = ZHAO,
    light_dist2: Optional[torch.Tensor] = None,
) -> torch.Tensor:
    """Differentiable flash rendering.

    Args:
        maps: (B, 8, H, W) packed maps: linear diffuse [0,1], specular [0,1], roughness [0,1], unit normals.
        view: (B or 1, 3, H, W) unit directions surface -> camera.
        light: (B or 1, 3, H, W) unit directions surface -> light.
        config: renderer settings.
        light_dist2: (B or 1, 1, H, W) squared light distance (needed if ``config.falloff``).

    Returns:
        (B, 3, H, W) linear radiance (unclamped).
    """
    diffuse, dw, sr = _shading(maps, view, light, config, light_dist2)
    return dw * diffuse + sr


def _shading(maps: torch.Tensor, view: torch.Tensor, light: torch.Tensor, config: RenderConfig,
             light_dist2: Optional[torch.Tensor]) -> Tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(diffuse albedo, diffuse weight, specular radiance)`` of packed maps: :func:`shade` in the torch layout."""
    m = unpack(maps)
    dw, sr = shade(m["normal"], (view[:, 0:1], view[:, 1:2], view[:, 2:3]),
                   (light[:, 0:1], light[:, 1:2], light[:, 2:3]), m["specular"], m["roughness"], config, light_dist2)
    return m["diffuse"], dw, sr




def unpack(maps: torch.Tensor) -> Dict[str, Union[torch.Tensor, Tuple[torch.Tensor, ...]]]:
    """The maps of packed ``(B, 8, H, W)`` maps as views, split in one op.

    Returns ``{"diffuse": (B, 3, H, W), "specular": (B, 1, H, W), "roughness": (B, 1, H, W), "normal": (nx, ny,
    nz)}`` (each normal component (B, 1, H, W)), in the layout of :data:`svbrdf.runtime.core.maps.MAP_CHANNELS`. One
    split's backward is one concatenation of the gradients, where a slice per map fills a zero gradient of the
    whole packed tensor and adds into it (on one CPU thread, 1.8 s of an 18 s v2 training step went to those 91 slices' backward, profiled).
    """
    sizes: list = []
    for name, c in MAP_CHANNELS.items():
        sizes += [1] * c if name == "normal" else [c]
    parts = iter(maps.split(sizes, dim=1))
    return {name: (tuple(next(parts) for _ in range(c)) if name == "normal" else next(parts))
            for name, c in MAP_CHANNELS.items()}


class FlashGeometry:
    """View/light directions of a whole photo as torch tensors, cropped per tile.

    Args:
        height, width: whole-photo size in pixels.
        config: renderer settings (field of view).
        light_pos: (3,) light position, ``None`` = co-located flash.
        device, dtype: where the tensors live.
        camera_pos: (3,) camera position, ``None`` = above the photo's centre
            (:func:`svbrdf.runtime.core.render.camera_position`).
    """

    def __init__(self, height: int, width: int, config: RenderConfig = ZHAO,
                 light_pos: Optional[Sequence[float]] = None, device=None, dtype=torch.float32,
                 camera_pos: Optional[Sequence[float]] = None):
        v, l, d2 = light_vectors(height, width, light_pos, config, camera_pos)
        to = dict(device=device, dtype=dtype)
        self.view = torch.as_tensor(v, **to).permute(2, 0, 1)[None].contiguous()
        self.light = torch.as_tensor(l, **to).permute(2, 0, 1)[None].contiguous()
        self.dist2 = torch.as_tensor(d2, **to).permute(2, 0, 1)[None].contiguous()
        self.config = config
        self.size = (height, width)

    def crop(self, y0: int, x0: int, h: int, w: int) -> Tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        sl = (slice(None), slice(None), slice(y0, y0 + h), slice(x0, x0 + w))
        return self.view[sl], self.light[sl], self.dist2[sl]

    def render(self, maps: torch.Tensor, y0: int = 0, x0: int = 0) -> torch.Tensor:
        """Render (B, 8, h, w) maps that cover the tile at (y0, x0) of the photo."""
        v, l, d2 = self.crop(y0, x0, maps.shape[-2], maps.shape[-1])
        return render_maps(maps, v, l, self.config, d2)


def plane_grid(height: int, width: int, device=None) -> torch.Tensor:
    """(1, 3, H, W) float32 world positions of the pixel centres (:func:`svbrdf.runtime.core.render.plane_positions`),
    cached per size and device."""
    return _plane_grid(int(height), int(width), torch.device(device if device is not None else "cpu"))


@lru_cache(maxsize=16)
def _plane_grid(height: int, width: int, device: torch.device) -> torch.Tensor:
    grid = torch.from_numpy(plane_positions(height, width)).permute(2, 0, 1)[None].contiguous()
    return to_device(grid, device)


def point_light_vectors(positions: torch.Tensor, camera: torch.Tensor, light: torch.Tensor
                        ) -> Tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Batched torch form of :func:`svbrdf.runtime.core.render.light_vectors`: one camera and one point light per photo.

    Args:
        positions: (1 or B, 3, H, W) pixel positions on the plane (:func:`plane_grid`, or windows of it).
        camera: (B, 3) camera positions (``runtime.render.camera_position`` of each photo's configuration).
        light: (B, 3) light positions (the camera's for a flash).

    Returns:
        ``(view, light, light_dist2)``: (B, 3, H, W), (B, 3, H, W) unit vectors and (B, 1, H, W), float32.
    """
    v = camera[:, :, None, None].float() - positions
    v = v / (v * v).sum(1, keepdim=True).sqrt()  # (not .norm(dim=1): 17x slower on one CPU thread, NCHW)
    l = light[:, :, None, None].float() - positions
    d2 = (l * l).sum(1, keepdim=True)
    return v, l / d2.sqrt(), d2


def direction_vectors(directions: torch.Tensor, height: int, width: int) -> torch.Tensor:
    """(B, 3) unit directions (a distant camera or light, the same for every pixel) -> (B, 3, H, W)."""
    d = directions.float() / directions.float().norm(dim=1, keepdim=True)
    return d[:, :, None, None].expand(-1, -1, height, width)
