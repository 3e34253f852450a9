"""What a phone camera does to the flash rendering of a material: the realistic photo model (numpy, no torch).

A flash photo is not the renderer's radiance. Between the two stand (in this order, all in linear units):

1. **exposure**: one unknown scale ``2 ** ev`` for the whole photo;
2. **vignetting**: the lens darkens the corners, ``1 - v (r / r_corner)^2`` with ``r`` the distance from the image
   centre (radial, smooth, centred on the optical axis like the co-located flash itself);
3. **sensor noise**: Poisson-Gaussian, variance ``shot * x + read^2`` per pixel and channel;
4. **saturation**: values are clipped to [0, 1], so a bright highlight loses its shape (clipped pixels carry no
   information beyond "at least 1");
5. **8-bit sRGB storage**: quantised to 256 sRGB codes, decoded back to linear.

The light fall-off (1 / d^2) is the renderer's (:attr:`svbrdf.runtime.render.RenderConfig.falloff`; Mitsuba always
has it). :data:`REALISTIC` is the one table of parameter ranges; :func:`sample_camera` draws a :class:`Camera`
from it with a seed, :func:`expose` applies one. The benchmark's synthetic cases use them
(:func:`svbrdf.trainer.bench.cases.simulate_photo`), and a training stream of rendered materials can too.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Dict, Optional

import numpy as np

#: Ranges of the realistic photo model (uniform draws): exposure in stops, vignetting strength at the corner,
#: shot-noise variance per unit signal, read-noise standard deviation (linear units). A phone photo at base ISO
#: has about 0.1-0.5 % read noise and a shot term that gives ~2-4 % noise at mid grey.
REALISTIC: Dict[str, tuple] = {
    "ev": (-0.5, 0.5),
    "vignetting": (0.0, 0.3),
    "shot": (2e-4, 2e-3),
    "read": (1e-3, 5e-3),
}


@dataclass(frozen=True)
class Camera:
    """One camera's effect on a rendering (see the module docstring). The identity is ``Camera()`` with
    ``quantize=False``: no scale, no vignetting, no noise, only the clip to [0, 1].

    Attributes:
        ev: exposure in stops (the rendering is multiplied by ``2 ** ev``).
        vignetting: darkening at the image corner, in [0, 1).
        shot: shot-noise variance per unit of linear signal (>= 0).
        read: read-noise standard deviation, linear units (>= 0).
        quantize: store as 8-bit sRGB and decode back.
    """

    ev: float = 0.0
    vignetting: float = 0.0
    shot: float = 0.0
    read: float = 0.0
    quantize: bool = False

    def __post_init__(self) -> None:
        if not 0.0 <= self.vignetting < 1.0:
            raise ValueError(f"vignetting must be in [0, 1), got {self.vignetting}")
        if self.shot < 0 or self.read < 0:
            raise ValueError(f"noise parameters must be >= 0, got shot={self.shot}, read={self.read}")

    def to_dict(self) -> Dict[str, Any]:
        return asdict(self)


def sample_camera(seed: int, ranges: Optional[Dict[str, tuple]] = None) -> Camera:
    """A :class:`Camera` drawn uniformly from ``ranges`` (default :data:`REALISTIC`) with ``seed``; 8-bit storage."""
    rng = np.random.default_rng(seed)
    r = ranges or REALISTIC
    return Camera(**{k: float(rng.uniform(*r[k])) for k in ("ev", "vignetting", "shot", "read")}, quantize=True)


def radius2(height: int, width: int) -> np.ndarray:
    """(H, W, 1) float32 ``(r / r_corner)^2``: squared distance of each pixel centre from the image centre, 1 at
    the corners."""
    ys = (np.arange(height) + 0.5 - height / 2.0)[:, None]
    xs = (np.arange(width) + 0.5 - width / 2.0)[None, :]
    r2 = (ys * ys + xs * xs) / ((height / 2.0) ** 2 + (width / 2.0) ** 2)
    return r2.astype(np.float32)[..., None]


def vignette(height: int, width: int, strength: float) -> np.ndarray:
    """(H, W, 1) float32 factor ``1 - strength (r / r_corner)^2`` (:func:`radius2`)."""
    return (1.0 - strength * radius2(height, width)).astype(np.float32)


def expose(radiance: np.ndarray, camera: Camera, seed: int = 0) -> np.ndarray:
    """The photo a camera records of ``radiance``.

    Args:
        radiance: (H, W, 3) linear rendering (any non-negative values; may exceed 1).
        camera: the camera model.
        seed: noise seed.

    Returns:
        (H, W, 3) float32 linear photo in [0, 1].
    """
    img = np.asarray(radiance, dtype=np.float64) * (2.0 ** camera.ev)
    if camera.vignetting:
        img = img * vignette(img.shape[0], img.shape[1], camera.vignetting)
    if camera.shot or camera.read:
        var = camera.shot * np.clip(img, 0.0, None) + camera.read ** 2
        img = img + np.random.default_rng(seed).standard_normal(img.shape) * np.sqrt(var)
    img = np.clip(img, 0.0, 1.0).astype(np.float32)
    if camera.quantize:
        # imported here: the ranges above are read by the trainer on machines without OpenImageIO
        from .colour import linear_to_srgb, srgb_to_linear

        img = np.clip(srgb_to_linear(np.round(linear_to_srgb(img) * 255.0) / 255.0), 0.0, 1.0)
    return img.astype(np.float32)


__all__ = ["Camera", "REALISTIC", "sample_camera", "radius2", "vignette", "expose"]
