"""Perceptual loss L_P of Wen et al. 2022 (Eq. 5): L1 between VGG-19 features of the input tile and its re-rendering.

Layers relu1_1, relu2_1, relu3_1, relu4_1, relu5_1, equal weights (peers.md section 6 item 12). Images are linear;
the extractor clamps them to [0, 1], encodes them with the sRGB curve and applies the ImageNet normalisation,
because VGG was trained on sRGB photos.

Backends (:class:`PerceptualLoss`):

* ``"vgg19"``: torchvision's ImageNet VGG-19 weights (``vgg19-dcbb9e9d.pth``), looked up by
  :func:`load_vgg19_weights`; torchvision itself is not needed.
* ``"vgg19-random"``: the same network with fixed-seed random (Kaiming-normal) weights.
* ``"pyramid"``: a cheap 5-level Gaussian pyramid of the sRGB image with its Sobel gradients.
* ``"auto"``: ``"vgg19"`` if weights are found, else ``"vgg19-random"``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import torch
import torch.nn.functional as F
from kornia.filters import spatial_gradient
from kornia.geometry.transform import pyrdown
from torch import nn

from svbrdf.runtime.errors import ModelError
from svbrdf.trainer.colour import linear_to_srgb

#: Environment variable naming a VGG-19 state-dict file.
WEIGHTS_ENV = "SVBRDF_VGG19_WEIGHTS"
#: File name of torchvision's ImageNet VGG-19 weights in the torch hub cache.
VGG19_FILE = "vgg19-dcbb9e9d.pth"
#: torchvision's VGG-19 ``features`` up to conv5_1 (ints: 3x3 conv + ReLU output channels, "M": 2x2 max pool).
VGG19_CFG: Tuple[Union[int, str], ...] = (64, 64, "M", 128, 128, "M", 256, 256, 256, 256, "M",
                                          512, 512, 512, 512, "M", 512)
#: Tapped layers and their index in ``features``.
VGG19_TAPS: Mapping[str, int] = {"relu1_1": 1, "relu2_1": 6, "relu3_1": 11, "relu4_1": 20, "relu5_1": 29}
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
PYRAMID_LEVELS = 5

PathLike = Union[str, os.PathLike]


class VGGWeightsNotFoundError(ModelError, FileNotFoundError):
    """An explicitly requested VGG-19 weights file does not exist."""


class VGGWeightsError(ModelError, ValueError):
    """A VGG-19 weights file cannot be read or does not hold VGG-19 ``features`` weights."""


def _vgg19_layers(device=None) -> List[nn.Module]:
    layers: List[nn.Module] = []
    cin = 3
    for v in VGG19_CFG:
        if v == "M":
            layers.append(nn.MaxPool2d(2, 2))
        else:
            layers += [nn.Conv2d(cin, v, 3, padding=1, device=device), nn.ReLU()]
            cin = v
    return layers


def _expected_shapes() -> Dict[str, Tuple[int, ...]]:
    """torchvision state-dict keys (``features.N.weight/bias``) of the convs up to conv5_1 and their shapes."""
    out = {}
    for i, layer in enumerate(_vgg19_layers("meta")):
        if isinstance(layer, nn.Conv2d):
            out[f"features.{i}.weight"] = (layer.out_channels, layer.in_channels, 3, 3)
            out[f"features.{i}.bias"] = (layer.out_channels,)
    return out


class VGG19Features(nn.Module):
    """Frozen VGG-19 feature extractor (relu1_1 ... relu5_1).

    ``self.features`` has torchvision's layer indices, so its state-dict keys are torchvision's
    ``features.N.weight`` / ``features.N.bias``.

    Args:
        state_dict: weights for ``features`` (as returned by :func:`load_vgg19_weights`); ``None`` = random
            Kaiming-normal weights (zero biases) drawn from a local generator seeded with ``seed``.
        seed: seed of the random weights (the global RNG is not touched).

    Input (B, 3, H, W) linear RGB (any range; clamped to [0, 1]), H, W >= 16 (else ValueError); output: list of
    the five tapped activations, (B, 64, H, W), (B, 128, H/2, W/2), (B, 256, H/4, W/4), (B, 512, H/8, W/8),
    (B, 512, H/16, W/16).
    """

    layer_names: Tuple[str, ...] = tuple(VGG19_TAPS)

    def __init__(self, state_dict: Optional[Mapping[str, torch.Tensor]] = None, seed: int = 0):
        super().__init__()
        # built on "meta" (no default init, global RNG untouched), then given real storage
        self.features = nn.Sequential(*_vgg19_layers("meta")).to_empty(device="cpu")
        if state_dict is None:
            gen = torch.Generator().manual_seed(seed)
            for m in self.features:
                if isinstance(m, nn.Conv2d):
                    nn.init.kaiming_normal_(m.weight, mode="fan_in", nonlinearity="relu", generator=gen)
                    nn.init.zeros_(m.bias)
        else:
            self.load_state_dict(state_dict)
        self.register_buffer("mean", torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(IMAGENET_STD).view(1, 3, 1, 1), persistent=False)
        self.requires_grad_(False)
        self.eval()
        self._taps = frozenset(VGG19_TAPS.values())

    def forward(self, x: torch.Tensor) -> List[torch.Tensor]:
        if min(x.shape[-2:]) < 16:  # four 2x2 max-pools come before relu5_1
            raise ValueError(f"VGG-19 features need images of at least 16 x 16 px, got {x.shape[-2]} x {x.shape[-1]}")
        x = (linear_to_srgb(x, clip=True) - self.mean) / self.std
        out = []
        for i, layer in enumerate(self.features):
            x = layer(x)
            if i in self._taps:
                out.append(x)
        return out


class PyramidFeatures(nn.Module):
    """Cheap stand-in for VGG: a Gaussian pyramid of the sRGB-encoded image and its Sobel gradients.

    Input (B, 3, H, W) linear RGB (clamped to [0, 1]); output: one (B, 9, h, w) tensor per level (image, d/dx,
    d/dy) for up to 5 levels, halving the size while the smaller side is >= 4 (5 levels from 32 px up).
    """

    def __init__(self, levels: int = PYRAMID_LEVELS):
        super().__init__()
        self.levels = levels
        self.layer_names = tuple(f"level{i}" for i in range(levels))

    def forward(self, x: torch.Tensor) -> List[torch.Tensor]:
        x = linear_to_srgb(x, clip=True)
        out = []
        for i in range(self.levels):
            if i:
                if min(x.shape[-2:]) < 4:  # pyrdown's reflect padding needs >= 3 px
                    break
                x = pyrdown(x)
            b, c, h, w = x.shape
            out.append(torch.cat([x, spatial_gradient(x, mode="sobel").reshape(b, 2 * c, h, w)], dim=1))
        return out


def _resolve_path(path: Optional[PathLike]) -> Optional[Path]:
    if path is not None:
        p = Path(path).expanduser()
        if not p.is_file():
            raise VGGWeightsNotFoundError(f"{p}: VGG-19 weights file not found")
        return p
    env = os.environ.get(WEIGHTS_ENV)
    if env:
        p = Path(env).expanduser()
        if not p.is_file():
            raise VGGWeightsNotFoundError(f"{p}: VGG-19 weights file not found (set by {WEIGHTS_ENV})")
        return p
    p = Path(torch.hub.get_dir()) / "checkpoints" / VGG19_FILE
    return p if p.is_file() else None


def load_vgg19_weights(path: Optional[PathLike] = None) -> Optional[Dict[str, torch.Tensor]]:
    """Find and load ImageNet VGG-19 weights for :class:`VGG19Features`.

    Looks at, in order: ``path``; the file named by ``$SVBRDF_VGG19_WEIGHTS``; the torch hub cache
    ``torch.hub.get_dir()/checkpoints/vgg19-dcbb9e9d.pth`` (torchvision's download location).

    Accepts a full torchvision VGG-19 state dict (``features.N.weight``/``bias``; classifier and later layers are
    ignored) or the state dict of ``vgg.features`` alone (``N.weight``/``bias``). Loaded with
    ``torch.load(weights_only=True)``.

    Args:
        path: explicit weights file.

    Returns:
        state dict with keys ``features.N.weight``/``bias`` for the 13 convs up to conv5_1, or ``None`` when no
        path is given, the environment variable is unset and the hub cache has no file.

    Raises:
        VGGWeightsNotFoundError (a FileNotFoundError): the explicit path or the environment variable names a
            missing file.
        VGGWeightsError (a ValueError): the file cannot be loaded, or keys/shapes are not VGG-19's.
    """
    p = _resolve_path(path)
    if p is None:
        return None
    try:
        sd = torch.load(p, map_location="cpu", weights_only=True)
    except Exception as e:  # pickle, zip and weights_only errors have no common base class
        raise VGGWeightsError(f"{p}: cannot load a torch state dict ({type(e).__name__})") from None
    if not isinstance(sd, Mapping):
        raise VGGWeightsError(f"{p}: expected a state dict, got {type(sd).__name__}")
    out = {}
    for key, shape in _expected_shapes().items():
        alt = key[len("features."):]
        value = sd.get(key, sd.get(alt))
        if not isinstance(value, torch.Tensor):
            raise VGGWeightsError(f"{p}: not VGG-19 weights: missing {key!r} (expected torchvision keys "
                                  f"'features.N.weight' or 'N.weight')")
        if tuple(value.shape) != shape:
            raise VGGWeightsError(f"{p}: {key!r} has shape {tuple(value.shape)}, expected {shape} (VGG-19)")
        out[key] = value.float()
    return out


def perceptual_layer_losses(a: torch.Tensor, b: torch.Tensor,
                            extractor: Callable[[torch.Tensor], Sequence[torch.Tensor]]) -> torch.Tensor:
    """Per-layer mean absolute feature difference.

    Args:
        a, b: (B, 3, H, W) linear RGB images (e.g. the input tile and its re-rendering).
        extractor: maps (2B, 3, H, W) to a list of L feature tensors (e.g. :class:`VGG19Features`).

    Returns:
        (L,) float32 tensor.
    """
    if a.shape != b.shape:
        raise ValueError(f"perceptual loss needs equal shapes, got {tuple(a.shape)} and {tuple(b.shape)}")
    n = a.shape[0]
    feats = extractor(torch.cat([a, b], dim=0))  # one pass for both images
    return torch.stack([F.l1_loss(f[:n].float(), f[n:].float()) for f in feats])


def perceptual_loss(a: torch.Tensor, b: torch.Tensor,
                    extractor: Callable[[torch.Tensor], Sequence[torch.Tensor]]) -> torch.Tensor:
    """L_P: mean over layers (equal weights) of :func:`perceptual_layer_losses`; scalar."""
    return perceptual_layer_losses(a, b, extractor).mean()


class PerceptualLoss(nn.Module):
    """L_P as a module.

    Args:
        backend: "auto", "vgg19", "vgg19-random" or "pyramid" (see the module docstring).
        weights_path: explicit VGG-19 weights file (see :func:`load_vgg19_weights`).
        seed: seed of the "vgg19-random" weights (and of "auto" when it falls back to them).

    Attributes:
        backend_name: the backend actually used ("vgg19", "vgg19-random" or "pyramid").
        extractor: the feature extractor; ``extractor.layer_names`` names the layers.

    Raises:
        VGGWeightsNotFoundError: ``backend="vgg19"`` and no weights were found.
    """

    BACKENDS = ("auto", "vgg19", "vgg19-random", "pyramid")

    def __init__(self, backend: str = "auto", weights_path: Optional[PathLike] = None, seed: int = 0):
        super().__init__()
        if backend not in self.BACKENDS:
            raise ValueError(f"perceptual backend must be one of {', '.join(self.BACKENDS)}, got {backend!r}")
        if backend == "pyramid":
            self.extractor: nn.Module = PyramidFeatures()
            self.backend_name = "pyramid"
            return
        weights = load_vgg19_weights(weights_path) if backend != "vgg19-random" else None
        if weights is None and backend == "vgg19":
            raise VGGWeightsNotFoundError(
                f"VGG-19 weights not found: pass a file, set {WEIGHTS_ENV}, or place {VGG19_FILE} in "
                f"{Path(torch.hub.get_dir()) / 'checkpoints'}")
        self.extractor = VGG19Features(weights, seed=seed)
        self.backend_name = "vgg19" if weights is not None else "vgg19-random"

    @property
    def layer_names(self) -> Tuple[str, ...]:
        return tuple(self.extractor.layer_names)

    def layer_losses(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        """(L,) per-layer losses, in the order of :attr:`layer_names` (for logging)."""
        return perceptual_layer_losses(a, b, self.extractor)

    def forward(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        return perceptual_loss(a, b, self.extractor)

    def extra_repr(self) -> str:
        return f"backend_name={self.backend_name!r}"


__all__ = [
    "WEIGHTS_ENV", "VGG19_FILE", "VGG19_TAPS", "VGG19Features", "PyramidFeatures", "VGGWeightsNotFoundError",
    "VGGWeightsError", "load_vgg19_weights", "perceptual_layer_losses", "perceptual_loss", "PerceptualLoss",
]
