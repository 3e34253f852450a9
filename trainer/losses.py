"""Losses of Wen et al. 2022 and the "guessed diffuse" target of Zhao et al. 2020.

The papers' terms as read: ../shared/research/peers.md, sections 1.1, 1.6, 1.9 and 6.

Total generator loss per decoder: ``0.1 L_GAN + L_d + 0.1 L_F + 0.2 L_P`` (L_P is in
:mod:`svbrdf.trainer.perceptual`). All images and maps are linear; maps are packed (B, 8, H, W) in the layout of
:mod:`svbrdf.runtime.core.maps` with final ranges (diffuse/specular/roughness in [0, 1], unit normals).

Every loss is computed in at least float32, also under bf16 autocast.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Dict, Sequence

import torch
import torch.nn.functional as F

from svbrdf.runtime.outputs.conversions import DIELECTRIC_F0
from svbrdf.runtime.core.maps import SLICES
from svbrdf.runtime.core.relief import clamped_slopes
from svbrdf.trainer.colour import linear_to_srgb

#: Added under the square root of a complex modulus so its gradient stays finite at 0.
MODULUS_EPS = 1e-20


def _f32(x: torch.Tensor) -> torch.Tensor:
    """At least float32 (keeps float64 for gradcheck)."""
    return x.to(torch.promote_types(x.dtype, torch.float32))


def _fast_fft_size(n: int) -> int:
    """Smallest 5-smooth integer >= n (an FFT size). Decision: docs/decisions/070-fft-sizes.md."""
    while True:
        m = n
        for p in (2, 3, 5):
            while m % p == 0:
                m //= p
        if m == 1:
            return n
        n += 1


class _FFTBlur:
    """'same' convolution of (H, W) planes with a centred odd (k, k) kernel by FFT, zero or reflect padding.

    A plane is padded by p = k // 2 on each side; output rows/columns 2p .. 2p + H - 1 of the circular convolution
    only read padded samples 0 .. H + 2p - 1, so they never see the wrap-around. The kernel spectrum is computed
    once per image size.
    """

    def __init__(self, kernel: torch.Tensor, h: int, w: int, padding: str):
        self.p = kernel.shape[-1] // 2
        self.h, self.w = h, w
        self.mode = "constant" if padding == "zeros" else "reflect"
        self.size = (_fast_fft_size(h + 2 * self.p), _fast_fft_size(w + 2 * self.p))
        self.kernel_spec = torch.fft.rfft2(kernel, s=self.size)

    def __call__(self, plane: torch.Tensor) -> torch.Tensor:
        p = self.p
        padded = F.pad(plane[None], (p, p, p, p), mode=self.mode)[0]
        out = torch.fft.irfft2(torch.fft.rfft2(padded, s=self.size) * self.kernel_spec, s=self.size)
        # output index i collects padded[i - 2p .. i], the window centred on photo pixel i - 2p
        return out[2 * p:2 * p + self.h, 2 * p:2 * p + self.w]


#: Linear value counted as a clipped (saturated) pixel by :func:`clipped_fraction`.
CLIP_LEVEL = 0.99


def guessed_diffuse(photo: torch.Tensor, kernel_size: int = 101, sigma: float = 101.0, eps: float = 1e-4,
                    padding: str = "zeros") -> torch.Tensor:
    """Zhao et al.'s "guessed diffuse map": local mean/std normalisation of the photo, min-max rescaled.

    Per channel: ``m = K * x``, ``s = sqrt(K * (x - m)^2)``, ``z = (x - m) / (s + eps)``, then
    ``(z - min z) / (max z - min z + eps)`` over the whole image. ``K`` is a normalised
    ``kernel_size x kernel_size`` Gaussian (sigma 101 over 101 px is nearly a box). With ``padding="zeros"``
    (Zhao, TF SAME) the sums still divide by the full kernel weight, so a ``kernel_size // 2`` border is darkened;
    ``"reflect"`` avoids that (needs H, W > kernel_size // 2). Computed by FFT in float64, one channel at a time.
    Decision: docs/decisions/065-guessed-diffuse-float64.md

    Deviation: Zhao linearises with x^2.2; the project decodes sRGB exactly upstream, so ``photo`` is linear.

    Args:
        photo: (B, 3, H, W) linear RGB photo (whole image, before cropping).
        kernel_size: odd Gaussian window size (Zhao: 101).
        sigma: Gaussian standard deviation in pixels (Zhao: 101).
        eps: added to the local std and to the min-max range (Zhao: 1e-4).
        padding: "zeros" (Zhao) or "reflect".

    Returns:
        (B, 3, H, W) target for the linear diffuse albedo, in [0, 1], float32 (float64 for float64 input).

    Raises:
        ValueError: ``kernel_size`` not a positive odd integer, an unknown ``padding``, ``photo`` not 4-D, or
            ``"reflect"`` with H or W <= ``kernel_size // 2``.
    """
    if kernel_size < 1 or kernel_size % 2 == 0:
        raise ValueError(f"kernel_size must be a positive odd integer, got {kernel_size}")
    if padding not in ("zeros", "reflect"):
        raise ValueError(f"padding must be 'zeros' or 'reflect', got {padding!r}")
    if photo.ndim != 4:
        raise ValueError(f"photo must be (B, C, H, W), got {tuple(photo.shape)}")
    if padding == "reflect" and min(photo.shape[-2:]) <= kernel_size // 2:
        raise ValueError(f"reflect padding needs H, W > {kernel_size // 2}, got {tuple(photo.shape[-2:])}")
    x = photo.double()  # float32 round-off of the blurred variance shows in flat regions (decision 065)
    from kornia.filters import get_gaussian_kernel1d  # here: the prior's losses must import without kornia

    g = get_gaussian_kernel1d(kernel_size, sigma, device=x.device, dtype=x.dtype)[0]
    kernel = g[:, None] * g[None, :]  # separable: the outer product of the normalised 1D kernel sums to 1
    h, w = x.shape[-2:]
    blur = _FFTBlur(kernel, h, w, padding)
    planes = []
    for plane in x.reshape(-1, h, w):  # one channel at a time bounds the peak memory for large photos
        mean = blur(plane)
        # The floor (a std of 1e-12, far below eps) absorbs FFT round-off below 0 and keeps the gradient finite
        # where the local variance is 0 (flat or clipped regions), since d sqrt(v) / dv is infinite at 0.
        std = blur((plane - mean) ** 2).clamp_min(1e-24).sqrt()
        z = (plane - mean) / (std + eps)
        planes.append((z - z.min()) / (z.max() - z.min() + eps))
    return torch.stack(planes).reshape(x.shape).clamp(0.0, 1.0).to(_f32(photo).dtype)


DIFFUSE_TARGETS = ("absolute", "normalized")
#: Added to a tile's standard deviation where a loss divides by it.
STD_EPS = 0.01


def _standardize(x: torch.Tensor, eps: float = STD_EPS) -> torch.Tensor:
    """Per image and channel over (H, W): ``(x - mean) / (std + eps)``."""
    mean = x.mean(dim=(-2, -1), keepdim=True)
    std = x.std(dim=(-2, -1), keepdim=True, unbiased=False)
    return (x - mean) / (std + eps)


def diffuse_loss(pred_diffuse: torch.Tensor, guess: torch.Tensor, target: str = "absolute") -> torch.Tensor:
    """L_d: mean absolute error between the predicted diffuse albedo and the guessed diffuse map.

    The guess is min-max rescaled over the photo (:func:`guessed_diffuse`), so its level and contrast say nothing
    of the true albedo's. ``target="absolute"`` (Zhao et al., the paper) compares the values as they are;
    ``"normalized"`` compares both after standardising each channel over the tile (``(x - mean) / (std +
    0.01)``), so L_d only asks the diffuse map to follow the guess's pattern and leaves its level and contrast to
    the photo (a re-render term).

    Args:
        pred_diffuse: (B, 3, H, W) predicted linear diffuse albedo in [0, 1].
        guess: (B, 3, H, W) guessed diffuse crop in [0, 1] (:func:`guessed_diffuse`).
        target: "absolute" or "normalized".

    Returns:
        scalar.

    Raises:
        ValueError: an unknown ``target``.
    """
    if target not in DIFFUSE_TARGETS:
        raise ValueError(f"target must be one of {DIFFUSE_TARGETS}, got {target!r}")
    p, g = _f32(pred_diffuse), _f32(guess)
    if target == "normalized":
        p, g = _standardize(p), _standardize(g)
    return (p - g).abs().mean()


@lru_cache(maxsize=4)
def _srgb_level(linear: float) -> float:
    """The sRGB encoding of one linear value (the curve the loss uses), computed once per value."""
    return float(linear_to_srgb(torch.full((1, 3, 1, 1), linear, dtype=torch.float64))[0, 0, 0, 0])


def render_loss(rendering: torch.Tensor, photo: torch.Tensor, clip_level: float = 0.99) -> torch.Tensor:
    """Per-pixel re-render loss: mean absolute difference of the sRGB-encoded rendering and photo tile.

    A photo value at or above ``clip_level`` is saturated: it only says the radiance was at least that much, so
    there the loss is one-sided, ``max(0, enc(clip_level) - enc(rendering))`` (no pull down on a bright
    highlight the camera clipped). The rendering is not clipped: an over-bright pixel where the photo is not
    saturated is pulled down.

    Args:
        rendering: (B, 3, H, W) linear radiance (>= 0; may exceed 1) at the photo tile's position.
        photo: (B, 3, H, W) linear photo tile in [0, 1].
        clip_level: linear value from which a photo channel counts as saturated.

    Returns:
        scalar.
    """
    with torch.autocast(device_type=rendering.device.type, enabled=False):
        r = linear_to_srgb(_f32(rendering).clamp_min(0.0))
        x = _f32(photo)
        p = linear_to_srgb(x, clip=True)
        level = _srgb_level(float(clip_level))
        err = torch.where(x >= clip_level, (level - r).clamp_min(0.0), (r - p).abs())
        return err.mean()


def specular_prior_loss(maps: torch.Tensor, f0: float = DIELECTRIC_F0) -> torch.Tensor:
    """Weak prior on the specular albedo: ``mean |sqrt(rho_s) - sqrt(f0)|``.

    One flash photo of a rough material hardly tells a weak specular lobe from none (both leave a faint, broad
    highlight); most materials are dielectrics with F0 near 0.04. The square root makes the pull gentle on the
    metals and coatings the photo does show (a specular of 0.5 costs 0.51, one of 0.005 costs 0.13).

    Args:
        maps: (B, 8, H, W) packed maps, final ranges.
        f0: the level pulled to (default :data:`svbrdf.runtime.outputs.conversions.DIELECTRIC_F0`).

    Returns:
        scalar.
    """
    with torch.autocast(device_type=maps.device.type, enabled=False):
        s = _f32(maps[:, SLICES["specular"]]).clamp_min(0.0)
        return (torch.sqrt(s + 1e-8) - f0 ** 0.5).abs().mean()


#: Powers p of the flash basis ``l_z ** p`` (:func:`flash_basis`): broad (the fall-off and cosine), medium
#: and narrow (a highlight lobe). At a 66 deg field of view ``l_z ** 256`` falls to 1/2 about 0.05 W from the
#: flash centre, ``l_z ** 4`` to 0.74 at the photo's corner.
FLASH_POWERS = (4, 32, 256)


def flash_basis(light: torch.Tensor, powers: Sequence[int] = FLASH_POWERS) -> torch.Tensor:
    """Radial fields that follow the flash: ``l_z ** p`` for each power, from the per-pixel light directions.

    With a co-located flash over a flat surface, ``l_z`` (the cosine between the normal and the light) is 1 under
    the flash and falls smoothly away from it, so its powers describe the shapes the flash paints on a
    photo: the broad fall-off and the highlight lobes of several roughnesses. Computed from the photo's
    geometry (:class:`svbrdf.trainer.render.FlashGeometry`), they are exact for every tile, centred or not.

    Args:
        light: (1, 3, H, W) unit directions surface -> light.
        powers: the exponents.

    Returns:
        (1, K, H, W) float32 basis, K = len(powers).
    """
    lz = _f32(light[:, 2:3]).clamp_min(0.0)
    return torch.cat([lz ** p for p in powers], dim=1)


def flash_maps(maps: torch.Tensor) -> torch.Tensor:
    """The scalar fields of the maps that a flash burn-in shows in: (B, 6, H, W) = diffuse R, G, B, specular,
    roughness and the normal's z (a flattened or bulged centre)."""
    return torch.cat([maps[:, SLICES["diffuse"]], maps[:, SLICES["specular"]], maps[:, SLICES["roughness"]],
                      maps[:, SLICES["normal"]][:, 2:3]], dim=1)


def flash_correlation_loss(maps: torch.Tensor, basis: torch.Tensor, eps: float = STD_EPS) -> torch.Tensor:
    """Stationarity with respect to the flash: how much of each map follows the flash pattern.

    For every field g of :func:`flash_maps` and basis field b (:func:`flash_basis`), both centred over the tile,
    the amplitude of g along b is ``a = mean(g_c b_c) / rms(b_c)`` (map units); it is divided by the tile's
    standard deviation of g plus ``eps``, computed without gradient, so the loss can only fall by removing the
    flash-shaped component, never by adding texture. The loss is the mean of ``(a / (std(g) + eps))^2`` over
    fields, bases and batch: about the squared correlation of each map with the flash, 0 for a map that does not
    follow it (a stationary material, whose highlight must then come from the specular lobe of the renderer).

    Args:
        maps: (B, 8, H, W) packed maps, final ranges.
        basis: (1 or B, K, H, W) flash basis cropped to the same tile.
        eps: added to the standard deviation.

    Returns:
        scalar in [0, ~1].
    """
    with torch.autocast(device_type=maps.device.type, enabled=False):
        g = flash_maps(_f32(maps))
        b = _f32(basis)
        gc = g - g.mean(dim=(-2, -1), keepdim=True)
        bc = b - b.mean(dim=(-2, -1), keepdim=True)
        bn = bc / (bc.pow(2).mean(dim=(-2, -1), keepdim=True).sqrt() + 1e-8)
        amp = (gc[:, :, None] * bn[:, None]).mean(dim=(-2, -1))  # (B, fields, K)
        scale = gc.pow(2).mean(dim=(-2, -1)).sqrt().detach()[:, :, None] + eps
        return (amp / scale).pow(2).mean()


def gan_generator_loss(fake_logits: torch.Tensor) -> torch.Tensor:
    """Non-saturating GAN loss of the generator: BCE-with-logits(D(fake), 1), mean over the patch map.

    Args:
        fake_logits: (B, 1, h, w) discriminator logits of rendered (fake) images.

    Returns:
        scalar.
    """
    x = _f32(fake_logits)
    return F.binary_cross_entropy_with_logits(x, torch.ones_like(x))


def gan_discriminator_loss(real_logits: torch.Tensor, fake_logits: torch.Tensor) -> torch.Tensor:
    """Discriminator loss ``BCE(D(real), 1) + BCE(D(fake), 0)`` (Zhao: no 1/2 factor), each a patch mean.

    Args:
        real_logits: (B, 1, h, w) logits of real photo crops.
        fake_logits: (B, 1, h, w) logits of renderings (detached from the generator by the caller).

    Returns:
        scalar.
    """
    r, f = _f32(real_logits), _f32(fake_logits)
    return (F.binary_cross_entropy_with_logits(r, torch.ones_like(r))
            + F.binary_cross_entropy_with_logits(f, torch.zeros_like(f)))


def maps_for_loss(maps: torch.Tensor) -> torch.Tensor:
    """The four maps as comparable 3-channel images in [0, 1], stacked for the Fourier loss.

    Args:
        maps: (B, 8, H, W) packed maps (:mod:`svbrdf.runtime.core.maps` layout, final ranges).

    Returns:
        (B, 4, 3, H, W): diffuse, specular (grey, broadcast to 3 channels), roughness (broadcast),
        normal encoded as (n + 1) / 2.
    """
    b, _, h, w = maps.shape
    spec = maps[:, SLICES["specular"]].expand(b, 3, h, w)
    rough = maps[:, SLICES["roughness"]].expand(b, 3, h, w)
    normal = (maps[:, SLICES["normal"]] + 1.0) * 0.5
    return torch.stack([maps[:, SLICES["diffuse"]], spec, rough, normal], dim=1)


def _modulus(z: torch.Tensor) -> torch.Tensor:
    # |z| with a finite gradient at z = 0 (torch.abs of a complex zero has a NaN gradient)
    return torch.sqrt(z.real * z.real + z.imag * z.imag + MODULUS_EPS)


def fourier_loss(maps: torch.Tensor, guess: torch.Tensor, mode: str = "complex", eps: float = 1e-8,
                 include_dc: bool = True) -> torch.Tensor:
    """L_F (Wen et al. Eq. 4): log of the mean L1 distance between the spectra of the maps and the guessed diffuse.

    For each map u of :func:`maps_for_loss` and the guess g, with 2D FFTs over (H, W) normalised "ortho"
    (size-independent magnitudes):

    * ``mode="complex"`` (literal Eq. 4): ``|FFT(u) - FFT(g)|``, the modulus of the complex difference;
    * ``mode="magnitude"`` (translation-invariant, as Henzler et al. 2021): ``| |FFT(u)| - |FFT(g)| |``;

    averaged over the frequencies (all, or all but DC if ``include_dc=False``), channels, maps and batch; the
    loss is ``log(mean + eps)``. FFTs run in float32 (float64 for float64 input) even under autocast.

    Args:
        maps: (B, 8, H, W) packed predicted maps, final ranges.
        guess: (B, 3, H, W) guessed diffuse crop in [0, 1].
        mode: "complex" or "magnitude".
        eps: added inside the log.
        include_dc: keep the zero-frequency coefficient (the mean of the map).

    Returns:
        scalar (negative when the mean distance is below 1).

    Raises:
        ValueError: an unknown ``mode``, or ``include_dc=False`` on a single pixel.
    """
    if mode not in ("complex", "magnitude"):
        raise ValueError(f"mode must be 'complex' or 'magnitude', got {mode!r}")
    h, w = maps.shape[-2:]
    if not include_dc and h * w < 2:
        raise ValueError("include_dc=False needs at least 2 pixels")
    with torch.autocast(device_type=maps.device.type, enabled=False):
        u = maps_for_loss(_f32(maps))
        g = _f32(guess)[:, None]  # (B, 1, 3, H, W), broadcast over the four maps
        if mode == "complex":
            dist = _modulus(torch.fft.fft2(u - g, norm="ortho"))  # FFT is linear: FFT(u) - FFT(g) = FFT(u - g)
        else:
            dist = (_modulus(torch.fft.fft2(u, norm="ortho")) - _modulus(torch.fft.fft2(g, norm="ortho"))).abs()
        if include_dc:
            mean = dist.mean()
        else:
            per_image = (dist.sum(dim=(-2, -1)) - dist[..., 0, 0]) / (h * w - 1)
            mean = per_image.mean()
        return torch.log(mean + eps)


def clipped_fraction(photo: torch.Tensor, level: float = CLIP_LEVEL) -> float:
    """Fraction of pixels whose brightest channel is at or above ``level``: how much of the photo a saturated
    flash highlight covers.

    Args:
        photo: (B, 3, H, W) linear RGB in [0, 1].
        level: linear value counted as clipped (0.99: sensor saturation after sRGB decoding of 8-bit 253+).

    Returns:
        float in [0, 1].
    """
    return float((photo.amax(dim=1) >= level).float().mean())


# ----------------------------------------------------------------------------------- supervised (stage-one prior)
#: Per-map weights of :func:`supervised_maps_loss` (normals count double: their components vary little).
SUPERVISED_WEIGHTS = {"diffuse": 1.0, "specular": 1.0, "roughness": 1.0, "normal": 2.0}
#: Offset inside the logarithm of :func:`relit_loss` (linear radiance units).
RELIT_LOG_EPS = 0.01


def supervised_maps_loss(pred: torch.Tensor, target: torch.Tensor, weights=None) -> Dict[str, torch.Tensor]:
    """Mean absolute error per map between predicted and ground-truth maps (the prior's map term).

    The diffuse albedo is compared sRGB-encoded (kornia's curve), so an error on a dark or grey material weighs
    as much as one on a bright material; the others as stored.

    Args:
        pred, target: (B, 8, H, W) packed maps, final ranges (:mod:`svbrdf.runtime.core.maps`).
        weights: per-map weights (default :data:`SUPERVISED_WEIGHTS`).

    Returns:
        ``{"diffuse", "specular", "roughness", "normal", "total"}`` scalars; ``total`` is the weighted sum.
    """
    weights = dict(SUPERVISED_WEIGHTS if weights is None else weights)
    with torch.autocast(device_type=pred.device.type, enabled=False):
        p, t = _f32(pred), _f32(target)
        out = {}
        for name in ("diffuse", "specular", "roughness", "normal"):
            a, b = p[:, SLICES[name]], t[:, SLICES[name]]
            if name == "diffuse":
                a, b = linear_to_srgb(a, clip=True), linear_to_srgb(b, clip=True)
            out[name] = (a - b).abs().mean()
        out["total"] = sum(weights[k] * out[k] for k in ("diffuse", "specular", "roughness", "normal"))
    return out


def relit_loss(pred_renderings: torch.Tensor, target_renderings: torch.Tensor, eps: float = RELIT_LOG_EPS) -> torch.Tensor:
    """Rendering loss of predicted against ground-truth maps under the same lights: mean absolute difference of
    ``log(eps + radiance)`` (the log keeps a highlight from drowning the rest of the image).

    Args:
        pred_renderings, target_renderings: (..., 3, H, W) linear radiance (>= 0, unclipped) of the predicted and
            true maps under the same lights and view.
        eps: offset inside the log, linear units.

    Returns:
        scalar.
    """
    with torch.autocast(device_type=pred_renderings.device.type, enabled=False):
        a = torch.log(_f32(pred_renderings).clamp_min(0.0) + eps)
        b = torch.log(_f32(target_renderings).clamp_min(0.0) + eps)
        return (a - b).abs().mean()


#: Maps whose spatial detail :func:`gradient_loss` compares by default.
GRADIENT_MAPS = ("normal", "roughness")


def gradient_loss(pred: torch.Tensor, target: torch.Tensor, maps: Sequence[str] = GRADIENT_MAPS) -> torch.Tensor:
    """Detail term: mean absolute difference of the horizontal and vertical forward differences of the named maps.

    A per-map L1 is satisfied by a blurred map (the mean of the possible details); this term asks for the detail
    itself (its edges and slopes), as map errors of the same size do not.

    Args:
        pred, target: (B, 8, H, W) packed maps, final ranges (:mod:`svbrdf.runtime.core.maps`), H, W >= 2.
        maps: names of :data:`svbrdf.runtime.core.maps.SLICES` to compare (default: normal and roughness).

    Returns:
        scalar: the mean over the differences of both directions and every channel of those maps.
    """
    with torch.autocast(device_type=pred.device.type, enabled=False):
        p = torch.cat([_f32(pred[:, SLICES[n]]) for n in maps], dim=1)
        t = torch.cat([_f32(target[:, SLICES[n]]) for n in maps], dim=1)
        dx = (p[..., :, 1:] - p[..., :, :-1]) - (t[..., :, 1:] - t[..., :, :-1])
        dy = (p[..., 1:, :] - p[..., :-1, :]) - (t[..., 1:, :] - t[..., :-1, :])
        return 0.5 * (dx.abs().mean() + dy.abs().mean())


#: Truths whose slopes spread less than this in both components have no pattern to correlate with: left out.
SLOPE_MIN_STD = 1e-3


def slope_correlation_loss(pred: torch.Tensor, target: torch.Tensor, eps: float = 1e-8) -> torch.Tensor:
    """Pattern-of-relief term: one minus the correlation of the predicted and true surface slopes, per image.

    The slopes are :func:`~svbrdf.runtime.core.relief.clamped_slopes` (``(-n_x / n_z, -n_y / n_z)``, ``n_z`` clamped
    at ``SLOPE_MIN_NZ``), each component's mean over the image removed; the correlation is over both components and
    every pixel (the benchmark's ``normal_slope_corr``). It does not depend on the prediction's scale, so its
    gradient reaches the network however flat the normals are; the per-map L1 then sets the amplitude.
    Decision: docs/decisions/023-stage-one-v2.md (the slope term)

    Args:
        pred, target: (B, 8, H, W) packed maps, final ranges (:mod:`svbrdf.runtime.core.maps`), unit normals.
        eps: added to the correlation's denominator.

    Returns:
        scalar in [0, 2]: the mean of ``1 - corr`` over the images whose true slopes vary (0 if none do).
    """
    with torch.autocast(device_type=pred.device.type, enabled=False):
        def slopes(maps: torch.Tensor) -> torch.Tensor:
            s = clamped_slopes(_f32(maps[:, SLICES["normal"]]), axis=1)
            return s - s.mean(dim=(2, 3), keepdim=True)

        a, b = slopes(pred), slopes(target)
        aa, bb = (a * a).sum(dim=(1, 2, 3)), (b * b).sum(dim=(1, 2, 3))
        corr = (a * b).sum(dim=(1, 2, 3)) / (aa * bb + eps).sqrt()
        valid = (b.flatten(2).std(dim=2) > SLOPE_MIN_STD).any(dim=1).to(corr.dtype)  # ridges along one axis count
        return ((1.0 - corr) * valid).sum() / valid.sum().clamp_min(1.0)


#: Sides of the square windows, px, whose spread :func:`detail_amount_loss` compares (clamped to the image side).
DETAIL_WINDOWS = (16, 64)


def _window_std(x: torch.Tensor, side: int) -> torch.Tensor:
    """Standard deviation of ``x`` (B, C, H, W) in non-overlapping ``side`` x ``side`` windows: (B, C, H/s, W/s)."""
    side = max(1, min(side, x.shape[-2], x.shape[-1]))
    mean = F.avg_pool2d(x, side)
    return (F.avg_pool2d(x * x, side) - mean * mean).clamp_min(0.0).add(1e-6).sqrt()


def detail_amount_loss(pred: torch.Tensor, target: torch.Tensor, maps: Sequence[str] = GRADIENT_MAPS,
                       windows: Sequence[int] = DETAIL_WINDOWS) -> torch.Tensor:
    """Amount-of-detail term: mean absolute difference of the maps' standard deviations in local windows.

    It asks for as much variation as the truth has in each window, wherever it lies inside the window (per-pixel
    L1 and :func:`gradient_loss` cost less for a flat map than for detail slightly misplaced). It is zero for a map
    whose windows vary as much as the truth's, and largest for a constant one (which alone gets no gradient from
    it). Decision: docs/decisions/023-stage-one-v2.md (the roughness detail term)

    Args:
        pred, target: (B, 8, H, W) packed maps, final ranges (:mod:`svbrdf.runtime.core.maps`).
        maps: names of :data:`svbrdf.runtime.core.maps.SLICES` to compare (default: normal and roughness).
        windows: window sides, px (each clamped to the image's shorter side; H and W multiples of it where it
            fits, or the border rows are left out).

    Returns:
        scalar: the mean over window sizes of the mean absolute difference of the per-window, per-channel
        standard deviations.
    """
    with torch.autocast(device_type=pred.device.type, enabled=False):
        p = torch.cat([_f32(pred[:, SLICES[n]]) for n in maps], dim=1)
        t = torch.cat([_f32(target[:, SLICES[n]]) for n in maps], dim=1)
        return torch.stack([(_window_std(p, s) - _window_std(t, s)).abs().mean() for s in windows]).mean()


__all__ = [
    "clipped_fraction", "CLIP_LEVEL", "guessed_diffuse", "diffuse_loss", "DIFFUSE_TARGETS", "render_loss",
    "FLASH_POWERS", "flash_basis", "flash_maps", "flash_correlation_loss", "specular_prior_loss",
    "gan_generator_loss", "gan_discriminator_loss", "maps_for_loss", "fourier_loss", "SUPERVISED_WEIGHTS",
    "supervised_maps_loss", "RELIT_LOG_EPS", "relit_loss", "GRADIENT_MAPS", "gradient_loss", "DETAIL_WINDOWS",
    "detail_amount_loss", "slope_correlation_loss",
]
