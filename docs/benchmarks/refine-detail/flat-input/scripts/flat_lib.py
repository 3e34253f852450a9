"""Lighting models tried beside the runtime's (``svbrdf.runtime.flash_trend.even_lighting``, the low pass that
began here as this probe's ``flatten`` and moved into the package unchanged), none adopted: a polynomial fitted to
the log luminance (no border bias, no width) and a locally linear low pass (the window cut at the border). The
photo is divided by either as the runtime divides it by its own (``_divide``).
"""
import math

import numpy as np

from svbrdf.runtime.tiling import block_mean

SMALL = 64


def _small_log_lum(photo):
    """(log luminance of a block-mean copy <= SMALL px (float64, floored at 1e-4), block size k)."""
    h, w = photo.shape[:2]
    k = max(1, math.ceil(max(h, w) / SMALL))
    lum = block_mean(np.asarray(photo, np.float32).mean(axis=-1, keepdims=True), k, partial=True)[..., 0]
    return np.log(np.maximum(lum, 1e-4)).astype(np.float64), k


def _divide(photo, field):
    """(H, W, 3) float32: the photo divided by a lighting field, median luminance kept."""
    lum = photo.mean(axis=-1)
    flat = photo / field[..., None]
    scale = np.median(lum) / max(float(np.median(flat.mean(axis=-1))), 1e-8)
    return np.clip(flat * scale, 0, None).astype(np.float32)


def poly_lighting(photo, degree):
    """(H, W) exp of a least-squares polynomial of ``degree`` in (x, y) (scaled to [-1, 1] by the width) fitted
    to the log luminance of a block-mean copy <= 64 px."""
    h, w = photo.shape[:2]
    g, k = _small_log_lum(photo)
    hs, ws = g.shape

    def terms(ys, xs):
        return np.stack([xs ** i * ys ** j for i in range(degree + 1) for j in range(degree + 1 - i)], -1)
    yy, xx = np.meshgrid((np.arange(hs) + 0.5) * k, (np.arange(ws) + 0.5) * k, indexing="ij")
    a = terms((2 * yy - h) / w, (2 * xx - w) / w).reshape(-1, (degree + 1) * (degree + 2) // 2)
    coef, *_ = np.linalg.lstsq(a, g.ravel(), rcond=None)
    yy, xx = np.meshgrid(np.arange(h) + 0.5, np.arange(w) + 0.5, indexing="ij")
    return np.exp(terms((2 * yy - h) / w, (2 * xx - w) / w) @ coef)


def flatten_poly(photo, degree=4):
    """(H, W, 3) float32: the photo divided by :func:`poly_lighting`, median luminance kept."""
    return _divide(photo, poly_lighting(photo, degree))


def _box_sum0(x, r):
    """Sum of x (h, w) over the (2r + 1)^2 window around each pixel, zero outside (float64)."""
    a = np.pad(x.astype(np.float64), ((r + 1, r), (r + 1, r)))
    c = a.cumsum(0).cumsum(1)
    n = 2 * r + 1
    return c[n:, n:] - c[:-n, n:] - c[n:, :-n] + c[:-n, :-n]


def llr_lighting(photo, sigma):
    """(H, W) exp of a locally linear fit of the log luminance (Gaussian weights of ``sigma`` x the width, three
    box blurs, the window cut at the image's border), on a block-mean copy <= 64 px, interpolated bilinearly: a
    straight fall-off is followed to the border instead of flattened there (no frame)."""
    from svbrdf.runtime.flash_trend import _interp_matrix

    h, w = photo.shape[:2]
    g, k = _small_log_lum(photo)
    hs, ws = g.shape
    s = sigma * w / k
    r = max(1, int(round((math.sqrt(1 + 4 * s * s) - 1) / 2)))
    v, u = np.meshgrid(np.arange(hs) - hs / 2, np.arange(ws) - ws / 2, indexing="ij")
    one = np.ones_like(g)

    def blur(x):
        for _ in range(3):
            x = _box_sum0(x, r)
        return x

    m = {key: blur(val) for key, val in {"1": one, "u": u, "v": v, "uu": u * u, "uv": u * v, "vv": v * v,
                                         "g": g, "ug": u * g, "vg": v * g}.items()}
    a = np.stack([np.stack([m["1"], m["u"], m["v"]], -1), np.stack([m["u"], m["uu"], m["uv"]], -1),
                  np.stack([m["v"], m["uv"], m["vv"]], -1)], -2)
    b = np.stack([m["g"], m["ug"], m["vg"]], -1)
    coef = np.linalg.solve(a + 1e-9 * np.eye(3), b[..., None])[..., 0]
    fit = coef[..., 0] + coef[..., 1] * u + coef[..., 2] * v
    return np.exp(_interp_matrix(h, hs, k) @ fit @ _interp_matrix(w, ws, k).T)


def flatten_llr(photo, sigma=0.25):
    """(H, W, 3) float32: the photo divided by :func:`llr_lighting`, median luminance kept."""
    return _divide(photo, llr_lighting(photo, sigma))
