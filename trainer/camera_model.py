"""What a phone camera does to the flash rendering of a material: the realistic photo model (numpy, no torch).

A flash photo is not the renderer's radiance. Between the two stand (in this order, all in linear units):

1. **exposure**: one unknown scale ``2 ** ev`` for the whole photo;
2. **vignetting**: the lens darkens the corners, ``1 - v (r / r_corner)^2`` with ``r`` the distance from the image
   centre (radial, smooth, centred on the optical axis like the co-located flash itself);
3. **sensor noise**: Poisson-Gaussian, variance ``shot * x + read^2`` per pixel and channel;
4. **highlight roll-off**: a phone's tone mapping bends bright values down instead of clipping them at once; the
   extended Reinhard curve ``y = x (1 + x / white^2) / (1 + x)`` keeps dark values (slope 1 at 0) and brings
   ``white`` to 1 (``white = 1`` is the identity: a linear sensor);
5. **saturation**: values are clipped to [0, 1], so a bright highlight loses its shape (clipped pixels carry no
   information beyond "at least 1");
6. **8-bit sRGB storage**: quantised to 256 sRGB codes, decoded back to linear.

The light fall-off (1 / d^2) is the renderer's (:attr:`svbrdf.runtime.core.render.RenderConfig.falloff`; Mitsuba always
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
#: has about 0.1-0.5 % read noise and a shot term that gives ~2-4 % noise at mid grey. ``white`` is the highlight
#: roll-off's white point (1: none, a linear camera, as the benchmark's synthetic inputs are; the procedural prior
#: may widen it: ``PriorConfig.photos.camera``).
REALISTIC: Dict[str, tuple] = {
    "ev": (-0.5, 0.5),
    "vignetting": (0.0, 0.3),
    "shot": (2e-4, 2e-3),
    "read": (1e-3, 5e-3),
    "white": (1.0, 1.0),
}
#: The camera parameters a range table holds, in the order they are drawn (``white`` last, so a table without a
#: roll-off draws the first four as before it existed).
CAMERA_KEYS = ("ev", "vignetting", "shot", "read", "white")


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
        white: white point of the highlight roll-off (>= 1; 1 = none), see :func:`roll_off`.
    """

    ev: float = 0.0
    vignetting: float = 0.0
    shot: float = 0.0
    read: float = 0.0
    quantize: bool = False
    white: float = 1.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.vignetting < 1.0:
            raise ValueError(f"vignetting must be in [0, 1), got {self.vignetting}")
        if self.shot < 0 or self.read < 0:
            raise ValueError(f"noise parameters must be >= 0, got shot={self.shot}, read={self.read}")
        if not self.white >= 1.0:
            raise ValueError(f"white must be >= 1 (1 = no highlight roll-off), got {self.white}")

    def to_dict(self) -> Dict[str, Any]:
        return asdict(self)


def sample_camera(seed: int, ranges: Optional[Dict[str, tuple]] = None) -> Camera:
    """A :class:`Camera` drawn uniformly from ``ranges`` (default :data:`REALISTIC`; ``white`` may be left out: 1)
    with ``seed``; 8-bit storage."""
    rng = np.random.default_rng(seed)
    r = {"white": (1.0, 1.0), **(ranges or REALISTIC)}
    return Camera(**{k: float(rng.uniform(*r[k])) for k in CAMERA_KEYS}, quantize=True)


def roll_off(x, white):
    """The highlight roll-off ``x (1 + x / white^2) / (1 + x)`` of linear values ``x >= 0``.

    Slope 1 at 0, ``white`` maps to 1, values above it pass 1 (the clip that follows takes them); a number
    ``white = 1`` returns ``x`` unchanged. Increasing in ``x`` for ``white >= 1``. Plain arithmetic, so ``x`` and
    ``white`` may be numpy arrays or torch tensors that broadcast (the batched camera of the trainer uses it).
    """
    if isinstance(white, (int, float)) and white == 1.0:
        return x
    return x * (1.0 + x / (white * white)) / (1.0 + x)


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
    if camera.white != 1.0:
        img = roll_off(np.clip(img, 0.0, None), camera.white)
    img = np.clip(img, 0.0, 1.0).astype(np.float32)
    if camera.quantize:
        # imported here: the ranges above are read by the trainer on machines without OpenImageIO
        from .colour import linear_to_srgb, srgb_to_linear

        img = np.clip(srgb_to_linear(np.round(linear_to_srgb(img) * 255.0) / 255.0), 0.0, 1.0)
    return img.astype(np.float32)


__all__ = ["Camera", "REALISTIC", "CAMERA_KEYS", "sample_camera", "roll_off", "radius2", "vignette", "expose"]
