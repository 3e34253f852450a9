"""Generator and discriminator of Wen et al. 2022 (Zhao et al. 2020 layers, decoder trimmed to output = input size).

Layer tables: /work/shared/research/peers.md sections 1.2, 1.3, 1.5 and 6 (items 1-2). Every block uses the
*pre-activation* order ``LeakyReLU(0.2) -> conv -> InstanceNorm``; convolutions have no bias and N(0, 0.02)
weights; instance norms are affine (scale N(1, 0.02), offset 0, eps 1e-5). Padding reproduces TensorFlow's
``SAME`` on the even sizes the networks see (the generator pads its input to a multiple of 4): stride-1 convs pad
``(k - 1) // 2`` before and the rest after (1 / 2 for k = 4), stride-2 convs pad ``k - 2`` in total, after first
((0, 1) for k = 3, (1, 1) for k = 4).

Generator (paper widths, T = input size)::

    encoder   e1 conv5 3->9 | e2 lrelu conv3 9->64 IN | e3 lrelu conv3/2 64->128 IN | e4 lrelu conv3/2 128->256 IN
    decoder   d1 conv3 256->512 IN | lrelu up2 conv4 512->256 conv4 256->256 IN
              | lrelu up2 conv4 256->64 conv4 64->64 IN | lrelu conv3 64->outc | tanh

with two decoders: ``decoder_nr`` (height, roughness) and ``decoder_ds`` (diffuse RGB, specular):
:class:`WenGenerator`, ``arch="wen"``.

:class:`UNetGenerator` (``arch="unet"``) is the candidate for a prior over many materials (issue 26,
:class:`UNetEncoder`, :class:`UNetDecoder`): a U-Net with skips down to full resolution, a global-feature track
(per-channel means fed back as per-channel biases, the idea of Deschaintre et al. 2018, peers.md), no
normalisation layer anywhere, and two cues that instance normalisation hid: the photo's log colour and the offset of
every pixel from the brightest spot (the flash highlight).

One class per architecture behind one contract, :class:`Generator` (``forward_features`` -> :class:`Features`,
``decode``, ``forward``, ``photo_context``) and the same attribute names (``encoder``, ``decoder_nr``,
``decoder_ds``, ``out_offset``), so the fine-tune, the checkpoints, the ONNX export and its part graphs run either
unchanged. :func:`create_generator` (or ``Generator(cfg)``) builds the class registered for the architecture
(:data:`GENERATORS`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from typing import Any, ClassVar, Dict, Iterable, List, Mapping, NamedTuple, Optional, Sequence, Tuple, Type

import torch
import torch.nn.functional as F
from torch import nn

from svbrdf.runtime.inference.manifest import DECODERS
from svbrdf.runtime.core.maps import MAP_NAMES

LRELU_SLOPE = 0.2
IN_EPS = 1e-5
INIT_STD = 0.02
#: Maps produced by each decoder, by module name (from the one table, :data:`svbrdf.runtime.inference.manifest.DECODERS`).
DECODER_MAPS: Mapping[str, Tuple[str, ...]] = {d.module: d.maps for d in DECODERS}


def _from_dict(cls, d: Mapping):
    names = {f.name for f in fields(cls)}
    unknown = set(d) - names
    if unknown:
        raise ValueError(f"unknown {cls.__name__} keys: {', '.join(sorted(unknown))}")
    return cls(**d)


#: Generator architectures (:attr:`GeneratorConfig.arch`), each a class in :data:`GENERATORS`.
ARCHS: Tuple[str, ...] = ("wen", "unet")
#: :attr:`GeneratorConfig.height_activation` values.
HEIGHT_ACTIVATIONS: Tuple[str, ...] = ("tanh", "linear")


@dataclass
class GeneratorConfig:
    """Generator hyper-parameters.

    Attributes:
        width: multiplier of every channel count (paper: 1.0). The 9-channel first conv is not narrowed: it is
            cheap, and fewer than 3 channels would drop colour information before the (frozen) encoder.
        decoder_blocks: upsampling blocks per decoder (paper: 2). The encoder gets as many stride-2 convs, so the
            output always has the input size; 2 reproduces the published tables exactly.
        height_scale: slope factor of the height -> normal conversion (Zhao: 32 per pixel step).
        train_encoder: if False (Zhao's released code), the encoder keeps its random initialisation and its
            parameters have ``requires_grad = False``.
        arch: ``"wen"`` (the published generator above, the default: every preset and checkpoint before issue 26)
            or ``"unet"`` (the U-Net with a global track; ``decoder_blocks`` is then its number of resolution
            levels below the full one, channels ``32 * 2**level * width`` capped at ``512 * width``).
        height_activation: how the height channel leaves the decoder: ``"tanh"`` (Zhao's, the default: every
            checkpoint before it existed) bounds it to [0, 1] with ``(tanh(y) + 1) / 2``; ``"linear"`` gives
            ``(y + 1) / 2``, the same slope at y = 0 and no bound (only the height's differences make the normals).
            :func:`linearise_height` converts a trained tanh model. Decision: docs/decisions/023-stage-one-v2.md
            (linear height)
    """

    width: float = 1.0
    decoder_blocks: int = 2
    height_scale: float = 32.0
    train_encoder: bool = False
    arch: str = "wen"
    height_activation: str = "tanh"

    def __post_init__(self) -> None:
        if not self.width > 0:
            raise ValueError(f"width must be > 0, got {self.width}")
        if not isinstance(self.decoder_blocks, int) or self.decoder_blocks < 1:
            raise ValueError(f"decoder_blocks must be an integer >= 1, got {self.decoder_blocks}")
        if not self.height_scale > 0:
            raise ValueError(f"height_scale must be > 0, got {self.height_scale}")
        if self.arch not in ARCHS:
            raise ValueError(f"arch must be one of {', '.join(ARCHS)}, got {self.arch!r}")
        if self.height_activation not in HEIGHT_ACTIVATIONS:
            raise ValueError(f"height_activation must be one of {', '.join(HEIGHT_ACTIVATIONS)}, "
                             f"got {self.height_activation!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping) -> "GeneratorConfig":
        return _from_dict(cls, d)


@dataclass
class DiscriminatorConfig:
    """PatchGAN discriminator hyper-parameters.

    Attributes:
        width: multiplier of every channel count (paper: 1.0 -> 64, 128, 256, 512).
        n_layers: number of 4x4 stride-2 convs (paper: 4; channels double from 64 up to 512).
    """

    width: float = 1.0
    n_layers: int = 4

    def __post_init__(self) -> None:
        if not self.width > 0:
            raise ValueError(f"width must be > 0, got {self.width}")
        if not isinstance(self.n_layers, int) or self.n_layers < 1:
            raise ValueError(f"n_layers must be an integer >= 1, got {self.n_layers}")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping) -> "DiscriminatorConfig":
        return _from_dict(cls, d)


MODEL_PRESETS: Dict[str, GeneratorConfig] = {
    "paper": GeneratorConfig(width=1.0),
    "fast": GeneratorConfig(width=0.25),
    "tiny": GeneratorConfig(width=0.125),
}
DISC_PRESETS: Dict[str, DiscriminatorConfig] = {
    "paper": DiscriminatorConfig(width=1.0),
    "fast": DiscriminatorConfig(width=0.25),
    "tiny": DiscriminatorConfig(width=0.125),
}


def _ch(channels: int, width: float) -> int:
    return max(1, int(round(channels * width)))


def _conv(cin: int, cout: int, k: int, stride: int = 1, pre_act: bool = False, norm: bool = False) -> nn.Sequential:
    """[lrelu] -> TF-SAME conv (no bias) -> [InstanceNorm], for inputs whose size is a multiple of ``stride``."""
    total = k - stride
    before, after = total // 2, total - total // 2
    layers: List[nn.Module] = [nn.LeakyReLU(LRELU_SLOPE)] if pre_act else []
    if before != after:
        layers.append(nn.ZeroPad2d((before, after, before, after)))
        before = 0
    layers.append(nn.Conv2d(cin, cout, k, stride=stride, padding=before, bias=False))
    if norm:
        layers.append(nn.InstanceNorm2d(cout, eps=IN_EPS, affine=True))
    return nn.Sequential(*layers)


#: Row (and column) tap sums of a 4-tap TF-SAME convolution after nearest x2 upsampling, per output phase, on the
#: low-resolution grid padded by 1: even outputs read low-res rows (m-1, m, m+1) with weights (w0, w1+w2, w3), odd
#: outputs rows (m, m+1) with (w0+w1, w2+w3).
_PHASE_TAPS = ((1, 0, 0, 0), (0, 1, 1, 0), (0, 0, 0, 1)), ((0, 0, 0, 0), (1, 1, 0, 0), (0, 0, 1, 1))


def upsample_conv4(x: torch.Tensor, weight: torch.Tensor) -> torch.Tensor:
    """Nearest x2 upsampling followed by a 4x4 TF-SAME convolution (pad 1 before, 2 after), computed on the
    low-resolution grid: one 3x3 convolution with ``4 * C_out`` phase kernels, then ``pixel_shuffle(2)``.

    Exactly the same function as ``conv4(upsample(x))`` (to float rounding) with 36 instead of 64 multiply-adds per
    output and no upsampled copy. Decision: docs/decisions/020-fast-schedule.md (fused up-blocks)

    Args:
        x: (B, C_in, h, w) input.
        weight: (C_out, C_in, 4, 4) weights of the 4x4 convolution.

    Returns:
        (B, C_out, 2h, 2w).
    """
    taps = weight.new_tensor(_PHASE_TAPS)  # (phase, 3, 4)
    cout, cin = weight.shape[:2]
    kernel = torch.einsum("iap,ckpq,jbq->cijkab", taps, weight, taps).reshape(cout * 4, cin, 3, 3)
    return F.pixel_shuffle(F.conv2d(x, kernel, padding=1), 2)


class _UpBlock(nn.Sequential):
    """lrelu -> nearest x2 -> conv4 cin->cout -> conv4 cout->cout -> IN (Zhao's "deconv").

    The children keep the plain layout (state-dict keys unchanged); :meth:`forward` fuses the upsampling with the
    first convolution (:func:`upsample_conv4`).
    """

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        act, _upsample, first, second = self
        return second(upsample_conv4(act(x), first[1].weight))


def _up_block(cin: int, cout: int) -> nn.Sequential:
    """lrelu -> nearest x2 -> conv4 cin->cout -> conv4 cout->cout -> IN (Zhao's "deconv")."""
    return _UpBlock(
        nn.LeakyReLU(LRELU_SLOPE),  # elementwise, so applying it before the upsample is the same and cheaper
        nn.Upsample(scale_factor=2, mode="nearest"),
        _conv(cin, cout, 4),
        _conv(cout, cout, 4, norm=True),
    )


def _init_weights(module: nn.Module) -> None:
    for m in module.modules():
        if isinstance(m, nn.Conv2d):
            nn.init.normal_(m.weight, 0.0, INIT_STD)
        elif isinstance(m, nn.InstanceNorm2d):
            nn.init.normal_(m.weight, 1.0, INIT_STD)
            nn.init.zeros_(m.bias)


def height_to_normal(height: torch.Tensor, scale: float = 32.0) -> torch.Tensor:
    """Unit normals from a height field by forward differences (Zhao's ``height_to_normal``), OpenGL frame.

    ``d_row = h[i+1, j] - h[i, j]`` and ``d_col = h[i, j+1] - h[i, j]`` (0 on the last row / column). Zhao's
    y-down normal is ``normalize(-s d_col, -s d_row, 1)``; flipping y to the project's +y-up frame gives
    ``normalize(-s d_col, +s d_row, 1)``: a height rising to the right tilts the normal to -x, a height rising
    down the image tilts it up the image (+y).

    Args:
        height: (B, 1, H, W) height in [0, 1] (one unit per ``scale`` pixel steps of slope 1).
        scale: slope factor ``s``.

    Returns:
        (B, 3, H, W) unit normals, components in [-1, 1], z > 0.
    """
    hp = F.pad(height, (0, 1, 0, 1), mode="replicate")  # replicated edge -> zero difference on the last row/col
    d_row = hp[..., 1:, :-1] - height
    d_col = hp[..., :-1, 1:] - height
    nx, ny = -scale * d_col, scale * d_row
    inv = torch.rsqrt(nx * nx + ny * ny + 1.0)
    return torch.cat([nx * inv, ny * inv, inv], dim=1)


def pack_maps(maps: Mapping[str, torch.Tensor]) -> torch.Tensor:
    """Concatenate ``{name: (B, C, H, W)}`` into the packed (B, 8, H, W) layout of :mod:`svbrdf.runtime.core.maps`."""
    missing = [n for n in MAP_NAMES if n not in maps]
    if missing:
        raise ValueError(f"cannot pack maps: missing {', '.join(missing)}")
    return torch.cat([maps[n] for n in MAP_NAMES], dim=1)



# ------------------------------------------------------------------------------------------------ the U-Net candidate

#: Offset added before the logarithm of the U-Net's input (linear photo values).
UNET_LOG_EPS = 0.01
#: Sharpness of the soft arg-max that finds the brightest spot (the flash highlight): weights ``luminance ** k``.
UNET_FLASH_POWER = 8.0


def _unet_channels(cfg: "GeneratorConfig") -> List[int]:
    return [_ch(min(32 * 2 ** i, 512), cfg.width) for i in range(cfg.decoder_blocks + 1)]


def _conv3(cin: int, cout: int, stride: int = 1) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, 3, stride=stride, padding=1)


def _frame(n: int, start: torch.Tensor, whole: int) -> torch.Tensor:
    """(B, n) centres of ``n`` pixels from ``start`` (B,) along a side of ``whole`` px, mapped to [-1, 1]."""
    return 2.0 * (start.view(-1, 1) + torch.arange(n, device=start.device, dtype=torch.float32) + 0.5) / whole - 1.0


def flash_cue(x: torch.Tensor, centre: Optional[torch.Tensor] = None, origin: Optional[torch.Tensor] = None,
              size: Optional[Tuple[int, int]] = None) -> Tuple[torch.Tensor, torch.Tensor]:
    """Where the brightest spot of a photo is (a soft arg-max of its luminance), and every pixel's offset from it.

    Args:
        x: (B, 3, H, W) linear photo, values >= 0: the whole photo, or a tile of it (then give the three below).
        centre: (B, 2) the spot, as returned for the whole photo (:class:`PhotoContext`); None = found in ``x``.
        origin: (B, 2) or (2,) top-left pixel (row, column) of ``x`` in the whole photo; None = (0, 0).
        size: (H, W) of the whole photo the coordinates refer to; None = ``x``'s own size.

    Returns:
        ``(offset, centre)``: (B, 2, H, W) offset of every pixel from the spot and (B, 2) the spot, both in the
        units of :func:`svbrdf.runtime.core.render.plane_positions` of the whole photo (x right in [-1, 1] across its
        width, y up, scaled by its H / W). The spot is the mean position weighted by ``luminance **
        UNET_FLASH_POWER`` (a softmax of the log luminance), so a clipped highlight dominates; in a photo without
        one it drifts to the brightest area. A tile given the whole photo's ``centre``, its ``origin`` and ``size``
        gets exactly the offsets of the same pixels of the whole photo.
    """
    b, _, h, w = x.shape
    hh, ww = (h, w) if size is None else size
    org = torch.zeros(2, device=x.device) if origin is None else torch.as_tensor(origin, device=x.device)
    org = org.to(torch.float32).reshape(-1, 2).expand(b, 2)
    xs = _frame(w, org[:, 1], ww)  # (B, W)
    ys = -(hh / ww) * _frame(h, org[:, 0], hh)  # (B, H), y up
    if centre is None:
        lum = x.float().mean(1).clamp_min(1e-6)  # (B, H, W)
        weight = torch.softmax(UNET_FLASH_POWER * torch.log(lum).flatten(1), dim=1).view(b, h, w)
        centre = torch.stack([(weight.sum(1) * xs).sum(-1), (weight.sum(2) * ys).sum(-1)], dim=1)
    c = centre.to(torch.float32).view(b, 2)
    off_x = (xs - c[:, 0:1]).view(b, 1, w).expand(b, h, w)
    off_y = (ys - c[:, 1:2]).view(b, h, 1).expand(b, h, w)
    return torch.stack([off_x, off_y], dim=1).to(x.dtype), c.to(x.dtype)


@dataclass
class PhotoContext:
    """What a tile of a photo takes from the whole photo in the U-Net (``arch="unet"``): everything the network
    otherwise computes from its own input as a whole (:meth:`UNetGenerator.photo_context`).

    The U-Net's flash cue (the spot's position and every pixel's offset from it) and its global track (means over
    the input, fed back as per-channel biases at every decoder level) change with the crop it sees: a tile alone
    gets other maps than the same pixels of the whole photo. With this context a tile gets the whole photo's spot,
    its own pixels' offsets in the whole photo's frame and the whole photo's global vectors, so its maps differ from
    the whole photo's only within a receptive field of its border. Decision: docs/decisions/066-unet-photo-context.md

    Attributes:
        centre: (B, 2) the flash spot of the whole photo (:func:`flash_cue` units).
        size: (H, W) of the whole photo as the network saw it (padded to its multiple), px.
        tracks: decoder module name -> the (B, G) global vectors its levels take, deepest level first.
    """

    centre: torch.Tensor
    size: Tuple[int, int]
    tracks: Dict[str, Tuple[torch.Tensor, ...]]


class UNetEncoder(nn.Module):
    """Encoder of the U-Net candidate: linear photo -> skips at every level and a global vector.

    Input features (5 channels, full resolution): ``log(photo + UNET_LOG_EPS)`` (the photo's colour and level are
    kept: no normalisation) and the :func:`flash_cue` offsets. Level 0 is one 3x3 conv at full resolution; each
    further level halves the resolution (3x3 stride-2 conv) and adds a 3x3 conv, LeakyReLU(0.2) after every conv.
    The global vector starts from the per-channel means of the input features, the flash spot and the deepest
    level's per-channel means (one linear layer + LeakyReLU).

    Args:
        channels: channels per level, level 0 = full resolution.
        global_dim: size of the global vector.
    """

    def __init__(self, channels: Sequence[int], global_dim: int):
        super().__init__()
        self.stem = _conv3(5, channels[0])
        self.down = nn.ModuleList(
            nn.ModuleList([_conv3(channels[i], channels[i + 1], stride=2), _conv3(channels[i + 1], channels[i + 1])])
            for i in range(len(channels) - 1))
        self.global_in = nn.Linear(5 + 2 + channels[-1], global_dim)

    def forward(self, x: torch.Tensor, context: Optional[PhotoContext] = None, origin: Optional[torch.Tensor] = None
                ) -> Tuple[Tuple[torch.Tensor, ...], Optional[torch.Tensor]]:
        """(B, 3, H, W) linear photo (H, W multiples of ``2 ** levels``) -> (skips, (B, global_dim)).

        With a ``context`` (``x`` a tile of that photo at ``origin``, see :func:`flash_cue`) the offsets are the
        whole photo's and the global vector is None (the decoders take the context's).
        """
        act = nn.functional.leaky_relu
        if context is None:
            offset, centre = flash_cue(x)
        else:
            offset, centre = flash_cue(x, context.centre, origin, context.size)
        feats = torch.cat([torch.log(x.clamp_min(0.0) + UNET_LOG_EPS), offset], dim=1)
        h = act(self.stem(feats), LRELU_SLOPE)
        skips = [h]
        for down, conv in self.down:
            h = act(conv(act(down(h), LRELU_SLOPE)), LRELU_SLOPE)
            skips.append(h)
        if context is not None:
            return tuple(skips), None
        g = torch.cat([feats.mean((2, 3)), centre, h.mean((2, 3))], dim=1)
        return tuple(skips), act(self.global_in(g), LRELU_SLOPE)


class UNetDecoder(nn.Module):
    """One decoder of the U-Net candidate: skips + global vector -> ``outc`` pre-tanh channels at full resolution.

    From the deepest level up: bilinear x2 upsampling, concatenation with the encoder's skip of that level, a 3x3
    conv (and a second one below full resolution), each followed by the global track's per-channel bias (a linear
    layer of the global vector) and LeakyReLU(0.2); the global vector is then updated from itself and the new
    level's per-channel means (Deschaintre et al. 2018's global track) for the next level. A 1x1 conv gives the
    outputs.

    Args:
        channels: the encoder's channels per level.
        global_dim: size of the global vector.
        outc: output channels.
    """

    def __init__(self, channels: Sequence[int], global_dim: int, outc: int):
        super().__init__()
        levels = len(channels) - 1
        self.convs = nn.ModuleList()
        self.bias = nn.ModuleList()
        self.track = nn.ModuleList()
        for lvl in range(levels - 1, -1, -1):
            cin, cout = channels[lvl + 1] + channels[lvl], channels[lvl]
            convs = [_conv3(cin, cout)] + ([_conv3(cout, cout)] if lvl > 0 else [])
            self.convs.append(nn.ModuleList(convs))
            self.bias.append(nn.Linear(global_dim, cout))
            if lvl > 0:  # the global vector after the last level would feed nothing
                self.track.append(nn.Linear(global_dim + cout, global_dim))
        self.out = nn.Conv2d(channels[0], outc, 1)

    def forward(self, latent: Tuple[Tuple[torch.Tensor, ...], Optional[torch.Tensor]],
                tracks: Optional[Sequence[torch.Tensor]] = None) -> torch.Tensor:
        """Encoder latent -> (B, outc, H, W) pre-tanh outputs; ``tracks``: the global vector of every level (a
        :class:`PhotoContext`'s) instead of the latent's own track."""
        out = self._levels(latent, tracks)
        # The 1x1 output conv runs in float32 even under bf16 autocast: a linear height's normals are 16 times the
        # differences of neighbouring outputs, which bf16's 8-bit mantissa would round to steps of degrees.
        with torch.autocast(device_type=out.device.type, enabled=False):
            return self.out(out.float())

    def tracks(self, latent: Tuple[Tuple[torch.Tensor, ...], torch.Tensor]) -> Tuple[torch.Tensor, ...]:
        """The global vector each level takes (deepest first) for this latent; skips the full-resolution level,
        whose means feed nothing."""
        record: List[torch.Tensor] = []
        self._levels(latent, None, record)
        return tuple(record)

    def _levels(self, latent, tracks=None, record: Optional[List[torch.Tensor]] = None) -> Optional[torch.Tensor]:
        act = nn.functional.leaky_relu
        skips, g = latent
        h = skips[-1]
        for i, (convs, bias) in enumerate(zip(self.convs, self.bias)):
            if tracks is not None:
                g = tracks[i]
            elif record is not None:
                record.append(g)
                if len(record) == len(self.convs):
                    return None
            skip = skips[-2 - i]
            h = F.interpolate(h, scale_factor=2.0, mode="bilinear", align_corners=False)
            h = torch.cat([h, skip], dim=1)
            h = act(convs[0](h) + bias(g)[:, :, None, None], LRELU_SLOPE)
            for conv in convs[1:]:
                h = act(conv(h), LRELU_SLOPE)
            if tracks is None and i < len(self.track):
                g = act(self.track[i](torch.cat([g, h.mean((2, 3))], dim=1)), LRELU_SLOPE)
        return h

#: What each entry of :attr:`Generator.out_offset` shifts (pre-tanh): decoder_nr's two channels, then decoder_ds's four.
OFFSET_CHANNELS = ("height", "roughness", "diffuse_r", "diffuse_g", "diffuse_b", "specular")


class Features(NamedTuple):
    """What :meth:`Generator.forward_features` returns and :meth:`Generator.decode` takes, for every architecture.

    Attributes:
        encoded: the encoder's output, as this architecture's decoders take it (``"wen"``: the (B, C, H / m, W / m)
            latent, m = :attr:`Generator.multiple`; ``"unet"``: the skips at every level, level 0 at the padded full
            size, and the (B, G) global vector, None with a context).
        size: (H, W) of the padded input, the size the decoders' outputs have before cropping.
        context: the whole photo's :class:`PhotoContext` when the input is a tile of it (``"unet"``), else None.
    """

    encoded: Any
    size: Tuple[int, int]
    context: Optional[PhotoContext] = None


#: Generator classes by :attr:`GeneratorConfig.arch` (:func:`register_generator`).
GENERATORS: Dict[str, Type["Generator"]] = {}


def register_generator(cls: Type["Generator"]) -> Type["Generator"]:
    """Class decorator: make ``cls`` the generator built for ``GeneratorConfig(arch=cls.arch)``."""
    GENERATORS[cls.arch] = cls
    return cls


def create_generator(arch: str = "wen", **cfg: Any) -> "Generator":
    """The generator of architecture ``arch`` (:data:`GENERATORS`), the other :class:`GeneratorConfig` fields as
    keywords (a checkpoint's ``generator_config`` unpacks here).

    Raises:
        ValueError: an unknown architecture, field or value.
    """
    return Generator(GeneratorConfig.from_dict({"arch": arch, **cfg}))


class Generator(nn.Module):
    """Encoder + two decoders; linear photo -> SVBRDF maps of the same size. The contract every architecture keeps.

    ``Generator(cfg)`` builds the class registered for ``cfg.arch`` (:data:`GENERATORS`: :class:`WenGenerator`,
    :class:`UNetGenerator`), as :func:`create_generator` does.

    Args:
        cfg: hyper-parameters (default: the paper's; a subclass's: its architecture's defaults).

    Attributes:
        arch: the :attr:`GeneratorConfig.arch` the class implements.
        takes_context: whether a tile can take its whole photo's :meth:`photo_context`.
        multiple: the input is padded to a multiple of it (``2 ** decoder_blocks``).
        encoder: shared encoder.
        decoder_nr: encoder output -> (height, roughness) pre-tanh.
        decoder_ds: encoder output -> (diffuse RGB, specular) pre-tanh.
        out_offset: (6,) constants added to the decoders' pre-tanh outputs, in the order height, roughness,
            diffuse R, G, B, specular (:data:`OFFSET_CHANNELS`); 0 unless trained (a fine-tune fits them per photo
            with a high learning rate, so a saturated output can move its level quickly;
            ``TrainConfig.photo.learn_offsets``). Checkpoints written before it existed load
            with zeros.
    """

    arch: ClassVar[str] = ""
    takes_context: ClassVar[bool] = False

    def __new__(cls, cfg: Optional[GeneratorConfig] = None):
        if cls is Generator:
            cls = GENERATORS[(cfg or GeneratorConfig()).arch]
        return super().__new__(cls)

    def __init__(self, cfg: Optional[GeneratorConfig] = None):
        super().__init__()
        self.cfg = cfg or GeneratorConfig(arch=self.arch)
        if self.cfg.arch != self.arch:
            raise ValueError(f"{type(self).__name__} implements arch={self.arch!r}, not {self.cfg.arch!r}")
        self.multiple = 2 ** self.cfg.decoder_blocks

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        # Checkpoints from before ``out_offset`` existed: zero offsets, i.e. the same model.
        state_dict.setdefault(prefix + "out_offset", torch.zeros(len(OFFSET_CHANNELS)))
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    def _padded(self, x: torch.Tensor) -> torch.Tensor:
        m = self.multiple
        return F.pad(x, (0, (-x.shape[-1]) % m, 0, (-x.shape[-2]) % m), mode="replicate")

    def forward_features(self, x: torch.Tensor, context: Optional[PhotoContext] = None,
                         origin: Optional[torch.Tensor] = None) -> Features:
        """Encoder output of a linear photo.

        Args:
            x: (B, 3, H, W) linear RGB photo (values >= 0, typically [0, 1]); any H, W >= 8. It is padded
                (replicate, bottom/right) to a multiple of :attr:`multiple` before encoding.
            context: ``x`` is a tile of the photo this :meth:`photo_context` was taken from, at ``origin`` ((B, 2)
                or (2,) top-left row, column in that photo); its maps then are those of the same pixels of the whole
                photo, up to a receptive field at the tile's border. Ignored where not :attr:`takes_context`.

        Returns:
            :class:`Features`.
        """
        if x.ndim != 4 or x.shape[1] != 3:
            raise ValueError(f"Generator expects (B, 3, H, W), got {tuple(x.shape)}")
        x = self._padded(x)
        context = context if self.takes_context else None
        return Features(self._encode(x, context, origin), (x.shape[-2], x.shape[-1]), context)

    def _encode(self, x: torch.Tensor, context: Optional[PhotoContext], origin: Optional[torch.Tensor]) -> Any:
        """The padded photo -> :attr:`Features.encoded`."""
        raise NotImplementedError

    def decoder_outputs(self, name: str, features: Features) -> torch.Tensor:
        """The pre-tanh outputs of decoder ``name`` (``"decoder_nr"`` or ``"decoder_ds"``), before
        :attr:`out_offset`: (B, 2 or 4, H, W) at the padded size."""
        raise NotImplementedError

    def photo_context(self, photo: torch.Tensor) -> PhotoContext:
        """The whole photo's context for its tiles (:class:`PhotoContext`), where :attr:`takes_context`.

        Args:
            photo: (B, 3, H, W) linear RGB photo, as given to :meth:`forward`.

        Raises:
            ValueError: an architecture whose tiles take no context.
        """
        takers = ", ".join(repr(a) for a, cls in GENERATORS.items() if cls.takes_context)
        raise ValueError(f"a photo context exists for arch {takers} only, not {self.arch!r}")

    @staticmethod
    def _unit(y: torch.Tensor) -> torch.Tensor:
        # tanh output -> [0, 1]; at least float32 (bf16 forward differences of the height would be too coarse)
        y = y.to(torch.promote_types(y.dtype, torch.float32))
        return (torch.tanh(y) + 1.0) * 0.5

    def decode(self, features: Features, maps: Iterable[str] = MAP_NAMES,
               size: Optional[Tuple[int, int]] = None) -> Dict[str, torch.Tensor]:
        """Run only the decoders needed for ``maps``.

        Args:
            features: output of :meth:`forward_features`.
            maps: names among ``diffuse, specular, roughness, normal``; ``normal``/``roughness`` run
                ``decoder_nr``, ``diffuse``/``specular`` run ``decoder_ds``.
            size: (H, W) of the original photo to crop to (default: the padded size, ``features.size``).

        Returns:
            ``{name: tensor}`` in :data:`~svbrdf.runtime.core.maps.MAP_NAMES` order, float32 (float64 for float64
            input): diffuse (B, 3, H, W) linear [0, 1], specular (B, 1, H, W) linear [0, 1], roughness
            (B, 1, H, W) [0, 1], normal (B, 3, H, W) unit vectors, OpenGL frame.
        """
        want = set(maps)
        unknown = want - set(MAP_NAMES)
        if unknown:
            raise ValueError(f"unknown maps {sorted(unknown)}; expected some of {', '.join(MAP_NAMES)}")
        h, w = features.size if size is None else size
        out: Dict[str, torch.Tensor] = {}
        if want & set(DECODER_MAPS["decoder_nr"]):
            pre = self.decoder_outputs("decoder_nr", features) + self.out_offset[0:2].view(1, 2, 1, 1)
            y = self._unit(pre)[..., :h, :w]
            height = y[:, 0:1]
            if self.cfg.height_activation == "linear":
                height = (pre[:, 0:1].to(y.dtype)[..., :h, :w] + 1.0) * 0.5
            out["normal"] = height_to_normal(height, self.cfg.height_scale)
            out["roughness"] = y[:, 1:2]
        if want & set(DECODER_MAPS["decoder_ds"]):
            pre = self.decoder_outputs("decoder_ds", features) + self.out_offset[2:6].view(1, 4, 1, 1)
            y = self._unit(pre)[..., :h, :w]
            out["diffuse"] = y[:, 0:3]
            out["specular"] = y[:, 3:4]
        return {n: out[n] for n in MAP_NAMES if n in want}

    def forward(self, x: torch.Tensor, context: Optional[PhotoContext] = None,
                origin: Optional[torch.Tensor] = None) -> torch.Tensor:
        """(B, 3, H, W) linear photo -> (B, 8, H, W) packed maps (layout and ranges of :meth:`decode`); a tile of a
        photo with that photo's ``context`` at ``origin`` (:meth:`forward_features`)."""
        return pack_maps(self.decode(self.forward_features(x, context, origin), size=(x.shape[-2], x.shape[-1])))


@register_generator
class WenGenerator(Generator):
    """The published generator (``arch="wen"``, the module docstring's table): a shared encoder to a latent at
    1/4 resolution for the paper depth, (B, 4*64*width, H/4, W/4), and two decoders, instance-normalised."""

    arch = "wen"

    def __init__(self, cfg: Optional[GeneratorConfig] = None):
        super().__init__(cfg)
        n, w = self.cfg.decoder_blocks, self.cfg.width
        enc = [9, _ch(64, w)] + [_ch(min(64 * 2 ** i, 512), w) for i in range(1, n + 1)]
        layers = [_conv(3, enc[0], 5), _conv(enc[0], enc[1], 3, pre_act=True, norm=True)]
        layers += [_conv(enc[i], enc[i + 1], 3, stride=2, pre_act=True, norm=True) for i in range(1, n + 1)]
        self.encoder = nn.Sequential(*layers)
        # d1 doubles the latent (256 -> 512); block j outputs the encoder width one level up, the last one 64.
        dec = [_ch(min(2 * 64 * 2 ** n, 512), w)] + enc[n + 1:2:-1] + [enc[1]]
        self.decoder_nr = self._decoder(enc[-1], dec, 2)
        self.decoder_ds = self._decoder(enc[-1], dec, 4)
        self.out_offset = nn.Parameter(torch.zeros(len(OFFSET_CHANNELS)))
        _init_weights(self)
        self.encoder.requires_grad_(self.cfg.train_encoder)

    @staticmethod
    def _decoder(cin: int, dec: Sequence[int], outc: int) -> nn.Sequential:
        layers = [_conv(cin, dec[0], 3, norm=True)]
        layers += [_up_block(dec[i], dec[i + 1]) for i in range(len(dec) - 1)]
        layers.append(_conv(dec[-1], outc, 3, pre_act=True))  # Wen's trimmed last block: no upsampling
        return nn.Sequential(*layers)

    def _encode(self, x, context, origin) -> torch.Tensor:
        return self.encoder(x)

    def decoder_outputs(self, name: str, features: Features) -> torch.Tensor:
        return getattr(self, name)(features.encoded)


@register_generator
class UNetGenerator(Generator):
    """The candidate for a prior over many materials (``arch="unet"``, issue 26): :class:`UNetEncoder` and two
    :class:`UNetDecoder`; a tile can take its whole photo's :meth:`photo_context`."""

    arch = "unet"
    takes_context = True

    def __init__(self, cfg: Optional[GeneratorConfig] = None):
        super().__init__(cfg)
        ch, gdim = _unet_channels(self.cfg), _ch(128, self.cfg.width)
        self.encoder = UNetEncoder(ch, gdim)
        self.decoder_nr = UNetDecoder(ch, gdim, 2)
        self.decoder_ds = UNetDecoder(ch, gdim, 4)
        self.out_offset = nn.Parameter(torch.zeros(len(OFFSET_CHANNELS)))
        self.encoder.requires_grad_(self.cfg.train_encoder)

    def _encode(self, x, context, origin) -> Tuple[Tuple[torch.Tensor, ...], Optional[torch.Tensor]]:
        return self.encoder(x, context, origin)

    def decoder_outputs(self, name: str, features: Features) -> torch.Tensor:
        ctx = features.context
        return getattr(self, name)(features.encoded, None if ctx is None else ctx.tracks[name])

    def photo_context(self, photo: torch.Tensor) -> PhotoContext:
        """The whole photo's flash spot and global vectors, for its tiles (:class:`PhotoContext`).

        Args:
            photo: (B, 3, H, W) linear RGB photo, as given to :meth:`forward`. Costs the encoder and the decoders
                below full resolution; differentiable (compute it under ``torch.no_grad()`` to reuse it across steps).
        """
        x = self._padded(photo)
        skips, g = self.encoder(x)
        _, centre = flash_cue(x)
        tracks = {name: getattr(self, name).tracks((skips, g)) for name in DECODER_MAPS}
        return PhotoContext(centre, (x.shape[-2], x.shape[-1]), tracks)


class Discriminator(nn.Module):
    """PatchGAN discriminator (Zhao's ``Discriminator_patch``).

    ``conv4/2 3->64 | (lrelu conv4/2 IN) x (n_layers - 1), channels doubling up to 512 | lrelu conv4/1 -> 1``.

    Args:
        cfg: hyper-parameters (default: the paper's).

    Input (B, 3, H, W) linear RGB image; output (B, 1, H / 2**n_layers, W / 2**n_layers) real/fake logits
    (16 x 16 for a 256 px tile).
    """

    def __init__(self, cfg: Optional[DiscriminatorConfig] = None):
        super().__init__()
        self.cfg = cfg = cfg or DiscriminatorConfig()
        ch = [_ch(min(64 * 2 ** i, 512), cfg.width) for i in range(cfg.n_layers)]
        layers = [_conv(3, ch[0], 4, stride=2)]
        layers += [_conv(ch[i], ch[i + 1], 4, stride=2, pre_act=True, norm=True) for i in range(cfg.n_layers - 1)]
        layers.append(_conv(ch[-1], 1, 4, pre_act=True))
        self.net = nn.Sequential(*layers)
        _init_weights(self)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


@torch.no_grad()
def linearise_height(generator: Generator, photos: torch.Tensor) -> float:
    """Switch a ``height_activation="tanh"`` generator to ``"linear"`` at its operating point, in place.

    The tanh height ``(tanh(y) + 1) / 2`` has the slope ``sech(y)**2 / 2`` in ``y``; the linear one ``1 / 2``. The
    height channel of ``decoder_nr``'s last convolution (weights and bias) and its ``out_offset`` are multiplied by
    ``k``, the mean of ``sech(y)**2`` over ``photos``' pixels, so the new height's differences, hence the normals,
    are those of the tanh model's linearisation around where it works: equal where its height varies little around
    one level, steeper where it was pressed flat by the tanh's tail (those differences now reach the normals).
    Everything else (roughness, diffuse, specular) is untouched.

    Args:
        generator: a tanh-height generator (its ``cfg.height_activation`` becomes ``"linear"``).
        photos: (B, 3, H, W) linear photos the slope is averaged over (e.g. a validation batch).

    Returns:
        ``k``, the mean slope ratio applied (1 for an unsaturated model, near 0 for a saturated one).
    """
    if generator.cfg.height_activation != "tanh":
        raise ValueError(f"the generator's height is already {generator.cfg.height_activation!r}")
    was_training = generator.training
    generator.eval()
    pre = generator.decoder_outputs("decoder_nr", generator.forward_features(photos))[:, 0] + generator.out_offset[0]
    generator.train(was_training)
    k = float((1.0 - torch.tanh(pre.float()) ** 2).mean())
    last = [m for m in generator.decoder_nr.modules() if isinstance(m, nn.Conv2d)][-1]
    last.weight[0].mul_(k)
    if last.bias is not None:
        last.bias[0].mul_(k)
    generator.out_offset[0].mul_(k)
    generator.cfg = replace(generator.cfg, height_activation="linear")
    return k


def count_parameters(module: nn.Module, trainable_only: bool = False) -> int:
    """Number of parameters of ``module`` (only those with ``requires_grad`` if ``trainable_only``)."""
    return sum(p.numel() for p in module.parameters() if p.requires_grad or not trainable_only)


__all__ = [
    "OFFSET_CHANNELS", "ARCHS", "UNetEncoder", "UNetDecoder", "flash_cue", "PhotoContext", "Features",
    "GeneratorConfig", "DiscriminatorConfig", "MODEL_PRESETS", "DISC_PRESETS", "DECODER_MAPS", "Generator",
    "WenGenerator", "UNetGenerator", "GENERATORS", "register_generator", "create_generator",
    "Discriminator", "height_to_normal", "pack_maps", "count_parameters", "linearise_height", "HEIGHT_ACTIVATIONS",
]
