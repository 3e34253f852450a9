"""The preview of a photo longer than 512 px: the network on the photo in k x k pixel blocks, the maps brought back
to the photo's size with its own detail (numpy).

The stage one was trained on 256 px crops, and its maps relight real photos and ground truth better when it sees a
photo of at most :data:`NETWORK_SIZE` (512) px than at 1024 px, in half the time (decision:
docs/decisions/010-network-size-512.md). So a photo longer than :attr:`Upsampling.network_size` runs the network
and the post-processing on itself averaged over k x k pixel blocks (:func:`network_photo`, ``k = ceil(long side /
network_size)``), and :func:`guided_upsample` brings the maps to its size: each map channel ``P`` is

.. math::

    P_{full} = \\operatorname{up}(P) + \\operatorname{up}(a) \\cdot (I_{full} - \\operatorname{up}(I))

with ``I`` the photo's luminance (mean of the linear channels) at the network's size, ``I_full`` at the photo's,
``up`` the bilinear upsampling (the centres of the k x k blocks aligned: :func:`upsample_rows`) and ``a`` the local
gain of the map on the photo, ``cov(I, P) / (var(I) + eps)`` over a ``(2 r + 1)^2`` window at the network's size
(the guided filter's linear model; He et al. 2010). The low frequencies are the network's maps as they are (the plain
upsampling); the detail finer than the network's pixels is the photo's, scaled by how each map followed the photo
around that place (zero where it did not, e.g. a constant specular or a filled highlight). Normals are renormalised
and every map clipped to its range. The work is done in strips of rows, so the temporaries stay near
:attr:`Upsampling.strip_bytes`. ``Upsampling(network_size=None)`` runs the network at the photo's own size at any size
(in tiles above ``tile``): the reference path (``svbrdf-preview --network-size full``, ``svbrdf-bench --methods
preview-full``).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from ..core.maps import MAP_RANGES, Maps, normalize_normals

__all__ = ["Upsampling", "NETWORK_SIZE", "guided_upsample", "local_gain", "bilinear_rows", "upsample_rows",
           "upsample_planes", "luminance", "network_photo"]

#: Longest side (px) of the photo the network sees by default (:attr:`Upsampling.network_size`): photos up to this
#: size run the network at their own size, longer ones through :func:`guided_upsample`.
NETWORK_SIZE = 512


@dataclass(frozen=True)
class Upsampling:
    """How a photo longer than ``network_size`` gets its maps (module docstring).

    Attributes:
        network_size: the longest side (px) of the photo the network and the post-processing see (the photo in k x k
            pixel blocks, :func:`network_photo`); shorter photos run at their own size. ``None``: the photo's own
            size at any size (the network in tiles above ``tile``).
        radius: half-width of the window of the local gain, pixels at the network's size.
        eps: regulariser of the gain, a fraction of the squared mean luminance (flat areas of the photo get no
            detail: its noise is not the material's; 010-network-size-512.md).
        strip_bytes: bytes of float32 temporaries one strip of rows may take: small enough for the C allocator to
            reuse freed strips instead of mapping fresh pages (010-network-size-512.md).
        threads: strips upsampled at once (each strip's pixels are computed the same way: the result does not depend
            on it).
    """

    network_size: Optional[int] = NETWORK_SIZE
    radius: int = 2
    eps: float = 1e-4
    strip_bytes: int = 8 << 20
    threads: int = 2

    def __post_init__(self) -> None:
        if self.network_size is not None and self.network_size < 8:
            raise ValueError(f"network_size must be None or >= 8 px, got {self.network_size}")
        if self.radius < 1 or not self.eps > 0 or self.strip_bytes < 1 or self.threads < 1:
            raise ValueError(f"need radius >= 1, eps > 0, strip_bytes >= 1 and threads >= 1; got {self.radius}, "
                             f"{self.eps}, {self.strip_bytes}, {self.threads}")

    def factor(self, size: Tuple[int, int]) -> int:
        """The k of the k x k pixel blocks the network sees of a photo of ``size`` (H, W): ``ceil(long side /
        network_size)``, but no more than keeps the short side at the network's minimum (8 px); 1 (the photo as it
        is) without ``network_size``."""
        from .manifest import MIN_SIZE

        if self.network_size is None:
            return 1
        return max(1, min(-(-max(size) // self.network_size), min(size) // MIN_SIZE))

    def applies(self, size: Tuple[int, int]) -> bool:
        """Whether a photo of ``size`` (H, W) takes the guided path (:meth:`factor` > 1)."""
        return self.factor(size) > 1


def local_gain(guide: np.ndarray, maps: np.ndarray, radius: int, eps: float) -> np.ndarray:
    """The gain ``a`` of :func:`guided_upsample`: ``cov(I, P) / (var(I) + eps)`` per channel over windows of
    ``radius``, then averaged over the same windows (each pixel's mean of the gains of the windows covering it).

    Args:
        guide: (h, w) luminance ``I`` (linear).
        maps: (h, w, C) map channels ``P``.
        radius: window half-width in pixels.
        eps: absolute regulariser (luminance units squared).

    Returns:
        (h, w, C) float32.
    """
    from ..core.filters import box_mean

    # float32 window sums (filters.box_mean): the gains of a constant map are rounding noise (1e-7), not 0
    i = np.asarray(guide, np.float32)[..., None]
    p = np.asarray(maps, np.float32)
    c = p.shape[-1]
    means = box_mean(np.concatenate([i, p, i * i, i * p], axis=-1), radius, np.float32)  # every window mean at once
    mi, mp, mii, mip = means[..., :1], means[..., 1:1 + c], means[..., 1 + c:2 + c], means[..., 2 + c:]
    var = mii - mi * mi
    np.maximum(var, 0.0, out=var)
    var += np.float32(eps)
    cov = mip - mi * mp
    cov /= var
    return box_mean(cov, radius, np.float32)


def _axis(n_out: int, n_in: int) -> Tuple[np.ndarray, np.ndarray]:
    """Bilinear taps along one axis, pixel centres aligned: (n_out,) first index and (n_out,) weight of the next."""
    x = np.clip((np.arange(n_out) + 0.5) * (n_in / n_out) - 0.5, 0.0, n_in - 1)
    i0 = np.minimum(np.floor(x).astype(np.int64), max(n_in - 2, 0))
    f = (x - i0).astype(np.float32) if n_in > 1 else np.zeros(n_out, np.float32)
    return i0, f


def bilinear_rows(low: np.ndarray, rows: slice, out_shape: Tuple[int, int]) -> np.ndarray:
    """Rows ``rows`` of the bilinear upsampling of ``low`` (h, w, C) to ``out_shape`` (H, W), float32 (len, W, C):
    pixel centres aligned, edges repeated. The reference of :func:`upsample_rows` (any sizes, by gathers)."""
    h, w = low.shape[:2]
    iy, fy = _axis(out_shape[0], h)
    ix, fx = _axis(out_shape[1], w)
    iy, fy = iy[rows], fy[rows][:, None, None]
    nxt = np.minimum(iy + 1, h - 1)
    r = low[iy] * (1 - fy) + low[nxt] * fy  # (len, w, C)
    fx = fx[None, :, None]
    return r[:, ix] * (1 - fx) + r[:, np.minimum(ix + 1, w - 1)] * fx


def _factor(out_shape: Tuple[int, int], in_shape: Tuple[int, int]) -> int:
    """The integer k > 1 for which ``in_shape`` is ``out_shape`` in k x k pixel blocks, the last ones partial
    (``ceil(H / k), ceil(W / k)``), as :func:`network_photo` makes it; else 0."""
    long_axis = int(out_shape[1] > out_shape[0])
    k = -(-out_shape[long_axis] // max(in_shape[long_axis], 1))
    fits = all(-(-o // k) == i for o, i in zip(out_shape, in_shape))
    return k if k > 1 and fits else 0


def _up(x: np.ndarray, k: int, axis: int) -> np.ndarray:
    """``x`` with ``n + 2`` entries along ``axis`` (one neighbour each side) -> the ``k n`` entries of the bilinear
    upsampling of the ``n`` middle ones (pixel centres of k x k blocks aligned): entry ``k i + p`` is ``x_i + |f|
    (x_{i +- 1} - x_i)``, ``f = (p + 0.5) / k - 0.5``. Slices only, no gathers."""
    def take(start, stop, step=1):
        return tuple([slice(None)] * axis + [slice(start, stop, step)])

    n = x.shape[axis] - 2
    mid = x[take(1, n + 1)]
    shape = list(mid.shape)
    shape[axis] *= k
    out = np.empty(shape, np.float32)
    d_next = x[take(2, n + 2)] - mid
    d_prev = x[take(0, n)] - mid
    for p in range(k):
        f = (p + 0.5) / k - 0.5
        o = out[take(p, None, k)]
        np.multiply(d_next if f >= 0 else d_prev, np.float32(abs(f)), out=o)
        o += mid
    return out


def upsample_rows(low: np.ndarray, rows: slice, out_shape: Tuple[int, int]) -> np.ndarray:
    """Rows ``rows`` (a slice with a step of 1) of the bilinear upsampling of ``low`` (h, w, C) to ``out_shape`` (H,
    W), float32 (len, W, C): pixel centres aligned, edges repeated. When ``low`` holds the means of k x k pixel
    blocks of the output (``h = ceil(H / k)``, the same ``k`` across, as :func:`network_photo` makes them) the
    centres of those blocks are aligned and the rows are computed by slices (:func:`upsample_planes`); otherwise it
    is :func:`bilinear_rows`. The two agree within float32 rounding where both apply (tested)."""
    if not _factor(out_shape, low.shape[:2]):
        return bilinear_rows(low, rows, out_shape)
    planes = np.ascontiguousarray(np.moveaxis(np.asarray(low, np.float32), -1, 0))
    return np.ascontiguousarray(np.moveaxis(upsample_planes(planes, rows, out_shape), 0, -1))


def upsample_planes(planes: np.ndarray, rows: slice, out_shape: Tuple[int, int]) -> np.ndarray:
    """Rows ``rows`` of the bilinear upsampling by slices (:func:`upsample_rows`) of channel planes (C, h, w) that
    are the k x k blocks of ``out_shape`` (H, W): (C, len, W) float32, each plane contiguous."""
    c, h, w = planes.shape
    k = _factor(out_shape, (h, w))
    if not k:
        raise ValueError(f"{(h, w)} are not the k x k blocks of {tuple(out_shape)}")
    y0, y1, _ = rows.indices(out_shape[0])
    a, b = y0 // k, -(-y1 // k)  # the block rows the output rows fall in
    idx = np.clip(np.arange(a - 1, b + 1), 0, h - 1)  # with one neighbour each side (edges repeated)
    cols = np.clip(np.arange(-1, w + 1), 0, w - 1)
    wide = _up(planes[:, idx[:, None], cols], k, 2)[:, :, :out_shape[1]]  # (C, b - a + 2, W): columns at low rows
    return _up(wide, k, 1)[:, y0 - k * a:y1 - k * a]  # then whole contiguous rows


def guided_upsample(maps: Maps, guide_low: np.ndarray, guide: np.ndarray,
                    settings: Upsampling = Upsampling()) -> Maps:
    """``maps`` (h, w) at the size of ``guide`` (H, W), with the photo's detail (module docstring).

    Args:
        maps: the texture set at the network's size, as the post-processing returned it (any subset).
        guide_low: (h, w) luminance of the photo the network saw (linear).
        guide: (H, W) luminance of the photo at its own size (linear), H >= h, W >= w.
        settings: window and strips (:class:`Upsampling`).

    Returns:
        A new :class:`Maps` of (H, W) float32 maps (clipped to their ranges, unit normals), same meta; a constant
        channel (e.g. the one specular level) stays that constant, as a read-only view that takes no memory.
    """
    h, w = maps.shape
    big = guide.shape[:2]
    if guide_low.shape[:2] != (h, w) or big[0] < h or big[1] < w:
        raise ValueError(f"guides {guide_low.shape[:2]} / {big} do not fit maps of {(h, w)}")
    mean = float(guide_low.mean())
    eps = settings.eps * max(mean * mean, 1e-12)
    # Every varying map's channels P, their gains a and the guide I in one (h, w, 2 C + 1) stack upsampled strip by
    # strip: P_full = up(P) + up(a) (I_full - up(I)). Constant maps stay constant (gain 0).
    varying, plans, result, at = [], [], {}, 0
    for n in maps.names:
        a = np.asarray(getattr(maps, n), np.float32)
        if a.min() == a.max():
            result[n] = np.broadcast_to(a.reshape(-1)[:1], big + (a.shape[-1],))  # read-only, no memory
            continue
        varying.append(a)
        plans.append((n, at, a.shape[-1]))
        result[n] = np.empty(big + (a.shape[-1],), np.float32)
        at += a.shape[-1]
    if plans:
        p = np.concatenate(varying, axis=-1)
        g_low = np.asarray(guide_low, np.float32)
        stack = np.concatenate([p, local_gain(g_low, p, settings.radius, eps), g_low[..., None]], axis=-1)
        del varying, p
        fast = bool(_factor(big, (h, w)))
        if fast:  # channel planes: every operation below runs over contiguous rows
            stack = np.ascontiguousarray(np.moveaxis(stack, -1, 0))
        rows = max(1, settings.strip_bytes // (big[1] * (2 * at + 1) * 4 * 2))

        def strip_of(y0: int) -> None:
            y1 = min(big[0], y0 + rows)
            if fast:
                up = upsample_planes(stack, slice(y0, y1), big)  # (2 C + 1, len, W)
            else:
                up = np.moveaxis(bilinear_rows(stack, slice(y0, y1), big), -1, 0)
            detail = guide[y0:y1] - up[2 * at]  # the photo's detail finer than the network's pixels
            for n, o, c in plans:
                lo, hi = MAP_RANGES[n]
                strip = result[n][y0:y1]
                for j in range(c):
                    plane = up[at + o + j]
                    plane *= detail
                    plane += up[o + j]
                    np.clip(plane, lo, hi, out=plane)
                    strip[..., j] = plane
                if n == "normal":
                    strip[...] = normalize_normals(strip)

        starts = range(0, big[0], rows)
        if settings.threads > 1 and len(starts) > 1:  # numpy leaves the GIL in its array operations
            with ThreadPoolExecutor(settings.threads) as pool:
                list(pool.map(strip_of, starts))
        else:
            for y0 in starts:
                strip_of(y0)
    return maps._with(result)


def luminance(image: np.ndarray) -> np.ndarray:
    """(H, W) float32 mean of the linear channels of an (H, W, 3) photo: ``(r + g) + b`` over 3, channel by channel
    (the bits of ``mean(axis=-1)``, without a reduction over an axis of 3)."""
    a = np.asarray(image, np.float32)
    out = a[..., 0] + a[..., 1]
    out += a[..., 2]
    out /= np.float32(a.shape[-1])
    return out


def network_photo(image: np.ndarray, k: int) -> np.ndarray:
    """The (h, w, 3) photo the network sees: ``image`` (H, W, 3) averaged over k x k pixel blocks (the last block of a
    row or column over the pixels it has), ``(h, w) = (ceil(H / k), ceil(W / k))``, so that :func:`upsample_rows`
    brings the maps back by slices; ``k`` from :meth:`Upsampling.factor`. A block mean of 16 Mpx takes a tenth of
    OpenImageIO's resize."""
    from ..core.filters import block_mean

    return block_mean(image, k, partial=True) if k > 1 else np.asarray(image, np.float32)
