"""The procedural stream drawn on the training device (``PriorConfig.materials.stream = "device"``, issue 64).

The host stream (:func:`svbrdf.trainer.procedural.sample_materials` and
:func:`~svbrdf.trainer.prior.photos.simulate_photos_batched`) draws every random number from the caller's CPU
generator, material by material in Python: measured on a batch of 16 (CPU, one thread), 646-726 scalar draws and
1.7 M (whole 128 px photos) to 3.4 M (crops of 256 px photos) random table numbers drawn on the host and copied to
the device (v2's 32 materials at 512 px: about 8 times that), and about 460 torch operations (kernel launches on a
GPU) per material. That keeps the stream the same on every device, at the cost of a GPU waiting for the host.

Here the same families, class materials, augmentations and photo model are built for a whole batch at once:

* **what is drawn on the host**: one 63-bit seed per draw of materials and one per photographing, from the
  stream's generator (``rng``); from the first, with a CPU generator, each material's family and whether the batch
  is cropped (``batch + 1`` numbers: the host needs them to group the materials by family and to size the tensors).
* **everything else on the device**: a :class:`torch.Generator` on the device seeded with that seed draws every
  other number (each family's parameters, its random tables and spectra, the class colours, the shares, the field of
  view, flash offset, renderer mix, camera, crop windows and the camera noise) as tensors of one value per material.
* **vectorised over the batch**: each family is one batched function of all the batch's materials of that family
  (:data:`BATCHED_FAMILIES`): per-material parameters are (n, 1, 1) tensors, branches are both computed and chosen
  per material (``torch.where``), per-material counts index tables of their largest size. At most twelve batched
  family calls instead of one Python call per material: 6.7 k torch operations for a batch of 32 and 7.4 k for 128,
  against 14.9 k and 58.8 k for the host stream (``trainer/tools/throughput.py``'s ``ops_per_batch``). Nothing is
  read back from the device (checked on the meta device by ``tests/trainer/prior/test_device_stream.py``,
  ``test_the_device_stream_batch_and_loss_never_make_a_gpu_wait``). On a CPU it is no faster than the host stream
  (it computes both sides of every branch and Worley distances over tables of the largest size): it is built for
  a GPU.

Reproducibility: the same ``rng`` state gives the same batch **on one device** (and one torch version): a CUDA
generator and a CPU generator draw different numbers from one seed, so a run resumed on another device type continues
with another stream of the same distribution (the host stream, ``materials.stream="host"``, stays the reference that is the
same everywhere). The distributions are the host stream's: same :data:`~svbrdf.trainer.procedural.PARAMS`, same
families and shares (checked by the statistics test: family shares, per-map means, the photos' brightness and
clipped fraction).

Known differences from the host stream, none in distribution: scratches are rasterised in windows of the largest
segment's size (the host's boxes fit each segment; the masks are the same); the flash falls off with the base
configuration's camera distance as in :func:`~svbrdf.trainer.prior.photos.simulate_photos_batched`; both renderer
settings are rendered and one is chosen per photo.
"""

from __future__ import annotations

import math
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import torch

from svbrdf.trainer.camera_model import CAMERA_KEYS
from svbrdf.runtime.core.maps import SLICES
from svbrdf.runtime.core.render import physical_config
from svbrdf.trainer.camera import expose_batch, frame_radius2
from svbrdf.trainer.colour import srgb_to_linear
from svbrdf.trainer.config import resolve
from svbrdf.trainer.device import to_device
from svbrdf.trainer.models import height_to_normal, pack_maps
from svbrdf.trainer.procedural import FAMILIES, PARAMS, TWO_PI, _smoothstep, hsv_to_rgb
from svbrdf.trainer.render import plane_grid, point_light_vectors, render_maps

SEED_MAX = 2 ** 62


class Draws:
    """Per-material random numbers from one device generator: every method returns a tensor on ``device``."""

    def __init__(self, seed: int, device: torch.device):
        self.device = torch.device(device)
        self.g = torch.Generator(device=self.device).manual_seed(int(seed))

    def rand(self, *shape: int) -> torch.Tensor:
        return torch.rand(shape, generator=self.g, device=self.device)

    def randn(self, *shape: int) -> torch.Tensor:
        return torch.randn(shape, generator=self.g, device=self.device)

    def u(self, n: int, lo=0.0, hi=1.0) -> torch.Tensor:
        """(n,) uniform in [lo, hi) (lo, hi numbers or (n,) tensors)."""
        return lo + (hi - lo) * self.rand(n)

    def logu(self, n: int, lo: float, hi: float) -> torch.Tensor:
        return torch.exp(self.u(n, math.log(lo), math.log(hi)))

    def int(self, n: int, lo, hi) -> torch.Tensor:
        """(n,) float integers uniform in [lo, hi] inclusive (lo, hi numbers or (n,) tensors)."""
        return torch.floor(lo + (hi - lo + 1) * self.rand(n)).clamp(max=hi)

    def chance(self, n: int, p: float) -> torch.Tensor:
        return self.rand(n) < p

    def choice(self, n: int, options: Sequence[float]) -> torch.Tensor:
        table = to_device(torch.tensor([float(o) for o in options]), self.device)
        return table[torch.floor(self.rand(n) * len(options)).long().clamp(max=len(options) - 1)]


def _c(t: torch.Tensor) -> torch.Tensor:
    """(n,) -> (n, 1, 1) to broadcast over (n, H, W)."""
    return t[:, None, None]


def _norm01(x: torch.Tensor) -> torch.Tensor:
    flat = x.flatten(-2)
    lo, hi = flat.min(-1, keepdim=True)[0], flat.max(-1, keepdim=True)[0]
    return ((flat - lo) / (hi - lo).clamp_min(1e-12)).view_as(x)


def _xy(size: int, device) -> Tuple[torch.Tensor, torch.Tensor]:
    t = (torch.arange(size, dtype=torch.float32, device=device) + 0.5) / size - 0.5
    y, x = torch.meshgrid(-t, t, indexing="ij")
    return x, y


def _features(d: Draws, n: int, size: int, lo: Optional[float] = None, hi: Optional[float] = None) -> torch.Tensor:
    flo, fhi = PARAMS["features"]
    lo, hi = lo or flo, hi or fhi
    hi = max(min(hi, size / PARAMS["min_feature_px"]), lo)
    return d.logu(n, lo, hi) if hi > lo else torch.full((n,), float(lo), device=d.device)


def _grid(d: Draws, n: int, size: int, su: torch.Tensor, sv: torch.Tensor, angle: Optional[torch.Tensor] = None):
    if angle is None:
        angle = d.u(n, 0.0, TWO_PI)
    x, y = _xy(size, d.device)
    c, s = _c(torch.cos(angle)), _c(torch.sin(angle))
    u = (c * x + s * y) * _c(su) + _c(d.u(n, 0.0, 16.0))
    v = (-s * x + c * y) * _c(sv) + _c(d.u(n, 0.0, 16.0))
    return u, v


def _axis_angle(d: Draws, n: int, free_p: float = 0.25) -> torch.Tensor:
    free = d.chance(n, free_p)
    return torch.where(free, d.u(n, 0.0, TWO_PI), d.choice(n, (0.0, 0.5 * math.pi)) + d.u(n, -0.03, 0.03))


def _fbm(d: Draws, n: int, k: int, size: int, beta, low, aniso=1.0, angle=0.0) -> torch.Tensor:
    """(n, k, H, W) periodic fBm fields in [0, 1] (:func:`svbrdf.trainer.procedural._fbm`, per-material parameters:
    numbers or (n,) tensors)."""
    dev = d.device
    as_t = lambda x: (x if isinstance(x, torch.Tensor) else torch.full((n,), float(x), device=dev))  # noqa: E731
    beta, low, aniso, angle = (as_t(x)[:, None, None, None] for x in (beta, low, aniso, angle))
    fy = torch.fft.fftfreq(size, d=1.0 / size, device=dev)
    fx = torch.fft.rfftfreq(size, d=1.0 / size, device=dev)
    fy, fx = torch.meshgrid(fy, fx, indexing="ij")
    c, s = torch.cos(angle), torch.sin(angle)
    along, across = fx * c + fy * s, -fx * s + fy * c
    amp = ((along * aniso) ** 2 + across ** 2 + low * low) ** (-0.5 * beta)
    amp = amp * (fx.abs() + fy.abs() > 0).float()  # no DC term
    shape = (n, k) + tuple(fx.shape)
    spec = torch.complex(d.randn(*shape), d.randn(*shape)) * amp
    return _norm01(torch.fft.irfft2(spec, s=(size, size)))


def _worley(d: Draws, u: torch.Tensor, v: torch.Tensor, cells: torch.Tensor, cmax: int, jitter):
    """Batched :func:`svbrdf.trainer.procedural._worley`: ``cells`` (n,) float integers <= ``cmax``."""
    n = u.shape[0]
    jit = jitter if isinstance(jitter, torch.Tensor) else torch.full((n,), float(jitter), device=d.device)
    pts = 0.5 + jit[:, None, None] * (d.rand(n, 2, cmax * cmax) - 0.5)
    iu, iv = torch.floor(u), torch.floor(v)
    fu, fv = (u - iu)[:, None], (v - iv)[:, None]
    c = cells.long()[:, None, None, None]
    r = torch.arange(-1, 2, device=d.device)
    du, dv = [t.reshape(1, 9, 1, 1) for t in torch.meshgrid(r, r, indexing="ij")]
    idx = torch.remainder(iu.long()[:, None] + du, c) * c + torch.remainder(iv.long()[:, None] + dv, c)  # (n,9,H,W)
    flat = idx.flatten(1)
    px = pts[:, 0].gather(1, flat).view_as(idx)
    py = pts[:, 1].gather(1, flat).view_as(idx)
    dist = torch.hypot(px + du - fu, py + dv - fv)
    near, order = torch.topk(dist, 2, dim=1, largest=False)
    return near[:, 0], near[:, 1], idx.gather(1, order[:, :1])[:, 0]


def _table(d: Draws, n: int, size: int, index: torch.Tensor) -> torch.Tensor:
    """(n, H, W) values of a per-material uniform table of ``size`` entries at ``index`` (n, H, W) long."""
    return d.rand(n, size).gather(1, index.flatten(1)).view_as(index).float()


def _soft(d: Draws, n: int, size: int) -> torch.Tensor:
    return d.u(n, *PARAMS["soft_px"]) / size


class Pattern:
    """A batched family's draw: ``weights`` (n, 3, H, W) (an unused class all 0), ``height`` (n, H, W), ``metal``
    (n, 3) bool, ``cell`` (n, H, W) or None, ``detail`` (n, H, W) or None, ``related`` [(dst, src, (n,) bool)],
    ``hue`` (lo, hi) or None and ``hue_p``."""

    def __init__(self, weights, height, metal, cell=None, detail=None, related=(), hue=None, hue_p=0.0):
        self.weights, self.height, self.metal, self.cell, self.detail = weights, height, metal, cell, detail
        self.related, self.hue, self.hue_p = list(related), hue, hue_p


def _metal(n: int, device, *flags) -> torch.Tensor:
    cols = [f if isinstance(f, torch.Tensor) else torch.full((n,), bool(f), device=device) for f in flags]
    return torch.stack(cols, 1)


def _w(*classes) -> torch.Tensor:
    return torch.stack(classes, 1)


def _where(cond: torch.Tensor, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return torch.where(cond.view(-1, *([1] * (a.dim() - 1))), a, b)


def _fam_noise(d: Draws, n: int, size: int) -> Pattern:
    feat = _features(d, n, size)
    f = _fbm(d, n, 3, size, d.u(n, *PARAMS["fbm_beta"]), feat)
    level, soft = _c(d.u(n, 0.3, 0.7)), _c(d.u(n, 0.01, 0.15))
    a = _smoothstep(level - soft, level + soft, f[:, 1])
    third = d.chance(n, 0.5)
    lvl = _c(d.u(n, 0.7, 0.85))
    b = _smoothstep(lvl, lvl + 0.02, f[:, 2]) * _c(third.float())
    w = _w((1 - a) * (1 - b), a * (1 - b), b)
    return Pattern(w, f[:, 0] + _c(d.u(n, 0.0, 0.3)) * a, _metal(n, d.device, False, False, False))


def _fam_cells(d: Draws, n: int, size: int) -> Pattern:
    c = torch.clamp(torch.round(_features(d, n, size, 2.5, 30.0)), min=2)
    cmax = max(2, round(min(30.0, size / PARAMS["min_feature_px"])))
    u, v = _grid(d, n, size, c, c)
    f1, f2, cid = _worley(d, u, v, c, cmax, d.u(n, 0.5, 1.0))
    border = _c(d.u(n, 0.02, 0.15))
    inside = _smoothstep(border, border + _c(_soft(d, n, size) * c), f2 - f1)
    rnd = _table(d, n, cmax * cmax, cid)
    sel = (rnd < _c(d.u(n, 0.0, 0.6))).float()
    w = _w(inside * (1 - sel), inside * sel, 1 - inside)
    height = inside * (1 + _c(d.u(n)) * (f2 - f1).clamp(max=0.5) + 0.3 * rnd)
    return Pattern(w, height, _metal(n, d.device, False, False, False), cell=inside * (2 * rnd - 1))


def _fam_tiles(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    nx = torch.clamp(d.int(n, *P["tiles_count"]), max=int(size // 8))
    aspect = d.choice(n, P["tiles_aspect"])
    ny = torch.clamp(torch.round(nx * aspect * d.u(n, 0.8, 1.25)), min=1)
    u, v = _grid(d, n, size, nx, ny, _axis_angle(d, n, 0.15))
    row = torch.floor(v)
    bond = d.chance(n, P["tiles_bond_p"])
    shift = d.choice(n, (0.5, 0.5, 1 / 3))
    period = torch.where(aspect > 1, 2.0, 3.0)
    u = u + _c(bond.float() * shift) * torch.remainder(row, _c(period))
    col = torch.floor(u)
    fu, fv = u - col, v - row
    dist = torch.minimum(torch.minimum(fu, 1 - fu) / _c(nx), torch.minimum(fv, 1 - fv) / _c(ny))
    grout = _c(torch.clamp(d.u(n, *P["tiles_grout"]), min=0.7 / size))
    bevel = _c(d.u(n, *P["tiles_bevel"]))
    tile = _smoothstep(grout, grout + _c(_soft(d, n, size)), dist)
    bev = _smoothstep(grout, grout + bevel, dist)
    tid = (torch.remainder(col, 64) * 64 + torch.remainder(row, 64)).long()
    rnd = _table(d, n, 64 * 64, tid)
    second, checker = d.chance(n, P["tiles_second_p"]), d.chance(n, 0.4)
    sel = torch.where(_c(checker), torch.remainder(col + row, 2), (rnd < _c(d.u(n, 0.2, 0.5))).float())
    three = _w(tile * (1 - sel), tile * sel, 1 - tile)
    two = _w(tile, 1 - tile, torch.zeros_like(tile))
    grain = _fbm(d, n, 1, size, 1.2, _features(d, n, size, 8.0, 80.0))[:, 0]
    height = bev * (1.0 + 0.15 * rnd) + 0.05 * grain
    return Pattern(_where(second, three, two), height, _metal(n, d.device, False, False, False),
                   cell=tile * (2 * rnd - 1))


def _fam_wood(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    planks = d.int(n, *P["wood_planks"])
    length = d.u(n, *P["wood_plank_length"])
    angle = _axis_angle(d, n, 0.1)
    u, v = _grid(d, n, size, 1.0 / length, planks, angle)
    row = torch.floor(v)
    ri = torch.remainder(row, 64).long()
    u = u + _table(d, n, 64, ri) * 7.0
    col = torch.floor(u)
    fu, fv = u - col, v - row
    prnd = _table(d, n, 64 * 64, (torch.remainder(col, 64) * 64).long() + ri)
    warp = _fbm(d, n, 1, size, 1.3, 3.0, aniso=d.u(n, 6.0, 20.0), angle=-angle)[:, 0]
    pith = (prnd - 0.5) * 4.0
    arc = _c(d.u(n, 0.0, 0.4))
    r = torch.sqrt((fv - 0.5 - pith) ** 2 + (arc * (fu - 0.5 + prnd)) ** 2)
    ring = torch.remainder(r * _c(d.u(n, *P["wood_rings"])) + _c(d.u(n, 0.5, 3.0)) * warp, 1.0)
    sharp = _c(d.u(n, 0.55, 0.9))
    late = _smoothstep(sharp, sharp + 0.08, ring) * (1 - _smoothstep(0.97, 1.0, ring))
    du = torch.minimum(fu, 1 - fu) * _c(length) * size
    dv = torch.minimum(fv, 1 - fv) * size / _c(planks)
    seam = _c(d.u(n, 0.4, 1.5))
    board = _smoothstep(seam, seam + 1.0, torch.minimum(du, dv))
    w = _w(board * (1 - late), board * late, 1 - board)
    fibre = _fbm(d, n, 1, size, 1.0, 30.0, aniso=12.0, angle=-angle)[:, 0]
    height = board * (1.0 + 0.08 * late + 0.05 * fibre + 0.1 * prnd)
    yes = torch.ones(n, dtype=torch.bool, device=d.device)
    return Pattern(w, height, _metal(n, d.device, False, False, False), cell=board * (2 * prnd - 1), detail=fibre,
                   related=[(1, 0, yes), (2, 0, yes)], hue=P["wood_hue"], hue_p=P["wood_hue_p"])


def _thread(f: torch.Tensor, width: torch.Tensor) -> torch.Tensor:
    x = (f - 0.5) / (0.5 * width)
    return torch.sqrt((1 - x * x).clamp_min(0.0))


def _fam_weave(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    k = torch.clamp(d.int(n, *P["weave_threads"]), max=size // 5)
    angle = _axis_angle(d, n, 0.3)
    u, v = _grid(d, n, size, k, k * d.u(n, 0.8, 1.25), angle)
    i, j = torch.floor(u), torch.floor(v)
    fu, fv = u - i, v - j
    wd = _c(d.u(n, *P["weave_width"]))
    pw, pf = _thread(fu, wd), _thread(fv, wd)
    twill = _c(d.chance(n, P["weave_twill_p"]))
    warp_top = torch.where(twill, torch.remainder(i + j, 3) != 0, torch.remainder(i + j, 2) == 0)
    hw_top = pw * (0.6 + 0.4 * torch.sin(math.pi * fv))
    hf_top = pf * (0.6 + 0.4 * torch.sin(math.pi * fu))
    h_warp = torch.where(warp_top, hw_top, 0.5 * pw)
    h_weft = torch.where(warp_top, 0.5 * pf, hf_top)
    warp = (h_warp >= h_weft) & (pw > 0)
    weft = ~warp & (pf > 0)
    height = torch.maximum(h_warp, h_weft)
    gap = 1 - _smoothstep(0.0, 0.25, height)
    wa, wb = warp.float() * (1 - gap), weft.float() * (1 - gap)
    fib = _fbm(d, n, 2, size, 1.0, 2.0 * k, aniso=8.0, angle=-angle)
    fib2 = _fbm(d, n, 1, size, 1.0, 2.0 * k, aniso=8.0, angle=-angle + 0.5 * math.pi)[:, 0]
    detail = wa * fib2 + wb * fib[:, 0] + gap * 0.5
    yes = torch.ones(n, dtype=torch.bool, device=d.device)
    return Pattern(_w(wa, wb, gap), height + 0.08 * detail, _metal(n, d.device, False, False, False), detail=detail,
                   related=[(2, 0, yes)])


def _fam_knit(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    k = torch.clamp(d.int(n, *P["knit_columns"]), max=size // 8)
    angle = _axis_angle(d, n, 0.15)
    u, v = _grid(d, n, size, k, k * d.u(n, 1.1, 1.6), angle)
    i, j = torch.floor(u), torch.floor(v)
    fu = u - i
    tilt = d.u(n, 0.3, 0.5)
    a, b = _c(d.u(n, 0.14, 0.19)), _c(d.u(n, 0.42, 0.52))
    height = torch.zeros_like(u)
    for dj in (-1.0, 0.0, 1.0):
        fv = v - (j + dj)
        for cx, sgn in ((0.3, 1.0), (0.7, -1.0)):
            x, y = fu - cx, fv - 0.5
            c, s = _c(torch.cos(sgn * tilt)), _c(torch.sin(sgn * tilt))
            xr, yr = c * x - s * y, s * x + c * y
            e = (xr / a) ** 2 + (yr / b) ** 2
            height = torch.maximum(height, torch.sqrt((1 - e).clamp_min(0.0)))
    gap = 1 - _smoothstep(0.0, 0.3, height)
    yarn = 1 - gap
    fib = _fbm(d, n, 1, size, 1.0, 3.0 * k, aniso=4.0, angle=-angle + 0.5 * math.pi)[:, 0]
    stripes = d.chance(n, P["knit_stripes_p"])
    period = d.int(n, 2, 8)
    sel = (torch.remainder(j, _c(period)) < _c(d.int(n, 1, period - 1))).float()
    w = _where(stripes, _w(yarn * (1 - sel), yarn * sel, gap), _w(yarn, gap, torch.zeros_like(gap)))
    return Pattern(w, height + 0.1 * fib, _metal(n, d.device, False, False, False), detail=fib,
                   related=[(2, 0, stripes), (1, 0, ~stripes)])


def _fam_leather(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    c = torch.clamp(d.int(n, *P["leather_cells"]), max=size // 5)
    cmax = max(1, min(P["leather_cells"][1], size // 5))
    u, v = _grid(d, n, size, c, c)
    warp = _fbm(d, n, 2, size, 1.6, 3.0) - 0.5
    amt = _c(d.u(n, 0.1, 0.5))
    u, v = u + amt * warp[:, 0], v + amt * warp[:, 1]
    f1, f2, _ = _worley(d, u, v, c, cmax, 1.0)
    edge = f2 - f1
    top = _smoothstep(0.0, _c(d.u(n, *P["leather_crease"])), edge)
    rounded = torch.sqrt(_smoothstep(0.0, _c(d.u(n, 0.2, 0.5)), edge))
    patches = _fbm(d, n, 1, size, 1.5, 2.0)[:, 0]
    lvl = _c(d.u(n, 0.65, 0.95))
    worn = _smoothstep(lvl - 0.05, lvl + 0.05, patches)
    yes = torch.ones(n, dtype=torch.bool, device=d.device)
    return Pattern(_w(top * (1 - worn), 1 - top, top * worn), rounded, _metal(n, d.device, False, False, False),
                   related=[(1, 0, yes)], hue=P["leather_hue"], hue_p=P["leather_hue_p"])


def _fam_plaster(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    bumps = _fbm(d, n, 1, size, d.u(n, 1.2, 1.8), _features(d, n, size, 2.5, 20.0))[:, 0]
    flakes = _fbm(d, n, 2, size, d.u(n, 1.0, 1.6), _features(d, n, size, 3.0, 20.0))
    level = _c(1 - d.u(n, *P["plaster_paint_cover"]))
    paint = _smoothstep(level, level + 0.6 * _c(_soft(d, n, size)) * size / 64, flakes[:, 0])
    stains = d.chance(n, 0.4)
    lvl = _c(d.u(n, 0.65, 0.85))
    stain = _smoothstep(lvl, lvl + 0.1, flakes[:, 1]) * paint * _c(stains.float())
    w = _w(paint - stain, 1 - paint, stain)
    grain = _fbm(d, n, 1, size, 0.9, _features(d, n, size, 20.0, 100.0))[:, 0]
    height = bumps + _c(d.u(n, 0.1, 0.5)) * paint + 0.1 * grain * (1 - paint)
    return Pattern(w, height, _metal(n, d.device, False, False, False))


#: Segments rasterised at once per material by :func:`_segments` (bounds the memory: n x this x window^2 floats).
SEGMENT_CHUNK = 16


def _segments(d: Draws, n: int, size: int, count: torch.Tensor, angle: torch.Tensor, spread: torch.Tensor,
              length: Tuple[float, float], width_px: Tuple[float, float], most: int) -> torch.Tensor:
    """Batched :func:`svbrdf.trainer.procedural._segments`: (n, H, W), ``count`` (n,) segments of at most ``most``
    per material. Each segment is rasterised in a square window around its centre as large as the longest and
    widest segment's box (about a quarter of the image), and the image keeps the largest value per pixel: the same
    mask as the host's boxes (a window's pixels farther than its width from the segment are 0)."""
    r = d.rand(n, most, 5)
    th = angle[:, None] + spread[:, None] * d.randn(n, most)
    active = torch.arange(most, device=d.device)[None] < count[:, None]
    cx, cy = r[..., 0] * size, r[..., 1] * size
    half = 0.5 * size * (length[0] + (length[1] - length[0]) * r[..., 2])
    w = width_px[0] + (width_px[1] - width_px[0]) * r[..., 3]
    depth = (0.4 + 0.6 * r[..., 4]) * active.float()
    dx, dy = torch.cos(th) * half, torch.sin(th) * half
    span = 4 * half * half + 1e-9
    reach = math.ceil(0.5 * size * length[1] + width_px[1] + 2)
    offsets = torch.arange(-reach, reach + 1, device=d.device)
    out = torch.zeros(n, size * size, device=d.device)
    for s in range(0, most, SEGMENT_CHUNK):
        e = slice(s, s + SEGMENT_CHUNK)
        q = lambda t: t[:, e, None, None]  # noqa: E731
        rows = torch.floor(q(cy)).long() + offsets[:, None]  # (n, k, S, 1)
        cols = torch.floor(q(cx)).long() + offsets[None, :]  # (n, k, 1, S)
        ys = rows.float() + 0.5 - q(cy - dy)
        xs = cols.float() + 0.5 - q(cx - dx)
        t = ((xs * 2 * q(dx) + ys * 2 * q(dy)) / q(span)).clamp(0.0, 1.0)
        dist = torch.hypot(xs - t * 2 * q(dx), ys - t * 2 * q(dy))
        m = (1.0 - dist / q(w)).clamp(0.0, 1.0) * q(depth)
        inside = (rows >= 0) & (rows < size) & (cols >= 0) & (cols < size)
        index = torch.where(inside, rows * size + cols, 0).flatten(1)
        out.scatter_reduce_(1, index, torch.where(inside, m, 0.0).flatten(1), reduce="amax")
    return out.view(n, size, size)


def _fam_scratches(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    metal = d.chance(n, P["scratches_metal_p"])
    angle = d.u(n, 0.0, math.pi)
    count = d.int(n, *P["scratches_count"])
    lines = _segments(d, n, size, count, angle, d.u(n, *P["scratches_spread_rad"]), P["scratches_length"],
                      P["scratches_width_px"], int(P["scratches_count"][1]))
    nd = d.int(n, *P["scratches_dents"])
    most = int(P["scratches_dents"][1])
    x, y = _xy(size, d.device)
    prm = d.rand(n, most, 3)
    rr = (0.01 + 0.05 * prm[..., 2])[..., None, None]
    on = (torch.arange(most, device=d.device)[None] < nd[:, None]).float()[..., None, None]
    dents = (torch.exp(-((x - prm[..., 0, None, None] + 0.5) ** 2 + (y - prm[..., 1, None, None] + 0.5) ** 2)
                       / (rr * rr)) * on).amax(1)
    base = _fbm(d, n, 1, size, d.u(n, *P["fbm_beta"]), _features(d, n, size))[:, 0]
    height = _c(d.u(n, 0.02, 0.2)) * base - lines - 0.7 * dents
    scr = lines.clamp(0.0, 1.0)
    worn = d.chance(n, 0.4)
    lvl = _c(d.u(n, 0.6, 0.85))
    wear = _smoothstep(lvl - 0.05, lvl + 0.05, _fbm(d, n, 1, size, 1.4, 2.0)[:, 0]) * (1 - scr) * _c(worn.float())
    return Pattern(_w(1 - scr - wear, scr, wear), height, _metal(n, d.device, metal, metal, False))


def _fam_brushed_metal(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    angle = _axis_angle(d, n, 0.5)
    brush = _fbm(d, n, 1, size, d.u(n, 0.7, 1.2), _features(d, n, size, 20.0, 120.0),
                 aniso=d.u(n, *P["brushed_aniso"]), angle=angle)[:, 0]
    patches = _fbm(d, n, 1, size, 1.5, d.u(n, 1.0, 4.0))[:, 0]
    lvl = _c(d.u(n, 0.55, 0.85))
    second = _smoothstep(lvl - 0.05, lvl + 0.05, patches)
    return Pattern(_w(1 - second, second, torch.zeros_like(second)), brush * (1 - 0.7 * second),
                   _metal(n, d.device, True, d.chance(n, 0.5), False), detail=brush)


def _fam_flat_metal(d: Draws, n: int, size: int) -> Pattern:
    hammered = d.chance(n, PARAMS["flat_metal_hammered_p"])
    c = torch.clamp(torch.round(_features(d, n, size, 4.0, 30.0)), min=2)
    cmax = max(2, round(min(30.0, size / PARAMS["min_feature_px"])))
    u, v = _grid(d, n, size, c, c)
    f1, _, _ = _worley(d, u, v, c, cmax, 1.0)
    height = torch.where(_c(hammered), f1 ** 2, _fbm(d, n, 1, size, 1.8, 2.0)[:, 0])
    f = _fbm(d, n, 2, size, d.u(n, 1.0, 1.6), _features(d, n, size, 2.5, 12.0))
    lvl = _c(d.u(n, 0.55, 0.8))
    patina = _smoothstep(lvl - 0.04, lvl + 0.04, f[:, 0])
    lvl2 = _c(d.u(n, 0.5, 0.8))
    smudge = _smoothstep(lvl2 - 0.1, lvl2 + 0.1, f[:, 1]) * (1 - patina)
    return Pattern(_w(1 - patina - smudge, patina, smudge), height + 0.3 * patina,
                   _metal(n, d.device, True, False, True))


def _fam_stone(d: Draws, n: int, size: int) -> Pattern:
    P = PARAMS
    f = _fbm(d, n, 2, size, d.u(n, 0.9, 1.3), _features(d, n, size, 2.5, 12.0))
    smooth = _fbm(d, n, 2, size, d.u(n, 1.8, 2.3), d.u(n, 1.0, 4.0))
    warped = _norm01(smooth[:, 0] + _c(d.u(n, 0.2, 0.8)) * (smooth[:, 1] - 0.5) + 0.04 * (f[:, 1] - 0.5))
    vw = _c(d.u(n, *P["stone_vein_width"]))
    vein = 1 - _smoothstep(vw, vw * 2.0, (warped - 0.5).abs())
    grainy = d.chance(n, P["stone_grain_p"])
    c = torch.clamp(d.int(n, 20, 80), max=size // 4)
    cmax = max(1, min(80, size // 4))
    u, v = _grid(d, n, size, c, c)
    f1, f2, cid = _worley(d, u, v, c, cmax, 1.0)
    sel = (_table(d, n, cmax * cmax, cid) < _c(d.u(n, 0.1, 0.4))).float()
    grain = sel * _smoothstep(0.02, 0.08, f2 - f1) * (1 - vein) * _c(grainy.float())
    w = _w((1 - vein) * (1 - grain), vein, grain)
    height = f[:, 0] + f[:, 1] * 0.3 - _c(d.u(n, 0.0, 0.3)) * vein
    return Pattern(w, height, _metal(n, d.device, False, False, False))


#: The batched families, in :data:`svbrdf.trainer.procedural.FAMILIES` order.
BATCHED_FAMILIES: Dict[str, Callable[[Draws, int, int], Pattern]] = {
    "noise": _fam_noise, "cells": _fam_cells, "tiles": _fam_tiles, "wood": _fam_wood, "weave": _fam_weave,
    "knit": _fam_knit, "leather": _fam_leather, "plaster": _fam_plaster, "scratches": _fam_scratches,
    "brushed_metal": _fam_brushed_metal, "flat_metal": _fam_flat_metal, "stone": _fam_stone,
}
assert tuple(BATCHED_FAMILIES) == FAMILIES


def _class_materials(d: Draws, pat: Pattern, neutral: torch.Tensor):
    """Batched :func:`svbrdf.trainer.procedural._class_materials`: (n, 3, 3) linear diffuse, (n, 3) specular and
    roughness."""
    P = PARAMS
    n, k = pat.metal.shape
    metal = pat.metal | (d.rand(n, k) < P["random_metal_class_p"])
    use_hue = (d.rand(n) < pat.hue_p) if pat.hue is not None else torch.zeros(n, dtype=torch.bool, device=d.device)
    grey = neutral[:, None] | (d.rand(n, k) < P["neutral_class_p"])
    hue = torch.where(use_hue[:, None], pat.hue[0] + (pat.hue[1] - pat.hue[0]) * d.rand(n, k) if pat.hue else 0.0,
                      d.rand(n, k))
    sat = torch.where(grey, 0.0, P["saturation"][0] + (P["saturation"][1] - P["saturation"][0]) * d.rand(n, k))
    mv, dv = P["metal_value_srgb"], P["value_srgb"]
    val = torch.where(metal, mv[0] + (mv[1] - mv[0]) * d.rand(n, k), dv[0] + (dv[1] - dv[0]) * d.rand(n, k))
    hsv = torch.stack([TWO_PI * hue, sat, val], 1)  # (n, 3 hsv, k)
    rgb = srgb_to_linear(hsv_to_rgb(hsv[..., None]))[..., 0].transpose(1, 2)  # (n, k, 3)
    for dst, src, active in pat.related:
        on = active & ~metal[:, dst] & ~metal[:, src] & (d.rand(n) < P["related_p"])
        factor = d.u(n, *P["related_factor"])
        rgb = torch.cat([rgb[:, :dst], torch.where(on[:, None], rgb[:, src] * factor[:, None], rgb[:, dst])[:, None],
                         rgb[:, dst + 1:]], 1)
    sm, tail, die = P["spec_metal"], P["spec_dielectric_tail"], P["spec_dielectric"]
    spec = torch.where(metal, sm[0] + (sm[1] - sm[0]) * d.rand(n, k),
                       torch.where(d.rand(n, k) < P["spec_dielectric_tail_p"],
                                   tail[0] + (tail[1] - tail[0]) * d.rand(n, k),
                                   torch.exp(math.log(die[0]) + math.log(die[1] / die[0]) * d.rand(n, k))))
    rough = P["roughness"][0] + (P["roughness"][1] - P["roughness"][0]) * d.rand(n, k)
    return rgb.clamp(0.0, 1.0), spec, rough


def normal_scale_batched(h: torch.Tensor, angle_deg: torch.Tensor) -> torch.Tensor:
    """:func:`svbrdf.trainer.procedural.normal_scale` per material: ``h`` (n, 1, H, W), ``angle_deg`` (n,) ->
    (n, 1, 1, 1) slope factors (0 for a flat height)."""
    grad = torch.hypot(h[..., 1:, :-1] - h[..., :-1, :-1], h[..., :-1, 1:] - h[..., :-1, :-1]).flatten(1)
    mean = grad.mean(1).double()
    flat = mean < 1e-9
    mean = torch.where(flat, torch.ones_like(mean), mean)
    target = torch.deg2rad(angle_deg.double())
    s = torch.tan(target) / mean
    cap = 4.0 * torch.tan(target) / mean
    for _ in range(3):
        got = torch.atan(s[:, None] * grad).mean(1).double()
        s = torch.minimum(s * target / got.clamp_min(1e-9), cap)
    return torch.where(flat, torch.zeros_like(s), s).float()[:, None, None, None]


def _maps_of(d: Draws, family: str, n: int, size: int) -> torch.Tensor:
    """(n, 8, size, size) packed maps of ``n`` materials of ``family`` (:func:`svbrdf.trainer.procedural._material`,
    batched)."""
    P = PARAMS
    pat = BATCHED_FAMILIES[family](d, n, size)
    w = pat.weights.clamp_min(0.0)
    w = w / w.sum(1, keepdim=True).clamp_min(1e-6)
    neutral = d.chance(n, P["neutral_material_p"])
    rgb, spec, rough = _class_materials(d, pat, neutral)
    detail = pat.detail if pat.detail is not None else \
        _fbm(d, n, 1, size, d.u(n, *P["detail_beta"]), _features(d, n, size, 4.0, 64.0))[:, 0]
    dd = 2.0 * detail - 1.0
    bright = 1.0 + _c(d.u(n, *P["detail_diffuse"])) * dd
    if pat.cell is not None:
        bright = bright + _c(d.u(n, *P["cell_jitter"])) * pat.cell
    diffuse = torch.einsum("nkhw,nkc->nchw", w, rgb) * bright.clamp_min(0.0)[:, None]
    specular = (torch.einsum("nkhw,nk->nhw", w, spec) * (1.0 + _c(d.u(n, *P["detail_specular"])) * dd))[:, None]
    roughness = (torch.einsum("nkhw,nk->nhw", w, rough) + _c(d.u(n, *P["detail_roughness"])) * dd)[:, None]
    height = _norm01(pat.height)[:, None]
    scale = normal_scale_batched(height, d.logu(n, *P["normal_angle_deg"]))
    normal = height_to_normal(height, scale)
    return pack_maps({"diffuse": diffuse.clamp(0.0, 1.0), "specular": specular.clamp(0.0, 1.0),
                      "roughness": roughness.clamp(0.0, 1.0), "normal": normal})


def sample_materials_device(n: int, size: int, seed: int, families: Optional[Sequence[str]] = None,
                            device: Union[str, torch.device] = "cpu") -> Tuple[torch.Tensor, List[str]]:
    """``n`` procedural materials built on ``device`` from ``seed``: what
    :func:`svbrdf.trainer.procedural.sample_materials` returns ((n, 8, size, size) maps, family names), of the same
    distribution; each material's family from a CPU generator seeded with ``seed``, everything else from a
    :class:`Draws` on ``device`` seeded with it. Reproducible on one device."""
    fams = tuple(FAMILIES if families is None else families)
    host = torch.Generator().manual_seed(int(seed))
    picks = torch.randint(0, len(fams), (int(n),), generator=host).tolist()
    names = [fams[i] for i in picks]
    d = Draws(seed, device)
    out = torch.empty(n, 8, size, size, device=d.device)
    with torch.no_grad():
        for fam in fams:
            idx = [i for i, name in enumerate(names) if name == fam]
            if idx:
                out[to_device(torch.tensor(idx), d.device)] = _maps_of(d, fam, len(idx), size)
    return out, names


def coarse_height_batched(d: Draws, n: int, size: int) -> Tuple[torch.Tensor, torch.Tensor]:
    """Batched :func:`svbrdf.trainer.procedural.coarse_height`: ((n, H, W) heights, (n,) tilts in degrees)."""
    P = PARAMS
    k = torch.ceil(d.logu(n, *P["coarse_features"]))
    tilt = d.logu(n, *P["coarse_tilt_deg"])
    stones = d.chance(n, P["coarse_stones_p"])
    ks = torch.clamp(k, min=2)
    kmax = math.ceil(P["coarse_features"][1])
    u, v = _grid(d, n, size, ks, ks)
    f1, f2, cid = _worley(d, u, v, ks, kmax, 1.0)
    level = 0.3 + 0.7 * _table(d, n, kmax * kmax, cid)
    dome = _table(d, n, kmax * kmax, cid)
    r = (2.0 * f1 / (f1 + f2).clamp_min(1e-6)) ** 2
    walls = _smoothstep(0.0, _c(d.u(n, *P["coarse_groove"])), f2 - f1)
    stone_h = walls * (level + dome * (1.0 - r))
    # the warp: a (k + 1) x (k + 1) normal grid bicubically interpolated; per-material k by sampling the largest grid
    grid = d.randn(n, 1, kmax + 1, kmax + 1)
    t = torch.linspace(0.0, 1.0, size, device=d.device)
    gy = (t[None, :] * k[:, None]) / kmax * 2 - 1  # align_corners: node j of a k-grid at j / k of the image
    gy = gy[:, :, None].expand(n, size, size)
    gx = (t[None, :] * k[:, None]) / kmax * 2 - 1
    gx = gx[:, None, :].expand(n, size, size)
    warp = torch.nn.functional.grid_sample(grid, torch.stack([gx, gy], -1), mode="bicubic", align_corners=True)[:, 0]
    return torch.where(_c(stones), stone_h, warp), tilt


def add_coarse_relief_device(maps: torch.Tensor, chosen: torch.Tensor, d: Draws) -> torch.Tensor:
    """:func:`~svbrdf.trainer.prior.photos.add_coarse_relief` with the choice ``chosen`` (B,) bool on the device
    and the reliefs from ``d`` (drawn for every material, used for the chosen)."""
    sl = SLICES["normal"]
    b, side = maps.shape[0], maps.shape[-1]
    height, tilt = coarse_height_batched(d, b, side)
    height = height[:, None]
    c = height_to_normal(height, normal_scale_batched(height, tilt))
    n = maps[:, sl]
    z = n[:, 2:].clamp_min(1e-3)
    m = torch.cat([n[:, :2] / z + c[:, :2] / c[:, 2:], torch.ones_like(z)], 1)
    relief = m / m.norm(dim=1, keepdim=True)
    return torch.cat([maps[:, :sl.start], _where(chosen, relief, n), maps[:, sl.stop:]], 1)


def draw_materials_device(config, rng: torch.Generator, batch: Optional[int] = None,
                          device: Optional[Union[str, torch.device]] = None) -> Tuple[torch.Tensor, List[str], bool]:
    """:func:`~svbrdf.trainer.prior.photos.draw_materials` of the device stream: one seed from ``rng``, then the
    batch's crop choice, its block-mean choice (``photos.block_share``; the maps are then ``photos.block_mean``
    times the side) and families on the host (:func:`sample_materials_device`) and the shares (coarse relief, flat,
    near-black, prints) on the device."""
    from svbrdf.trainer.prior.photos import BLACK_LEVEL, blacken_dielectrics

    n = config.optim.batch if batch is None else batch
    dev = torch.device(device if device is not None else "cpu")
    seed = int(torch.randint(0, SEED_MAX, (), generator=rng))
    host = torch.Generator().manual_seed(seed + 1)
    ph = config.photos
    crop = bool(torch.rand((), generator=host) < ph.crop_share)
    block = ph.block_mean if ph.block_mean > 1 and bool(torch.rand((), generator=host) < ph.block_share) else 1
    side = (ph.photo_size if crop else ph.size) * block
    maps, families = sample_materials_device(n, side, seed, config.materials.families, dev)
    d = Draws(seed + 2, dev)
    with torch.no_grad():
        if config.materials.coarse_share > 0:
            maps = add_coarse_relief_device(maps, d.chance(n, config.materials.coarse_share), d)
        if config.materials.flat_share > 0:
            sl = SLICES["normal"]
            up = torch.tensor([0.0, 0.0, 1.0], device=dev)[None, :, None, None].expand_as(maps[:, sl])
            maps = torch.cat([maps[:, :sl.start], _where(d.chance(n, config.materials.flat_share), up, maps[:, sl]),
                              maps[:, sl.stop:]], 1)
        if config.materials.black_share > 0:
            chosen = d.chance(n, config.materials.black_share)
            level = d.logu(n, *BLACK_LEVEL)
            maps = blacken_dielectrics(maps, chosen, level, check=False)
        if config.materials.print_share > 0:
            maps = add_prints(maps, d.chance(n, config.materials.print_share), d)
    return maps, families, crop


def add_prints(maps: torch.Tensor, chosen: torch.Tensor, d: Draws) -> torch.Tensor:
    """``maps`` (B, 8, H, W) with a print or inlay on the ``chosen`` materials ((B,) bool on the device).

    The print's mask is a soft threshold of a smooth fBm (blobs: ink, lacquer, varnish patches; with probability
    0.5 instead bands along a random direction: stripes, inlaid strips), covering 10-50 % of the material. Inside
    it the base colour is a colour of the class draw's ranges (:data:`~svbrdf.trainer.procedural.PARAMS`:
    ``value_srgb``, ``saturation``; grey with ``neutral_class_p``), the specular a dielectric's (log-uniform in
    ``spec_dielectric``, or the ``spec_dielectric_tail`` with its probability: a glossy lacquer) and the roughness
    uniform in ``roughness``, modulated by the material's own variation (its values over their mean); the normals
    are kept. Everything drawn from ``d`` for every material (used for the chosen)."""
    P = PARAMS
    b, _, h, w = maps.shape
    dev = maps.device
    blobs = _fbm(d, b, 1, h, d.u(b, 1.4, 2.2), d.u(b, 1.5, 6.0))[:, 0]
    x, y = _xy(h, dev)
    ang = d.u(b, 0.0, TWO_PI)
    period = d.u(b, 2.0, 10.0)
    along = _c(torch.cos(ang)) * x + _c(torch.sin(ang)) * y
    bands = 0.5 + 0.5 * torch.cos(TWO_PI * (along * _c(period) + _c(d.u(b))))
    field = _where(d.chance(b, 0.5), bands, blobs)
    cover = d.u(b, 0.1, 0.5)
    flat = field.flatten(1)
    rank = ((1.0 - cover) * (flat.shape[1] - 1)).long().clamp(0, flat.shape[1] - 1)
    level = flat.sort(dim=1).values.gather(1, rank[:, None])[:, 0]  # the (1 - cover) quantile of each field
    soft = _c(d.u(b, 0.005, 0.05))
    mask = _smoothstep(_c(level) - soft, _c(level) + soft, field) * _c(chosen.float())
    grey = d.chance(b, P["neutral_class_p"])
    sat = torch.where(grey, 0.0, d.u(b, *P["saturation"]))
    hsv = torch.stack([TWO_PI * d.u(b), sat, d.u(b, *P["value_srgb"])], 1)[..., None, None]
    rgb = srgb_to_linear(hsv_to_rgb(hsv))  # (B, 3, 1, 1)
    tail = d.chance(b, P["spec_dielectric_tail_p"])
    spec = torch.where(tail, d.u(b, *P["spec_dielectric_tail"]), d.logu(b, *P["spec_dielectric"]))
    rough = d.u(b, *P["roughness"])
    dl, sp, ro = SLICES["diffuse"], SLICES["specular"], SLICES["roughness"]
    rel = lambda t: t / t.mean((2, 3), keepdim=True).clamp_min(1e-4)  # noqa: E731
    m = mask[:, None]
    diffuse = maps[:, dl] * (1 - m) + (rgb * rel(maps[:, dl].mean(1, keepdim=True))).clamp(0, 1) * m
    specular = maps[:, sp] * (1 - m) + (_c(spec)[:, None] * rel(maps[:, sp])).clamp(0, 1) * m
    roughness = maps[:, ro] * (1 - m) + _c(rough)[:, None] * m
    return torch.cat([diffuse, specular, roughness, maps[:, SLICES["normal"]]], 1)


def block_means(photos: torch.Tensor, maps: torch.Tensor, k: int) -> Tuple[torch.Tensor, torch.Tensor]:
    """Photos and maps averaged in ``k`` x ``k`` blocks (what the preview shows the network of a photo ``k`` times
    its working size); the averaged normals renormalised."""
    if k == 1:
        return photos, maps
    pool = lambda t: torch.nn.functional.avg_pool2d(t, k)  # noqa: E731
    m = pool(maps)
    sl = SLICES["normal"]
    normal = m[:, sl] / m[:, sl].norm(dim=1, keepdim=True).clamp_min(1e-6)
    return pool(photos), torch.cat([m[:, :sl.start], normal, m[:, sl.stop:]], 1)


def simulate_photos_device(maps: torch.Tensor, config, seed: int, crop: Optional[int] = None
                           ) -> Tuple[torch.Tensor, torch.Tensor, Dict[str, torch.Tensor]]:
    """:func:`~svbrdf.trainer.prior.photos.simulate_photos_batched` with every draw from a :class:`Draws` on
    ``maps``' device seeded with ``seed``. Returns ``(photos, maps, draws)``, ``draws`` = {"fov_deg", "light",
    "physical", camera keys...}: (B,) or (B, 3) tensors on the device (not read back)."""
    b, _, h, w = maps.shape
    dev = maps.device
    d = Draws(seed, dev)
    base = resolve(config.finetune_preset).render_config.replace(falloff=True)
    fov = d.u(b, *config.photos.fov_deg)
    physical = d.chance(b, config.photos.physical_share)
    dist = 1.0 / torch.tan(torch.deg2rad(fov) / 2.0)
    o = config.photos.light_offset
    light = torch.stack([d.u(b, -o, o), d.u(b, -o, o), dist], 1)
    cams = torch.stack([torch.zeros_like(dist), torch.zeros_like(dist), dist], 1)
    keys = CAMERA_KEYS if config.photos.camera["white"] != (1.0, 1.0) else CAMERA_KEYS[:-1]
    param = {k: d.u(b, *config.photos.camera[k]) for k in keys}
    pos, r2 = plane_grid(h, w, dev), None
    maps = maps.float()
    if crop is not None and crop < h:
        y0 = torch.floor(d.rand(b) * (h - crop + 1)).long().clamp(max=h - crop)
        x0 = torch.floor(d.rand(b) * (w - crop + 1)).long().clamp(max=w - crop)
        from svbrdf.trainer.prior.photos import _windows

        ar = torch.arange(crop, device=dev)
        rows, cols = y0[:, None] + ar, x0[:, None] + ar
        pos, r2, maps = (_windows(t, rows, cols) for t in (pos, frame_radius2(h, w, dev), maps))
    v, l, d2 = point_light_vectors(pos, cams, light)
    with torch.no_grad():
        plain = render_maps(maps, v, l, base, d2)
        phys = render_maps(maps, v, l, physical_config(base), d2)
        radiance = _where(physical, phys, plain)
        photos = expose_batch(radiance, generator=d.g, radius2_map=r2,
                              white=param.pop("white", None), check_white=False, **param)
    draws = {"fov_deg": fov, "light": light, "physical": physical, **param}
    return photos.contiguous(), maps.contiguous(), draws


def photograph_device(config, rng: torch.Generator, maps: torch.Tensor, families: List[str], crop: bool
                      ) -> Tuple[torch.Tensor, torch.Tensor, Dict[str, Any]]:
    """:func:`~svbrdf.trainer.prior.photos.photograph` of the device stream (one seed from ``rng``)."""
    seed = int(torch.randint(0, SEED_MAX, (), generator=rng))
    k = maps.shape[-1] // (config.photos.photo_size if crop else config.photos.size)  # photos.block_mean, or 1
    photos, maps, draws = simulate_photos_device(maps, config, seed, crop=config.photos.size * k if crop else None)
    photos, maps = block_means(photos, maps, k)
    return photos, maps, {"families": families, "crop": crop, "draws": draws}


__all__ = ["Draws", "BATCHED_FAMILIES", "add_prints", "block_means", "sample_materials_device", "draw_materials_device",
           "photograph_device",
           "simulate_photos_device", "coarse_height_batched", "add_coarse_relief_device", "normal_scale_batched",
           "SEED_MAX"]
