"""Seeded, on-the-fly procedural SVBRDF materials (torch, CPU, float32) for pretraining.

:func:`sample_materials` draws ``n`` materials of ``size x size`` pixels, packed channel-first ``(n, 8, H, W)``
in the layout of :mod:`svbrdf.runtime.core.maps` (diffuse linear RGB, specular grey F0, perceptual roughness, unit
OpenGL-frame normals). Every random number comes from the caller's :class:`torch.Generator`, so a generator
state fully determines the batch.

How a material is built
-----------------------

1. A *family* function (one per entry of :data:`FAMILIES`) draws a pattern: K = 2 or 3 soft class weights
   (tile / grout, thread A / thread B / gap, metal / scratch ...), a height field, an optional per-cell value
   (per-tile colour jitter) and which classes are metallic.
2. Each class gets its own diffuse colour, specular and roughness (:func:`_class_materials`); the maps are the
   class values blended by the weights, modulated by mild noise (``detail_*`` ranges). Specular and roughness
   therefore follow the class masks, not independent noise.
3. Normals are ``height_to_normal(height, scale)`` (:func:`svbrdf.trainer.models.height_to_normal`, the generator
   network's own parameterisation), with ``scale`` solved so that the mean normal angle matches a target angle
   drawn log-uniformly in ``normal_angle_deg``.

Families
--------

=============  ==================================================================================================
noise          fBm grain; two classes split by a soft threshold of a second fBm (stains, speckle)
cells          Voronoi cells with borders; a random subset of cells in a second colour
tiles          tiles or bricks (grid or running bond) with grout, bevelled edges, per-tile colour jitter
wood           planks with seams; growth rings (early / late wood) warped by grain-stretched noise
weave          over-under woven fabric (plain or twill) of two thread colours, threads with a rounded profile
knit           stockinette knit: V-shaped stitches of rounded yarn legs, optional colour stripes, dark gaps
leather        pebbled leather: warped Voronoi cells with rounded tops and dark creases, worn patches
plaster        low-frequency plaster bumps under paint, paint flaked off in fBm-shaped patches
scratches      a base (metal or dielectric) with thin random scratch segments and round dents
brushed_metal  anisotropic stretched-noise brushing; a second finish (metal or dirt) in patches
flat_metal     flat or hammered metal with patina / oxidation patches and smudges
stone          multi-octave noise with warped ridged veins and small grains
=============  ==================================================================================================

Devices
-------

``sample_materials(..., device="cuda")`` builds the maps on that device: every field is computed there, and nothing
is read back to the host (the slope factor of the normals stays a device tensor). Every random number still comes
from the caller's CPU generator, in the same order: scalar draws are host numbers that parameterise the kernels, and
random tables and spectra are drawn on the CPU and copied to the device asynchronously
(:func:`svbrdf.trainer.device.to_device`). The stream is therefore the same on every
device (to float rounding), and a run resumed on another device continues it. On the CPU nothing changes.

Parameter distributions
-----------------------

All ranges are in :data:`PARAMS` (the one table of the generator's ranges). Colours are drawn perceptually in
sRGB-encoded HSV and decoded to linear: with ``neutral_class_p`` a class is neutral (R = G = B exactly), and with
``neutral_material_p`` the whole material is (with the per-class draws ~30 % of materials end up fully
neutral). The sRGB value spans ``value_srgb`` (about 0.01 to 0.91 linear). Metal classes have a near-black diffuse
(< ``metal_diffuse_max`` linear) and specular in ``spec_metal``; dielectric specular is log-uniform in
``spec_dielectric`` with a ``spec_dielectric_tail`` tail. Roughness is uniform in ``roughness``. Feature counts
across the image are log-uniform in ``features`` (at least ``min_feature_px`` pixels per feature).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import List, Optional, Sequence, Tuple, Union

import torch

from svbrdf.runtime.core.maps import SLICES
from svbrdf.trainer.colour import srgb_to_linear
from svbrdf.trainer.device import to_device
from svbrdf.trainer.models import height_to_normal, pack_maps

__all__ = ["FAMILIES", "sample_materials"]

#: Every range of the generator. (lo, hi) pairs are uniform unless the comment says log-uniform.
PARAMS = {
    # --- colour / BRDF values of a class ---
    "neutral_material_p": 0.22,  # whole material grey (all classes R = G = B)
    "neutral_class_p": 0.35,  # one class grey
    "value_srgb": (0.1, 0.96),  # HSV value, sRGB-encoded (0.01 .. 0.91 linear)
    "saturation": (0.08, 0.9),
    "metal_value_srgb": (0.0, 0.24),  # metal diffuse, sRGB-encoded (< 0.047 linear)
    "metal_diffuse_max": 0.05,  # linear bound the above guarantees
    "spec_metal": (0.5, 1.0),
    "spec_dielectric": (0.02, 0.08),  # log-uniform
    "spec_dielectric_tail_p": 0.2,
    "spec_dielectric_tail": (0.08, 0.3),
    "roughness": (0.05, 1.0),
    "random_metal_class_p": 0.04,  # any dielectric class of any family turned metal
    "related_p": 0.7,  # a related class (late wood, crease, gap) derives its colour from its source class
    "related_factor": (0.25, 0.7),  # ... times this linear factor (darker)  # darker related classes (late wood, creases, gaps): linear factor
    # --- modulation inside a class ---
    "detail_diffuse": (0.0, 0.3),  # relative brightness modulation by noise
    "detail_specular": (0.0, 0.3),  # relative
    "detail_roughness": (0.0, 0.12),  # absolute
    "cell_jitter": (0.0, 0.35),  # relative brightness jitter per cell / tile / plank
    "detail_beta": (0.6, 1.4),
    # --- geometry ---
    "normal_angle_deg": (2.0, 25.0),  # log-uniform target mean normal angle
    "features": (2.5, 60.0),  # log-uniform feature count across the image
    "min_feature_px": 4.0,
    "fbm_beta": (0.8, 1.6),  # spectral amplitude ~ f^-beta
    "soft_px": (0.5, 2.0),  # edge softness of class masks, px
    # --- families ---
    "tiles_count": (2, 16),  # tiles across (int)
    "tiles_aspect": (1.0, 1.0, 2.0, 3.0),  # tile width / height choices (1 = square, 2-3 = bricks)
    "tiles_grout": (0.004, 0.025),  # grout half-width, fraction of the image
    "tiles_bevel": (0.002, 0.02),  # fraction of the image
    "tiles_bond_p": 0.5,
    "tiles_second_p": 0.4,  # second tile colour (random or checker)
    "wood_planks": (1, 7),  # planks across (int)
    "wood_plank_length": (0.3, 1.5),  # fraction of the image
    "wood_rings": (4.0, 30.0),  # rings per plank width
    "wood_hue_p": 0.75,  # brown hues
    "wood_hue": (0.03, 0.12),  # hue fraction of a turn
    "weave_threads": (6, 48),  # threads across (int)
    "weave_width": (0.65, 0.95),  # thread width / pitch
    "weave_twill_p": 0.4,
    "knit_columns": (5, 24),
    "knit_stripes_p": 0.5,
    "leather_cells": (8, 32),
    "leather_crease": (0.04, 0.15),  # crease width in cell units
    "leather_hue_p": 0.5,
    "leather_hue": (0.0, 0.11),
    "plaster_paint_cover": (0.4, 0.9),  # paint coverage
    "scratches_count": (15, 90),
    "scratches_length": (0.05, 0.5),  # fraction of the image
    "scratches_width_px": (0.6, 1.8),
    "scratches_spread_rad": (0.05, 1.6),
    "scratches_dents": (0, 8),
    "scratches_metal_p": 0.5,
    "brushed_aniso": (8.0, 48.0),
    "flat_metal_hammered_p": 0.4,
    "stone_vein_width": (0.006, 0.03),
    "stone_grain_p": 0.5,
    # --- coarse relief (only drawn for the prior's ``coarse_share``: :func:`coarse_height`) ---
    "coarse_features": (1.0, 6.0),  # log-uniform features across the image (rounded up; stones: at least 2)
    "coarse_tilt_deg": (2.0, 15.0),  # log-uniform mean normal angle of the coarse relief alone
    "coarse_stones_p": 0.5,  # uneven stones (Voronoi cells at their own level, domed, grooves between); else a warp
    "coarse_groove": (0.1, 0.5),  # width of the slope down to a groove between stones, in cell units (F2 - F1)
}

FAMILIES: Tuple[str, ...] = ("noise", "cells", "tiles", "wood", "weave", "knit", "leather", "plaster", "scratches",
                             "brushed_metal", "flat_metal", "stone")

TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------------------------------------------------------
# random draws (only ever from the caller's generator)
# ---------------------------------------------------------------------------------------------------------------

def _u(g: torch.Generator, lo: float = 0.0, hi: float = 1.0) -> float:
    return lo + (hi - lo) * float(torch.rand((), generator=g, device="cpu"))


def _logu(g: torch.Generator, lo: float, hi: float) -> float:
    return math.exp(_u(g, math.log(lo), math.log(hi)))


def _int(g: torch.Generator, lo: int, hi: int) -> int:
    """Uniform integer in [lo, hi] (inclusive)."""
    return int(torch.randint(int(lo), int(hi) + 1, (), generator=g, device="cpu"))


def _chance(g: torch.Generator, p: float) -> bool:
    return _u(g) < p


def _rand(g: torch.Generator, *shape: int) -> torch.Tensor:
    """Uniform [0, 1) tensor drawn from ``g`` on the CPU, on the device the materials are built on."""
    return to_device(torch.rand(shape, generator=g, device="cpu"), torch.get_default_device())


def _randn(g: torch.Generator, *shape: int) -> torch.Tensor:
    """Standard normal tensor drawn from ``g`` on the CPU, on the device the materials are built on."""
    return to_device(torch.randn(shape, generator=g, device="cpu"), torch.get_default_device())


def _choice(g: torch.Generator, options: Sequence):
    return options[_int(g, 0, len(options) - 1)]


# ---------------------------------------------------------------------------------------------------------------
# building blocks
# ---------------------------------------------------------------------------------------------------------------

def hsv_to_rgb(hsv: torch.Tensor) -> torch.Tensor:
    """HSV to RGB, per pixel: (*, 3, H, W) with hue in radians [0, 2 pi), saturation and value in [0, 1] -> RGB in
    the same encoding as the value (here sRGB-encoded). The closed form ``c = v - v s clamp(min(k, 4 - k), 0, 1)``
    with ``k = (n + 6 h / 2 pi) mod 6`` and n = 5, 3, 1 for R, G, B (the conversion kornia's ``hsv_to_rgb``
    implements, which this module used; checked against it in ``tests/trainer/test_procedural.py``)."""
    h, s, v = hsv.unbind(-3)
    h6 = h * (6.0 / TWO_PI)
    out = []
    for n in (5.0, 3.0, 1.0):
        k = torch.remainder(n + h6, 6.0)
        out.append(v - v * s * torch.minimum(k, 4.0 - k).clamp(0.0, 1.0))
    return torch.stack(out, dim=-3)


def _smoothstep(e0, e1, x: torch.Tensor) -> torch.Tensor:
    t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _norm01(x: torch.Tensor) -> torch.Tensor:
    """Min-max normalise each (H, W) field of (..., H, W) to [0, 1]."""
    flat = x.flatten(-2)
    lo, hi = flat.min(-1, keepdim=True)[0], flat.max(-1, keepdim=True)[0]
    return ((flat - lo) / (hi - lo).clamp_min(1e-12)).view_as(x)


def _features(g: torch.Generator, size: int, lo: Optional[float] = None, hi: Optional[float] = None) -> float:
    """Log-uniform feature count across the image, at most ``size / min_feature_px``."""
    flo, fhi = PARAMS["features"]
    lo, hi = lo or flo, hi or fhi
    hi = max(min(hi, size / PARAMS["min_feature_px"]), lo)
    return _logu(g, lo, hi) if hi > lo else lo


def _pixel_xy(size: int) -> Tuple[torch.Tensor, torch.Tensor]:
    """(H, W) pixel-centre coordinates in image units: x right, y up, centred on the image."""
    return _pixel_xy_on(size, torch.get_default_device())


@lru_cache(maxsize=8)
def _pixel_xy_on(size: int, device: torch.device) -> Tuple[torch.Tensor, torch.Tensor]:
    t = (torch.arange(size, dtype=torch.float32, device=device) + 0.5) / size - 0.5
    y, x = torch.meshgrid(-t, t, indexing="ij")
    return x, y


def _grid(size: int, g: torch.Generator, scale: Tuple[float, float], angle: Optional[float] = None
          ) -> Tuple[torch.Tensor, torch.Tensor]:
    """Rotated, scaled, offset coordinates (u, v), each (H, W): ``scale`` features per image width along u, v.

    ``angle`` (radians) rotates the pattern; ``None`` draws it uniformly.
    """
    if angle is None:
        angle = _u(g, 0.0, TWO_PI)
    x, y = _pixel_xy(size)
    c, s = math.cos(angle), math.sin(angle)
    u = (c * x + s * y) * scale[0] + _u(g, 0.0, 16.0)
    v = (-s * x + c * y) * scale[1] + _u(g, 0.0, 16.0)
    return u, v


def _axis_angle(g: torch.Generator, free_p: float = 0.25) -> float:
    """Mostly axis-aligned (0 or 90 degrees, a little jitter), sometimes any angle."""
    if _chance(g, free_p):
        return _u(g, 0.0, TWO_PI)
    return _choice(g, (0.0, 0.5 * math.pi)) + _u(g, -0.03, 0.03)


def _freqs(size: int) -> Tuple[torch.Tensor, torch.Tensor]:
    return _freqs_on(size, torch.get_default_device())


@lru_cache(maxsize=8)
def _freqs_on(size: int, device: torch.device) -> Tuple[torch.Tensor, torch.Tensor]:
    fy = torch.fft.fftfreq(size, d=1.0 / size, device=device)
    fx = torch.fft.rfftfreq(size, d=1.0 / size, device=device)
    return torch.meshgrid(fy, fx, indexing="ij")


def _fbm(k: int, size: int, g: torch.Generator, beta: float, low: float, aniso: float = 1.0,
         angle: float = 0.0) -> torch.Tensor:
    """(k, H, W) periodic fBm fields in [0, 1] by spectral synthesis.

    A random complex spectrum with amplitude ``(f^2 + low^2)^(-beta/2)`` (f in cycles per image; flat below
    ``low``, so features are about ``1/low`` of the image) goes through an inverse real FFT. ``aniso > 1``
    stretches the features along the direction ``angle`` (radians, image x right / y down) by that factor.
    """
    fy, fx = _freqs(size)
    c, s = math.cos(angle), math.sin(angle)
    along, across = fx * c + fy * s, -fx * s + fy * c
    amp = ((along * aniso) ** 2 + across ** 2 + low * low) ** (-0.5 * beta)
    amp[:1, :1].zero_()  # no DC term (a fill on the device: `amp[0, 0] = 0.0` copies a host scalar, a GPU sync)
    shape = (k,) + tuple(amp.shape)
    spec = torch.complex(_randn(g, *shape), _randn(g, *shape)) * amp
    return _norm01(torch.fft.irfft2(spec, s=(size, size)))


def _worley(u: torch.Tensor, v: torch.Tensor, cells: int, g: torch.Generator, jitter: float = 0.9
            ) -> Tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Voronoi distances of a jittered grid of feature points (one per unit cell, period ``cells``).

    Args:
        u, v: (H, W) coordinates in cell units.
        cells: period of the random point table (cells per period along u and v).
        jitter: 0 = regular grid, 1 = points anywhere in their cell.

    Returns:
        F1 (H, W) distance to the nearest point, F2 (H, W) to the second nearest (cell units), and the cell id
        (H, W) int64 in [0, cells^2) of the nearest point.
    """
    pts = 0.5 + jitter * (_rand(g, 2, cells * cells) - 0.5)
    iu, iv = torch.floor(u), torch.floor(v)
    fu, fv = u - iu, v - iv
    iu, iv = iu.long(), iv.long()
    d = torch.arange(-1, 2)
    du, dv = [t.reshape(9, 1, 1) for t in torch.meshgrid(d, d, indexing="ij")]
    idx = ((iu + du) % cells) * cells + (iv + dv) % cells  # (9, H, W)
    dist = torch.hypot(pts[0][idx] + du - fu, pts[1][idx] + dv - fv)
    near, order = torch.topk(dist, 2, dim=0, largest=False)
    return near[0], near[1], idx.gather(0, order[:1])[0]


#: Pixels (segments x window) rasterised at once by :func:`_segments`: bounds the memory on a CPU.
SEGMENT_CHUNK_PIXELS = 1 << 20


def _segments(size: int, g: torch.Generator, n: int, angle: float, spread: float, length: Tuple[float, float],
              width_px: Tuple[float, float]) -> torch.Tensor:
    """(H, W) mask in [0, 1] of ``n`` thin line segments (anti-aliased, random depth in [0.4, 1]).

    Directions are ``angle + spread * N(0, 1)``; lengths uniform in ``length`` (fraction of the image); widths
    (half-widths, px) uniform in ``width_px``. Each segment is rasterised in its bounding box, many at once: the
    segments (smallest boxes first) go in chunks of at most :data:`SEGMENT_CHUNK_PIXELS` pixels, each segment in a
    window of its chunk's largest box at its own box's corner, and the image keeps the largest value per pixel. A
    window's pixels outside its segment's box are 0 (farther than the width from the segment) and those outside the
    image are dropped, so the mask is the same as one box at a time; a chunk is about 30 operations on the device
    whatever its size (a box at a time was about 50 per segment, the largest share of a batch's launches on a GPU).
    """
    out = torch.zeros(size, size)
    r = torch.rand(n, 6, generator=g, device="cpu").tolist()  # host numbers: the segment boxes
    th = (angle + spread * torch.randn(n, generator=g, device="cpu")).tolist()
    boxes = []  # (area, y0, x0, height, width, cy - dy, cx - dx, dx, dy, 4 half^2 + 1e-9, w, depth), host floats
    for (ru, rv, rl, rw, rd, _), theta in zip(r, th):
        cx, cy = ru * size, rv * size
        half = 0.5 * size * (length[0] + (length[1] - length[0]) * rl)
        w = width_px[0] + (width_px[1] - width_px[0]) * rw
        depth = 0.4 + 0.6 * rd
        dx, dy = math.cos(theta) * half, math.sin(theta) * half
        x0, x1 = int(max(0, math.floor(cx - abs(dx) - w - 1))), int(min(size, math.ceil(cx + abs(dx) + w + 2)))
        y0, y1 = int(max(0, math.floor(cy - abs(dy) - w - 1))), int(min(size, math.ceil(cy + abs(dy) + w + 2)))
        if x1 > x0 and y1 > y0:
            boxes.append(((y1 - y0) * (x1 - x0), y0, x0, y1 - y0, x1 - x0, cy - dy, cx - dx, dx, dy,
                          4 * half * half + 1e-9, w, depth))
    boxes.sort(key=lambda b: b[0])
    flat = out.view(-1)
    start = 0
    while start < len(boxes):
        end, bh, bw = start, 0, 0
        while end < len(boxes) and (end == start or (end + 1 - start) * max(bh, boxes[end][3]) * max(
                bw, boxes[end][4]) <= SEGMENT_CHUNK_PIXELS):
            bh, bw, end = max(bh, boxes[end][3]), max(bw, boxes[end][4]), end + 1
        corner = to_device([b[1:3] for b in boxes[start:end]], flat.device, torch.int64)  # (k, 2) box corners
        prm = to_device([b[5:] for b in boxes[start:end]], flat.device, torch.float64).float()  # (k, 7)
        c0, c1, dx, dy, span, w, depth = (prm[:, i, None, None] for i in range(7))
        rows = corner[:, 0, None, None] + torch.arange(bh)[None, :, None]  # (k, bh, 1) pixel rows
        cols = corner[:, 1, None, None] + torch.arange(bw)[None, None, :]  # (k, 1, bw) pixel columns
        ys, xs = rows.float() + 0.5 - c0, cols.float() + 0.5 - c1
        t = ((xs * 2 * dx + ys * 2 * dy) / span).clamp(0.0, 1.0)
        dist = torch.hypot(xs - t * 2 * dx, ys - t * 2 * dy)
        m = (1.0 - dist / w).clamp(0.0, 1.0) * depth
        inside = (rows < size) & (cols < size)  # the image's pixels (the box is clipped to it at the low side)
        index = torch.where(inside, rows * size + cols, 0)
        flat.scatter_reduce_(0, index.reshape(-1), torch.where(inside, m, 0.0).reshape(-1), reduce="amax")
        start = end
    return out


def _soft(g: torch.Generator, size: int) -> float:
    """Random class-edge softness in image-fraction units (``soft_px`` pixels)."""
    return _u(g, *PARAMS["soft_px"]) / size


# ---------------------------------------------------------------------------------------------------------------
# families
# ---------------------------------------------------------------------------------------------------------------

@dataclass
class _Pattern:
    """What a family draws. K classes.

    weights: (K, H, W) soft class weights (normalised to sum 1 afterwards).
    height: (H, W) height, any range (normalised to [0, 1] afterwards).
    metal: K flags.
    cell: (H, W) per-cell value in [-1, 1] for brightness jitter (0 where it does not apply), or None.
    detail: (H, W) noise in [0, 1] modulating the class values, or None (a generic fBm is drawn).
    related: {k: src} class k's colour is class src's scaled by a ``related_factor`` draw (darker).
    hue: (lo, hi) hue range (fraction of a turn) used with probability hue_p; None = any hue.
    """

    weights: torch.Tensor
    height: torch.Tensor
    metal: Tuple[bool, ...]
    cell: Optional[torch.Tensor] = None
    detail: Optional[torch.Tensor] = None
    related: Optional[dict] = None
    hue: Optional[Tuple[float, float]] = None
    hue_p: float = 0.0


def _fam_noise(size: int, g: torch.Generator) -> _Pattern:
    feat = _features(g, size)
    f = _fbm(3, size, g, _u(g, *PARAMS["fbm_beta"]), feat)
    level, soft = _u(g, 0.3, 0.7), _u(g, 0.01, 0.15)
    a = _smoothstep(level - soft, level + soft, f[1])
    if _chance(g, 0.5):  # a third class: speckles
        lvl = _u(g, 0.7, 0.85)
        b = _smoothstep(lvl, lvl + 0.02, f[2])
        w = torch.stack([(1 - a) * (1 - b), a * (1 - b), b])
    else:
        w = torch.stack([1 - a, a])
    return _Pattern(w, f[0] + _u(g, 0.0, 0.3) * a, (False,) * w.shape[0])


def _fam_cells(size: int, g: torch.Generator) -> _Pattern:
    c = max(2, round(_features(g, size, 2.5, 30.0)))
    u, v = _grid(size, g, (c, c))
    f1, f2, cid = _worley(u, v, c, g, _u(g, 0.5, 1.0))
    border = _u(g, 0.02, 0.15)
    inside = _smoothstep(border, border + _soft(g, size) * c, f2 - f1)
    rnd = _rand(g, c * c)[cid]
    sel = (rnd < _u(g, 0.0, 0.6)).float()
    w = torch.stack([inside * (1 - sel), inside * sel, 1 - inside])
    dome = _u(g, 0.0, 1.0)
    height = inside * (1 + dome * (f2 - f1).clamp(max=0.5) + 0.3 * rnd)
    return _Pattern(w, height, (False, False, False), cell=inside * (2 * rnd - 1))


def _fam_tiles(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    nx = min(_int(g, *P["tiles_count"]), int(size // 8))
    aspect = _choice(g, P["tiles_aspect"])
    ny = max(1, round(nx * aspect * _u(g, 0.8, 1.25)))
    u, v = _grid(size, g, (nx, ny), _axis_angle(g, 0.15))
    row = torch.floor(v)
    if _chance(g, P["tiles_bond_p"]):
        u = u + _choice(g, (0.5, 0.5, 1 / 3)) * torch.remainder(row, 2 if aspect > 1 else 3)
    col = torch.floor(u)
    fu, fv = u - col, v - row
    d = torch.minimum(torch.minimum(fu, 1 - fu) / nx, torch.minimum(fv, 1 - fv) / ny)  # image units to the edge
    grout = max(_u(g, *P["tiles_grout"]), 0.7 / size)
    bevel = _u(g, *P["tiles_bevel"])
    tile = _smoothstep(grout, grout + _soft(g, size), d)
    bev = _smoothstep(grout, grout + bevel, d)
    tid = (torch.remainder(col, 64) * 64 + torch.remainder(row, 64)).long()
    rnd = _rand(g, 64 * 64)[tid]
    if _chance(g, P["tiles_second_p"]):
        sel = (torch.remainder(col + row, 2) if _chance(g, 0.4) else (rnd < _u(g, 0.2, 0.5)).float())
        w = torch.stack([tile * (1 - sel), tile * sel, 1 - tile])
    else:
        w = torch.stack([tile, 1 - tile])
    grain = _fbm(1, size, g, 1.2, _features(g, size, 8.0, 80.0))[0]
    height = bev * (1.0 + 0.15 * rnd) + 0.05 * grain
    return _Pattern(w, height, (False,) * w.shape[0], cell=tile * (2 * rnd - 1))


def _fam_wood(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    planks = _int(g, *P["wood_planks"])
    length = _u(g, *P["wood_plank_length"])
    angle = _axis_angle(g, 0.1)
    u, v = _grid(size, g, (1.0 / length, planks), angle)
    row = torch.floor(v)
    rtab = _rand(g, 4, 64)
    ri = torch.remainder(row, 64).long()
    u = u + rtab[0][ri] * 7.0  # staggered plank ends
    col = torch.floor(u)
    fu, fv = u - col, v - row
    pid = (torch.remainder(col, 64) * 64).long() + ri
    prnd = _rand(g, 64 * 64)[pid]
    # growth rings: distance from a per-plank pith below/above the board, warped by grain-stretched noise
    warp = _fbm(1, size, g, 1.3, 3.0, aniso=_u(g, 6.0, 20.0), angle=-angle)[0]
    pith = (prnd - 0.5) * 4.0
    arc = _u(g, 0.0, 0.4)
    r = torch.sqrt((fv - 0.5 - pith) ** 2 + (arc * (fu - 0.5 + prnd)) ** 2)
    rings = _u(g, *P["wood_rings"])
    ring = torch.remainder(r * rings + _u(g, 0.5, 3.0) * warp, 1.0)
    sharp = _u(g, 0.55, 0.9)
    late = _smoothstep(sharp, sharp + 0.08, ring) * (1 - _smoothstep(0.97, 1.0, ring))
    # seams: the distance to the plank edge in pixels
    du = torch.minimum(fu, 1 - fu) * length * size
    dv = torch.minimum(fv, 1 - fv) * size / planks
    seam_px = _u(g, 0.4, 1.5)
    board = _smoothstep(seam_px, seam_px + 1.0, torch.minimum(du, dv))
    w = torch.stack([board * (1 - late), board * late, 1 - board])
    fibre = _fbm(1, size, g, 1.0, 30.0, aniso=12.0, angle=-angle)[0]
    height = board * (1.0 + 0.08 * late + 0.05 * fibre + 0.1 * prnd)
    return _Pattern(w, height, (False,) * 3, cell=board * (2 * prnd - 1), detail=fibre,
                    related={1: 0, 2: 0}, hue=P["wood_hue"], hue_p=P["wood_hue_p"])


def _thread(f: torch.Tensor, width: float) -> torch.Tensor:
    """Rounded cross-section profile in [0, 1] of a thread of ``width`` (fraction of the pitch) at frac ``f``."""
    x = (f - 0.5) / (0.5 * width)
    return torch.sqrt((1 - x * x).clamp_min(0.0))


def _fam_weave(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    n = min(_int(g, *P["weave_threads"]), size // 5)
    angle = _axis_angle(g, 0.3)
    u, v = _grid(size, g, (n, n * _u(g, 0.8, 1.25)), angle)
    i, j = torch.floor(u), torch.floor(v)
    fu, fv = u - i, v - j
    wd = _u(g, *P["weave_width"])
    pw, pf = _thread(fu, wd), _thread(fv, wd)  # warp runs along v (column i), weft along u (row j)
    if _chance(g, P["weave_twill_p"]):
        warp_top = torch.remainder(i + j, 3) != 0
    else:
        warp_top = torch.remainder(i + j, 2) == 0
    hw_top = pw * (0.6 + 0.4 * torch.sin(math.pi * fv))
    hf_top = pf * (0.6 + 0.4 * torch.sin(math.pi * fu))
    hw_low, hf_low = 0.5 * pw, 0.5 * pf
    h_warp = torch.where(warp_top, hw_top, hw_low)
    h_weft = torch.where(warp_top, hf_low, hf_top)
    warp = (h_warp >= h_weft) & (pw > 0)
    weft = ~warp & (pf > 0)
    height = torch.maximum(h_warp, h_weft)
    gap = (1 - _smoothstep(0.0, 0.25, height))
    wa, wb = warp.float() * (1 - gap), weft.float() * (1 - gap)
    fib = _fbm(2, size, g, 1.0, 2.0 * n, aniso=8.0, angle=-angle)
    fib2 = _fbm(1, size, g, 1.0, 2.0 * n, aniso=8.0, angle=-angle + 0.5 * math.pi)[0]
    detail = wa * fib2 + wb * fib[0] + gap * 0.5
    return _Pattern(torch.stack([wa, wb, gap]), height + 0.08 * detail, (False,) * 3, detail=detail,
                    related={2: 0})


def _fam_knit(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    n = min(_int(g, *P["knit_columns"]), size // 8)
    angle = _axis_angle(g, 0.15)
    u, v = _grid(size, g, (n, n * _u(g, 1.1, 1.6)), angle)
    i, j = torch.floor(u), torch.floor(v)
    fu = u - i
    tilt = _u(g, 0.3, 0.5)
    a, b = _u(g, 0.14, 0.19), _u(g, 0.42, 0.52)
    height = torch.zeros_like(u)
    for dj in (-1.0, 0.0, 1.0):  # legs of the stitches of the neighbouring rows overlap
        fv = v - (j + dj)
        for cx, sgn in ((0.3, 1.0), (0.7, -1.0)):
            x, y = fu - cx, fv - 0.5
            c, s = math.cos(sgn * tilt), math.sin(sgn * tilt)
            xr, yr = c * x - s * y, s * x + c * y
            e = (xr / a) ** 2 + (yr / b) ** 2
            height = torch.maximum(height, torch.sqrt((1 - e).clamp_min(0.0)))
    gap = 1 - _smoothstep(0.0, 0.3, height)
    yarn = 1 - gap
    fib = _fbm(1, size, g, 1.0, 3.0 * n, aniso=4.0, angle=-angle + 0.5 * math.pi)[0]
    if _chance(g, P["knit_stripes_p"]):
        period = _int(g, 2, 8)
        sel = (torch.remainder(j, period) < _int(g, 1, period - 1)).float()
        w, related = torch.stack([yarn * (1 - sel), yarn * sel, gap]), {2: 0}
    else:
        w, related = torch.stack([yarn, gap]), {1: 0}
    return _Pattern(w, height + 0.1 * fib, (False,) * w.shape[0], detail=fib, related=related)


def _fam_leather(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    c = min(_int(g, *P["leather_cells"]), size // 5)
    u, v = _grid(size, g, (c, c))
    warp = _fbm(2, size, g, 1.6, 3.0) - 0.5
    amt = _u(g, 0.1, 0.5)
    u, v = u + amt * warp[0], v + amt * warp[1]
    f1, f2, cid = _worley(u, v, c, g, 1.0)
    edge = f2 - f1
    cw = _u(g, *P["leather_crease"])
    top = _smoothstep(0.0, cw, edge)
    rounded = torch.sqrt(_smoothstep(0.0, _u(g, 0.2, 0.5), edge))
    patches = _fbm(1, size, g, 1.5, 2.0)[0]
    lvl = _u(g, 0.65, 0.95)
    worn = _smoothstep(lvl - 0.05, lvl + 0.05, patches)
    w = torch.stack([top * (1 - worn), 1 - top, top * worn])
    return _Pattern(w, rounded, (False,) * 3, related={1: 0}, hue=P["leather_hue"], hue_p=P["leather_hue_p"])


def _fam_plaster(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    bumps = _fbm(1, size, g, _u(g, 1.2, 1.8), _features(g, size, 2.5, 20.0))[0]
    flakes = _fbm(2, size, g, _u(g, 1.0, 1.6), _features(g, size, 3.0, 20.0))
    level = 1 - _u(g, *P["plaster_paint_cover"])
    paint = _smoothstep(level, level + 0.6 * _soft(g, size) * size / 64, flakes[0])
    if _chance(g, 0.4):  # stains on the paint
        lvl = _u(g, 0.65, 0.85)
        stain = _smoothstep(lvl, lvl + 0.1, flakes[1]) * paint
        w = torch.stack([paint - stain, 1 - paint, stain])
    else:
        w = torch.stack([paint, 1 - paint])
    grain = _fbm(1, size, g, 0.9, _features(g, size, 20.0, 100.0))[0]
    height = bumps + _u(g, 0.1, 0.5) * paint + 0.1 * grain * (1 - paint)
    return _Pattern(w, height, (False,) * w.shape[0])


def _fam_scratches(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    metal = _chance(g, P["scratches_metal_p"])
    angle = _u(g, 0.0, math.pi)
    lines = _segments(size, g, _int(g, *P["scratches_count"]), angle, _u(g, *P["scratches_spread_rad"]),
                      P["scratches_length"], P["scratches_width_px"])
    nd = _int(g, *P["scratches_dents"])
    dents = torch.zeros(size, size)
    if nd:
        x, y = _pixel_xy(size)
        prm = _rand(g, nd, 3)
        r = 0.01 + 0.05 * prm[:, 2, None, None]
        dents = torch.exp(-((x - prm[:, 0, None, None] + 0.5) ** 2 + (y - prm[:, 1, None, None] + 0.5) ** 2)
                          / (r * r)).amax(0)
    base = _fbm(1, size, g, _u(g, *P["fbm_beta"]), _features(g, size))[0]
    height = _u(g, 0.02, 0.2) * base - lines - 0.7 * dents
    scr = lines.clamp(0.0, 1.0)
    if _chance(g, 0.4):  # a third class: worn / dirty area
        lvl = _u(g, 0.6, 0.85)
        wear = _smoothstep(lvl - 0.05, lvl + 0.05, _fbm(1, size, g, 1.4, 2.0)[0]) * (1 - scr)
        return _Pattern(torch.stack([1 - scr - wear, scr, wear]), height, (metal, metal, False))
    return _Pattern(torch.stack([1 - scr, scr]), height, (metal, metal))


def _fam_brushed_metal(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    angle = _axis_angle(g, 0.5)
    brush = _fbm(1, size, g, _u(g, 0.7, 1.2), _features(g, size, 20.0, 120.0),
                 aniso=_u(g, *P["brushed_aniso"]), angle=angle)[0]
    patches = _fbm(1, size, g, 1.5, _u(g, 1.0, 4.0))[0]
    lvl = _u(g, 0.55, 0.85)
    second = _smoothstep(lvl - 0.05, lvl + 0.05, patches)
    return _Pattern(torch.stack([1 - second, second]), brush * (1 - 0.7 * second), (True, _chance(g, 0.5)),
                    detail=brush)


def _fam_flat_metal(size: int, g: torch.Generator) -> _Pattern:
    if _chance(g, PARAMS["flat_metal_hammered_p"]):
        c = max(2, round(_features(g, size, 4.0, 30.0)))
        u, v = _grid(size, g, (c, c))
        f1, _, _ = _worley(u, v, c, g, 1.0)
        height = f1 ** 2
    else:
        height = _fbm(1, size, g, 1.8, 2.0)[0]
    f = _fbm(2, size, g, _u(g, 1.0, 1.6), _features(g, size, 2.5, 12.0))
    lvl = _u(g, 0.55, 0.8)
    patina = _smoothstep(lvl - 0.04, lvl + 0.04, f[0])
    lvl2 = _u(g, 0.5, 0.8)
    smudge = _smoothstep(lvl2 - 0.1, lvl2 + 0.1, f[1]) * (1 - patina)
    w = torch.stack([1 - patina - smudge, patina, smudge])
    return _Pattern(w, height + 0.3 * patina, (True, False, True))


def _fam_stone(size: int, g: torch.Generator) -> _Pattern:
    P = PARAMS
    feat = _features(g, size, 2.5, 12.0)
    f = _fbm(2, size, g, _u(g, 0.9, 1.3), feat)
    smooth = _fbm(2, size, g, _u(g, 1.8, 2.3), _u(g, 1.0, 4.0))  # veins: contours of a smooth warped field
    warped = _norm01(smooth[0] + _u(g, 0.2, 0.8) * (smooth[1] - 0.5) + 0.04 * (f[1] - 0.5))
    vw = _u(g, *P["stone_vein_width"])
    vein = 1 - _smoothstep(vw, vw * 2.0, (warped - 0.5).abs())
    if _chance(g, P["stone_grain_p"]):
        c = min(_int(g, 20, 80), size // 4)
        u, v = _grid(size, g, (c, c))
        f1, f2, cid = _worley(u, v, c, g, 1.0)
        sel = (_rand(g, c * c)[cid] < _u(g, 0.1, 0.4)).float()
        grain = sel * _smoothstep(0.02, 0.08, f2 - f1) * (1 - vein)
        w = torch.stack([(1 - vein) * (1 - grain), vein, grain])
    else:
        w = torch.stack([1 - vein, vein])
    height = f[0] + f[1] * 0.3 - _u(g, 0.0, 0.3) * vein
    return _Pattern(w, height, (False,) * w.shape[0])


_FAMILY_FUNCS = {
    "noise": _fam_noise, "cells": _fam_cells, "tiles": _fam_tiles, "wood": _fam_wood, "weave": _fam_weave,
    "knit": _fam_knit, "leather": _fam_leather, "plaster": _fam_plaster, "scratches": _fam_scratches,
    "brushed_metal": _fam_brushed_metal, "flat_metal": _fam_flat_metal, "stone": _fam_stone,
}
assert tuple(_FAMILY_FUNCS) == FAMILIES


# ---------------------------------------------------------------------------------------------------------------
# class values and the maps
# ---------------------------------------------------------------------------------------------------------------

def _class_materials(g: torch.Generator, pat: _Pattern, neutral: bool
                     ) -> Tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Per-class (K, 3) linear diffuse, (K,) specular and (K,) roughness.

    Colours are drawn in sRGB-encoded HSV and decoded with the exact sRGB curve; a neutral class has saturation 0,
    so R = G = B exactly. Related classes (``pat.related``) are their source's colour times a darker factor.
    Computed on the CPU (a few numbers), returned on the device the materials are built on.
    """
    P = PARAMS
    k = len(pat.metal)
    metal = list(pat.metal)
    for i in range(k):
        if not metal[i] and _chance(g, P["random_metal_class_p"]):
            metal[i] = True
    use_hue = pat.hue is not None and _chance(g, pat.hue_p)
    hsv = torch.zeros(k, 3, device="cpu")
    for i in range(k):
        grey = neutral or _chance(g, P["neutral_class_p"])
        hue = _u(g, *pat.hue) if use_hue else _u(g)
        hsv[i, 0] = TWO_PI * hue
        hsv[i, 1] = 0.0 if grey else _u(g, *P["saturation"])
        hsv[i, 2] = _u(g, *(P["metal_value_srgb"] if metal[i] else P["value_srgb"]))
    rgb = srgb_to_linear(hsv_to_rgb(hsv.T[:, :, None]))[:, :, 0].T.contiguous()  # (K, 3) linear
    for dst, src in (pat.related or {}).items():
        if not metal[dst] and not metal[src] and _chance(g, P["related_p"]):
            rgb[dst] = rgb[src] * _u(g, *P["related_factor"])
    spec = torch.empty(k, device="cpu")
    for i in range(k):
        if metal[i]:
            spec[i] = _u(g, *P["spec_metal"])
        elif _chance(g, P["spec_dielectric_tail_p"]):
            spec[i] = _u(g, *P["spec_dielectric_tail"])
        else:
            spec[i] = _logu(g, *P["spec_dielectric"])
    rough = torch.rand(k, generator=g, device="cpu") * (P["roughness"][1] - P["roughness"][0]) + P["roughness"][0]
    dev = torch.get_default_device()
    return to_device(rgb.clamp(0.0, 1.0), dev), to_device(spec, dev), to_device(rough, dev)


def normal_scale(h: torch.Tensor, angle_deg: float) -> torch.Tensor:
    """Slope factor s such that ``height_to_normal(h, s)`` has a mean normal angle of about ``angle_deg``.

    Returns a 0-d float64 tensor on ``h``'s device (0 for a flat height), so nothing is read back from a GPU.
    """
    grad = torch.hypot(h[..., 1:, :-1] - h[..., :-1, :-1], h[..., :-1, 1:] - h[..., :-1, :-1]).flatten()
    mean = grad.mean().double()
    flat = mean < 1e-9
    mean = torch.where(flat, torch.ones_like(mean), mean)
    target = math.radians(angle_deg)
    s = math.tan(target) / mean
    cap = 4.0 * math.tan(target) / mean
    for _ in range(3):  # atan is concave: correct the first guess (at most x4 in all)
        got = torch.atan(s * grad).mean().double()
        s = torch.minimum(s * target / got.clamp_min(1e-9), cap)
    return torch.where(flat, torch.zeros_like(s), s)


def coarse_height(size: int, g: torch.Generator) -> Tuple[torch.Tensor, float]:
    """A coarse relief on its own: ``(height, tilt)``, a (size, size) height field on the default device and the
    mean normal angle in degrees it is meant to have (``coarse_tilt_deg``; :func:`normal_scale` makes it so).

    With ``coarse_stones_p`` uneven stones: a Voronoi tiling of ``k`` cells across (rotated, offset), each cell at
    its own level (0.3-1) with its own dome, grooves of ``coarse_groove`` between them going down to 0 (brick and
    cobble walls, flagstones, leather tiles); otherwise a smooth warp, a (k + 1) x (k + 1) standard normal grid
    bicubically interpolated (warped tiles, dented sheets, wavy plaster). ``k`` is ``coarse_features`` rounded up.
    Every draw comes from ``g``.
    """
    P = PARAMS
    k = math.ceil(_logu(g, *P["coarse_features"]))
    tilt = _logu(g, *P["coarse_tilt_deg"])
    if _chance(g, P["coarse_stones_p"]):
        k = max(k, 2)
        u, v = _grid(size, g, (k, k))
        f1, f2, cid = _worley(u, v, k, g, 1.0)
        level = 0.3 + 0.7 * _rand(g, k * k)
        dome = _rand(g, k * k)
        r = (2.0 * f1 / (f1 + f2).clamp_min(1e-6)) ** 2  # 0 at the cell's point, 1 on its border
        walls = _smoothstep(0.0, _u(g, *P["coarse_groove"]), f2 - f1)
        return walls * (level[cid] + dome[cid] * (1.0 - r)), tilt
    grid = _randn(g, 1, 1, k + 1, k + 1)
    return torch.nn.functional.interpolate(grid, size=(size, size), mode="bicubic", align_corners=True)[0, 0], tilt


def _material(family: str, size: int, g: torch.Generator) -> torch.Tensor:
    """One material: (8, size, size) packed maps."""
    P = PARAMS
    pat = _FAMILY_FUNCS[family](size, g)
    w = pat.weights.clamp_min(0.0)
    w = w / w.sum(0, keepdim=True).clamp_min(1e-6)
    neutral = _chance(g, P["neutral_material_p"])
    rgb, spec, rough = _class_materials(g, pat, neutral)
    detail = pat.detail if pat.detail is not None else \
        _fbm(1, size, g, _u(g, *P["detail_beta"]), _features(g, size, 4.0, 64.0))[0]
    d = 2.0 * detail - 1.0
    bright = 1.0 + _u(g, *P["detail_diffuse"]) * d
    if pat.cell is not None:
        bright = bright + _u(g, *P["cell_jitter"]) * pat.cell
    diffuse = torch.einsum("khw,kc->chw", w, rgb) * bright.clamp_min(0.0)
    specular = (torch.einsum("khw,k->hw", w, spec) * (1.0 + _u(g, *P["detail_specular"]) * d))[None]
    roughness = (torch.einsum("khw,k->hw", w, rough) + _u(g, *P["detail_roughness"]) * d)[None]
    height = _norm01(pat.height)[None, None]
    scale = normal_scale(height, _logu(g, *P["normal_angle_deg"]))
    normal = height_to_normal(height, scale)[0]
    return pack_maps({"diffuse": diffuse.clamp(0.0, 1.0)[None], "specular": specular.clamp(0.0, 1.0)[None],
                      "roughness": roughness.clamp(0.0, 1.0)[None], "normal": normal[None]})[0]


def sample_materials(n: int, size: int, generator: torch.Generator, families: Optional[Sequence[str]] = None,
                     device: Optional[Union[str, torch.device]] = None) -> Tuple[torch.Tensor, List[str]]:
    """Draw ``n`` procedural materials of ``size x size`` pixels.

    Args:
        n: number of materials (>= 1).
        size: side in pixels (>= 8).
        generator: the only source of randomness; the same state gives the same batch.
        families: names from :data:`FAMILIES` to draw from uniformly (default: all).
        device: where the maps are built and returned (default: the CPU); see "Devices" in the module docstring.

    Returns:
        ``(maps, names)``: (n, 8, size, size) float32 packed maps (:data:`svbrdf.runtime.core.maps.SLICES`: diffuse
        linear RGB in [0, 1], specular in [0, 1], perceptual roughness in [0, 1], unit normals with z > 0, OpenGL
        frame) and the family name of each material.

    Raises:
        ValueError: ``n < 1``, ``size < 8``, or an unknown / empty family list.
    """
    if int(n) != n or n < 1:
        raise ValueError(f"sample_materials: n must be an integer >= 1, got {n!r}")
    if int(size) != size or size < 8:
        raise ValueError(f"sample_materials: size must be an integer >= 8, got {size!r}")
    fams = tuple(FAMILIES if families is None else ([families] if isinstance(families, str) else families))
    unknown = [f for f in fams if f not in _FAMILY_FUNCS]
    if unknown or not fams:
        raise ValueError(f"sample_materials: unknown families {unknown or '(empty list)'}; "
                         f"choose from {', '.join(FAMILIES)}")
    picks = torch.randint(0, len(fams), (int(n),), generator=generator, device="cpu").tolist()
    names = [fams[i] for i in picks]
    with torch.no_grad(), torch.device(torch.device(device) if device is not None else "cpu"):
        maps = torch.stack([_material(name, int(size), generator) for name in names])
    assert maps.shape[1] == SLICES["normal"].stop
    return maps.float(), names
