"""A probe, not part of the package (measured worse than the network's maps: ../README.md): the specular lobe
measured from the photo, per material class (numpy).

Under a co-located flash each pixel of a flat material is seen at one angle, its distance from the flash: one point
of the specular lobe per pixel. A network (or a fine-tune) free to set the roughness pixel by pixel can fit any
brightness with any lobe, and it does: the roughness gets a blob under the flash, rings around it, and drifts with
longer fine-tunes (docs/benchmarks/refine-detail/). A stationary material repeats its classes (tile and grout, grain
and pores, a metal inlay) all over the photo, so each class is seen at every distance from the flash: together its
pixels trace its whole lobe.

:func:`fit_lobes` measures that lobe. The base colour is clustered into at most ``classes`` classes (k-means on log
colour, on a block-mean copy no longer than :data:`FIT_MAX_SIDE`); for each class, over its pixels that are not
clipped, the photo's luminance ``y`` is fitted by

.. math::

    y_i \\approx g_c\\, w_i\\, \\bar\\rho_{d,i} - v_c\\, w_i\\, \\bar\\rho_{d,i}\\, |x_i|^2 + b_c\\, s_i(r_c)

with ``w_i`` and ``s_i(r)`` the diffuse weight and the specular radiance at ``rho_s = 1`` of the one renderer
(:func:`svbrdf.runtime.render.shade`, with the maps' normals and the model's flash geometry), ``rho_d`` the base
colour's luminance, ``g_c >= 0`` an exposure, ``v_c >= 0`` a vignetting (``|x_i|`` the distance from the photo
centre) and ``b_c >= 0`` the lobe's height, by non-negative least squares for each roughness of
:data:`ROUGHNESS_GRID` (a clipped pixel adds the squared shortfall of the rendering below what the photo recorded); the class takes the roughness of least error and the specular albedo
``b_c / g_c`` (in the base colour's units: the photo gives the ratio of specular to diffuse, the maps their level).
A class whose lobe the photo does not show (too few pixels, or the lobe explains less than :data:`MIN_GAIN` of the
error left by the diffuse alone) keeps its median of the maps. Every pixel then takes its class's roughness and
specular, blended across class borders by the k-means soft assignment at full size.
"""

from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np

from svbrdf.runtime.maps import Maps
from svbrdf.runtime.render import RenderConfig, ZHAO, light_vectors, plane_positions, shade
from svbrdf.runtime.tiling import block_mean

#: The fit runs on a block-mean copy no longer than this.
FIT_MAX_SIDE = 256
#: Perceptual roughness values tried for each class (fine where the lobe changes fast, at low roughness).
ROUGHNESS_GRID: Tuple[float, ...] = tuple(float(x) for x in np.round(np.geomspace(0.04, 0.6, 25), 4))
#: A photo channel at or above this is clipped: the pixel is left out of the fit.
CLIP_LEVEL = 0.98
#: Fewest unclipped pixels (of the fit copy) a class needs for its own lobe.
MIN_PIXELS = 64
#: Smallest share of a class in the photo: smaller classes are merged into their nearest.
MIN_SHARE = 0.03
#: Least relative reduction of the diffuse-only error for the lobe to be taken as measured.
MIN_GAIN = 0.1
#: Temperature of the soft assignment, in units of the squared log-colour distance between class centres.
SOFTNESS = 0.05


def _log_colour(diffuse: np.ndarray) -> np.ndarray:
    return np.log(np.asarray(diffuse, np.float64) + 0.01)


def _kmeans(x: np.ndarray, k: int, iters: int = 20) -> np.ndarray:
    """Centres (k', C) of k-means on the rows of ``x`` (N, C), started from luminance quantiles; classes with less
    than :data:`MIN_SHARE` of the rows are merged into their nearest (so ``k' <= k``)."""
    lum = x.mean(axis=1)
    order = np.argsort(lum)
    centres = np.stack([x[order[int((j + 0.5) / k * (len(x) - 1))]] for j in range(k)])
    for _ in range(iters):
        labels = np.argmin(((x[:, None, :] - centres[None]) ** 2).sum(-1), axis=1)
        new = np.stack([x[labels == j].mean(0) if np.any(labels == j) else centres[j] for j in range(len(centres))])
        if np.allclose(new, centres):
            break
        centres = new
    while len(centres) > 1:
        labels = np.argmin(((x[:, None, :] - centres[None]) ** 2).sum(-1), axis=1)
        share = np.bincount(labels, minlength=len(centres)) / len(x)
        j = int(np.argmin(share))
        if share[j] >= MIN_SHARE:
            break
        centres = np.delete(centres, j, axis=0)
    return centres


def soft_classes(log_colour: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """(..., K) soft assignment of log colours (..., C) to class centres (K, C): a softmax of the negative squared
    distance over :data:`SOFTNESS` times the mean squared distance between centres (hard for one class)."""
    d2 = ((log_colour[..., None, :] - centres) ** 2).sum(-1)
    if len(centres) == 1:
        return np.ones_like(d2)
    spread = ((centres[:, None] - centres[None]) ** 2).sum(-1)
    tau = SOFTNESS * float(spread[np.triu_indices(len(centres), 1)].mean())
    z = -(d2 - d2.min(axis=-1, keepdims=True)) / max(tau, 1e-6)
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


def fit_lobes(maps: Maps, photo: np.ndarray, config: Optional[RenderConfig] = None, classes: int = 3,
              grid: Sequence[float] = ROUGHNESS_GRID, centre: Optional[Tuple[float, float]] = None) -> Maps:
    """The maps with their roughness and specular replaced by each material class's lobe as the photo shows it
    (see the module docstring).

    Args:
        maps: the four maps (H, W) estimated from ``photo`` (diffuse linear [0, 1], normals unit OpenGL).
        photo: (H, W, 3) linear photo, taken with the flash of ``config``'s geometry.
        config: renderer settings of the model (default ``maps.render_config`` or :data:`ZHAO`).
        classes: most material classes (>= 1).
        grid: perceptual roughness values tried.

    Returns:
        A new :class:`Maps`: specular and roughness (H, W, 1) float32 in [0, 1]; the others shared. ``meta["lobes"]``
        lists per class ``share``, ``roughness``, ``specular``, ``measured`` (False: the maps' median kept) and
        ``gain`` (relative error reduction by the lobe).
    """
    if classes < 1:
        raise ValueError(f"classes must be >= 1, got {classes}")
    maps.require(what="the lobe fit")
    config = config or maps.render_config or ZHAO
    h, w = maps.shape
    if photo.shape[:2] != (h, w):
        raise ValueError(f"photo {photo.shape[:2]} and maps {(h, w)} differ in size")
    k = max(1, math.ceil(max(h, w) / FIT_MAX_SIDE))
    clipped = (np.asarray(photo).max(axis=-1, keepdims=True) >= CLIP_LEVEL).astype(np.float32)
    small = {n: block_mean(np.asarray(getattr(maps, n), np.float32), k) for n in ("diffuse", "specular", "roughness",
                                                                                  "normal")}
    p = block_mean(np.asarray(photo, np.float32), k)
    ok = block_mean(clipped, k)[..., 0] == 0
    sh, sw = p.shape[:2]
    # The fit copy covers the top-left sh*k x sw*k pixels; its geometry is that of a photo of that size.
    cam = None
    if centre is not None:  # the flash above the located highlight (row, column in pixels of the maps)
        cam = (2.0 * centre[1] / w - 1.0, (h / w) * (1.0 - 2.0 * centre[0] / h), config.camera_distance)
    v, l, d2 = light_vectors(sh, sw, None, config, camera_pos=cam)
    n = small["normal"]
    args = ((n[..., 0], n[..., 1], n[..., 2]), (v[..., 0], v[..., 1], v[..., 2]), (l[..., 0], l[..., 1], l[..., 2]))
    one = np.ones((sh, sw), np.float32)
    dw, _ = shade(*args, one, one * 0.5, config, d2[..., 0])
    spec = np.stack([shade(*args, one, one * r, config, d2[..., 0])[1] for r in grid])  # (R, sh, sw)
    y = p.mean(-1).astype(np.float64)
    xd = (dw * small["diffuse"].mean(-1)).astype(np.float64)

    lc = _log_colour(small["diffuse"]).reshape(-1, 3)
    centres = _kmeans(lc, classes)
    labels = np.argmin(((lc[:, None, :] - centres[None]) ** 2).sum(-1), axis=1).reshape(sh, sw)
    pos = plane_positions(sh, sw)
    rho2 = (pos[..., 0] ** 2 + pos[..., 1] ** 2).astype(np.float64)  # vignetting: about the lens axis  # squared distance from the centre
    lobes = []
    for c in range(len(centres)):
        cls = labels == c
        sel, low = cls & ok, cls & ~ok
        share = float(cls.mean())
        lobe = {"share": share, "roughness": float(np.median(small["roughness"][cls])),
                "specular": float(np.median(small["specular"][cls])), "measured": False, "gain": 0.0}
        if sel.sum() >= MIN_PIXELS:
            yy, a = y[sel], xd[sel]
            cols = [a, -a * rho2[sel]]  # the diffuse and the vignetting's darkening of it
            base_coef, base = _nnls(np.stack(cols, 1), yy)
            best = None
            for j, r in enumerate(grid):
                s = spec[j][sel].astype(np.float64)
                coef, err = _nnls(np.stack(cols + [s], 1), yy)
                if low.any():  # clipped: the rendering must reach at least what the photo recorded
                    pred = coef[0] * xd[low] - coef[1] * xd[low] * rho2[low] + coef[2] * spec[j][low]
                    err += float(np.sum(np.maximum(y[low] - pred, 0.0) ** 2))
                if best is None or err < best[0]:
                    best = (err, r, coef)
            err, r, coef = best
            gain = 1.0 - err / max(base, 1e-12)
            lobe["gain"] = float(gain)
            if gain >= MIN_GAIN and coef[0] > 1e-6 and coef[2] > 0:
                lobe.update(roughness=float(r), specular=float(min(coef[2] / coef[0], 1.0)), measured=True)
        lobes.append(lobe)
    weights = soft_classes(_log_colour(maps.diffuse), centres)  # (H, W, K)
    rough = np.array([lb["roughness"] for lb in lobes])
    spec_level = np.array([lb["specular"] for lb in lobes])
    out = maps._with({**dict(maps.items()),
                      "roughness": np.clip(weights @ rough, 0, 1).astype(np.float32)[..., None],
                      "specular": np.clip(weights @ spec_level, 0, 1).astype(np.float32)[..., None]})
    out.meta["lobes"] = lobes
    return out


def _nnls(a: np.ndarray, y: np.ndarray) -> Tuple[np.ndarray, float]:
    """``(x, error)``: argmin over ``x >= 0`` of ``|a x - y|^2`` for a few columns ``a`` (N, K), by trying every set
    of free columns (K <= 4), and that least squared error."""
    gram, rhs, yy = a.T @ a, a.T @ y, float(y @ y)
    k = a.shape[1]
    best = (np.zeros(k), yy)
    for mask in range(1, 2 ** k):
        idx = [i for i in range(k) if mask >> i & 1]
        g = gram[np.ix_(idx, idx)]
        try:
            x = np.linalg.solve(g + 1e-12 * np.trace(g) * np.eye(len(idx)), rhs[idx])
        except np.linalg.LinAlgError:
            continue
        if np.any(x < 0):
            continue
        err = yy - 2 * float(x @ rhs[idx]) + float(x @ g @ x)
        if err < best[1]:
            full = np.zeros(k)
            full[idx] = x
            best = (full, err)
    return best[0], max(best[1], 0.0)


__all__ = ["fit_lobes", "soft_classes", "ROUGHNESS_GRID", "FIT_MAX_SIDE", "MIN_GAIN", "MIN_SHARE"]
