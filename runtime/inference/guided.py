"""Maps of a large photo from the network at a smaller size: the maps upsampled with the photo's own detail (numpy).

The network costs about 0.5 s per megapixel on two cores, so a 4096 px photo (16 Mpx, 25 tiles) takes 12 s and an
8192 px one a minute. Above :data:`DIRECT_MAX_SIZE` the preview instead runs the network and the post-processing on
the photo downsized to :attr:`Upsampling.network_size` (the same path and the same maps as a photo of that size),
and brings the maps to the photo's size with :func:`guided_upsample`: each map channel ``P`` is

.. math::

    P_{full} = \\operatorname{up}(P) + \\operatorname{up}(a) \\cdot (I_{full} - \\operatorname{up}(I))

with ``I`` the photo's luminance (mean of the linear channels) at the network's size, ``I_full`` at the photo's,
``up`` the bilinear upsampling (pixel centres aligned) and ``a`` the local gain of the map on the photo,
``cov(I, P) / (var(I) + eps)`` over a ``(2 r + 1)^2`` window at the network's size (the guided filter's linear
model; He et al. 2010). The low frequencies are the network's maps as they are (the plain upsampling); the detail
finer than the network's pixels is the photo's, scaled by how each map followed the photo around that place (zero
where it did not, e.g. a constant specular or a filled highlight). Normals are renormalised and every map clipped
to its range. The work is done in strips of rows, so the temporaries stay near :attr:`Upsampling.strip_bytes`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from ..core.maps import MAP_RANGES, Maps, normalize_normals

__all__ = ["Upsampling", "DIRECT_MAX_SIZE", "guided_upsample", "local_gain", "bilinear_rows", "luminance", "network_photo"]

#: Photos whose long side (after ``max_size``) is at most this run the network at their own size (tiled above
#: ``tile``), as before issue 54; larger ones through :func:`guided_upsample` (with the default
#: :class:`Upsampling`).
DIRECT_MAX_SIZE = 2048


@dataclass(frozen=True)
class Upsampling:
    """How a photo larger than :data:`DIRECT_MAX_SIZE` gets its maps (module docstring).

    Attributes:
        network_size: long side (px) of the photo the network and the post-processing see; ``None``: the photo's
            own size at any size (the network in tiles: 0.5 s per megapixel on two cores).
        radius: half-width of the window of the local gain, pixels at the network's size.
        eps: regulariser of the gain, a fraction of the squared mean luminance (flat areas of the photo get no
            detail: its noise is not the material's). Against the maps of the network at 2048 px (a 4032 x 3024
            photo, docs/lab/speed/README.md), 1e-2 / 1e-3 / 1e-4 cut the error of the base colour's and roughness's
            gradients (their detail) against the bilinear upsampling's by 8-9 / 14 / 19-24 % (normals 2 / 4 / 8 %);
            the smallest is kept.
        strip_bytes: bytes of float32 temporaries one strip of rows may take. Small enough for the C allocator to
            reuse freed strips instead of mapping fresh pages: at 4096 px, 8 MB took 3.7-5.3 s against 5.4-6.8 s
            for 64 MB strips (a third of the page faults; docs/lab/speed/README.md).
        direct_max_size: photos up to this long side run the network at their own size whatever
            ``network_size`` says (:data:`DIRECT_MAX_SIZE`: the preview's maps of such photos are unchanged).
    """

    network_size: Optional[int] = 1024
    radius: int = 2
    eps: float = 1e-4
    strip_bytes: int = 8 << 20
    direct_max_size: int = DIRECT_MAX_SIZE

    def __post_init__(self) -> None:
        if self.network_size is not None and self.network_size < 8:
            raise ValueError(f"network_size must be None or >= 8 px, got {self.network_size}")
        if self.radius < 1 or not self.eps > 0 or self.strip_bytes < 1 or self.direct_max_size < 8:
            raise ValueError(f"need radius >= 1, eps > 0, strip_bytes >= 1 and direct_max_size >= 8; got {self.radius}, "
                             f"{self.eps}, {self.strip_bytes}, {self.direct_max_size}")

    def applies(self, size: Tuple[int, int]) -> bool:
        """Whether a photo of ``size`` (H, W) takes the guided path."""
        return self.network_size is not None and max(size) > max(self.direct_max_size, self.network_size)


def _box(x: np.ndarray, r: int) -> np.ndarray:
    """Mean over the (2r + 1)^2 window (edges repeated) of (h, w, C) float64 -> float64."""
    a = np.pad(x, ((r + 1, r), (r + 1, r), (0, 0)), mode="edge")
    c = a.cumsum(0).cumsum(1)
    n = 2 * r + 1
    return (c[n:, n:] - c[:-n, n:] - c[n:, :-n] + c[:-n, :-n]) / (n * n)


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
    i = guide.astype(np.float64)[..., None]
    p = maps.astype(np.float64)
    mi, mp = _box(i, radius), _box(p, radius)
    var = _box(i * i, radius) - mi * mi
    cov = _box(i * p, radius) - mi * mp
    return _box(cov / (np.maximum(var, 0.0) + eps), radius).astype(np.float32)


def _axis(n_out: int, n_in: int) -> Tuple[np.ndarray, np.ndarray]:
    """Bilinear taps along one axis, pixel centres aligned: (n_out,) first index and (n_out,) weight of the next."""
    x = np.clip((np.arange(n_out) + 0.5) * (n_in / n_out) - 0.5, 0.0, n_in - 1)
    i0 = np.minimum(np.floor(x).astype(np.int64), max(n_in - 2, 0))
    f = (x - i0).astype(np.float32) if n_in > 1 else np.zeros(n_out, np.float32)
    return i0, f


def bilinear_rows(low: np.ndarray, rows: slice, out_shape: Tuple[int, int]) -> np.ndarray:
    """Rows ``rows`` of the bilinear upsampling of ``low`` (h, w, C) to ``out_shape`` (H, W), float32 (len, W, C)."""
    h, w = low.shape[:2]
    iy, fy = _axis(out_shape[0], h)
    ix, fx = _axis(out_shape[1], w)
    iy, fy = iy[rows], fy[rows][:, None, None]
    nxt = np.minimum(iy + 1, h - 1)
    r = low[iy] * (1 - fy) + low[nxt] * fy  # (len, w, C)
    fx = fx[None, :, None]
    return r[:, ix] * (1 - fx) + r[:, np.minimum(ix + 1, w - 1)] * fx


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
        channel (e.g. the one specular level) stays that constant.
    """
    h, w = maps.shape
    big = guide.shape[:2]
    if guide_low.shape[:2] != (h, w) or big[0] < h or big[1] < w:
        raise ValueError(f"guides {guide_low.shape[:2]} / {big} do not fit maps of {(h, w)}")
    mean = float(guide_low.mean())
    eps = settings.eps * max(mean * mean, 1e-12)
    g_low = np.asarray(guide_low, np.float32)[..., None]
    # Per map: its channels, their gains and the guide (h, w, 2C + 1) upsampled strip by strip into contiguous
    # rows, then P_full = up(P) + up(a) (I_full - up(I)). Constant maps stay constant (gain 0).
    plans, result = [], {}
    for n in maps.names:
        a = np.asarray(getattr(maps, n), np.float32)
        if a.min() == a.max():
            result[n] = np.full(big + (a.shape[-1],), a.flat[0], np.float32)
            continue
        gain = local_gain(guide_low, a, settings.radius, eps)
        plans.append((n, a.shape[-1], np.concatenate([a, gain, g_low], axis=-1)))
        result[n] = np.empty(big + (a.shape[-1],), np.float32)
    widest = max([c for _, c, _ in plans], default=1)
    rows = max(1, settings.strip_bytes // (big[1] * (2 * widest + 1) * 4 * 2))
    for y0 in range(0, big[0] if plans else 0, rows):
        y1 = min(big[0], y0 + rows)
        g = guide[y0:y1, :, None]
        for n, c, low in plans:
            up = bilinear_rows(low, slice(y0, y1), big)
            strip = result[n][y0:y1]
            np.subtract(g, up[..., 2 * c:], out=up[..., 2 * c:])  # the photo's detail finer than the network's pixels
            np.multiply(up[..., c:2 * c], up[..., 2 * c:], out=strip)
            strip += up[..., :c]
            lo, hi = MAP_RANGES[n]
            np.clip(strip, lo, hi, out=strip)
            if n == "normal":
                strip[...] = normalize_normals(strip)
    return maps._with(result)


def luminance(image: np.ndarray) -> np.ndarray:
    """(H, W) float32 mean of the linear channels of an (H, W, 3) photo."""
    return np.asarray(image, np.float32).mean(axis=-1, dtype=np.float32)


def network_photo(image: np.ndarray, network_size: int) -> np.ndarray:
    """The (h, w, 3) photo the network sees: ``image`` (H, W, 3) averaged over k x k pixel blocks, k the integer
    part of the reduction (the last block of a row or column over the pixels it has), then resized to a long side
    of ``network_size`` (:func:`~svbrdf.runtime.io.images.resize_long_side`) when the blocks did not get there.
    As :func:`~svbrdf.runtime.io.images.read_image` reduces a large file; a block mean of 16 Mpx takes a tenth of
    OpenImageIO's resize."""
    from ..core.filters import block_mean
    from ..io.images import resize_long_side

    k = max(1, int(max(image.shape[:2]) // network_size))
    small = block_mean(image, k, partial=True) if k > 1 else np.asarray(image, np.float32)
    return resize_long_side(small, network_size)

