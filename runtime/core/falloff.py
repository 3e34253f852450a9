"""The camera's field of view from the flash's own fall-off in a photo of a flat material (numpy only).

A point flash at height ``h`` above a plane lights it with irradiance ``cos(theta) / D^2 = cos^3(theta) / h^2``
(``D`` the distance to the flash, ``theta`` the angle from the plane's normal); a diffuse plane returns that to
the camera whatever the view. In the renderer's frame (:mod:`svbrdf.runtime.core.render`: lengths in half the
photo width, pixel ``(i, j)`` of an ``H x W`` photo at ``x = 2 (j + 0.5) / W - 1``, ``y = (H / W)(1 - 2 (i + 0.5) /
H)``; the camera and flash at height ``d = 1 / t`` with ``t = tan(fov / 2)``), the renderer with fall-off on
gives a diffuse pixel at distance ``rho`` from the flash's foot point ``(x0, y0)``

.. math::

    L = A\\,\\rho_d\\,(1 + t^2 |p - p_0|^2)^{-3/2}

(``n.l = d / D`` times ``d^2 / D^2``). :func:`estimate_fov` fits ``log A``, ``t``, ``x0`` and ``y0`` to the
photo's coarse log luminance by iteratively reweighted least squares: the photo is cut into square cells
(:data:`GRID` across its long side) whose **median** luminance keeps a stationary texture's share of every cell
alike; cells with clipped pixels are left out; residuals are weighted robustly and more harshly above the fit than
below it (the specular highlight and its glints only add light). The answer is ``fov = 2 atan(t)`` across the
photo's width; for a view rectified to the plane from an oblique camera (a capture's view) it is the flash's
height over the photographed width, the field of view the renderer needs.

Reliability (:class:`FovEstimate` ``reliable`` and ``reason``): the fit is refused when it lands at the edge of
:data:`T_RANGE` or outside :data:`FOV_LIMITS`, when the predicted fall-off over the photo is under
:data:`MIN_CONTRAST` times the residuals' robust spread (a narrow field of view or a flat photo: nothing to
measure), when the fit's own standard error of ``log t`` (inflated by :data:`SE_INFLATION` for the cells'
correlated texture) is above :data:`MAX_SE_LOG_T`, or when the same fit of the cells' **chroma** (brightest less
darkest channel: a white highlight adds the same to every channel, so it cancels) disagrees by more than
:data:`MAX_DISAGREEMENT` in ``log t`` on a photo with colour enough (:data:`MIN_COLOUR`): a broad highlight
steepening the luminance. On real textured or glossy materials the fit is seldom reliable
(``docs/results/camera.md``); the caller then keeps its default camera.

Decision: docs/decisions/055-fov-estimate.md
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Optional, Tuple

import numpy as np

#: Cells across the photo's long side.
GRID = 16
#: Pixels whose brightest channel reaches this (linear) are clipped; a cell with more than CLIPPED_SHARE of them is out.
CLIP = 0.98
CLIPPED_SHARE = 0.02
#: The range of ``t = tan(fov / 2)`` searched (fov 4-125 deg); a fit at its edge is unreliable.
T_RANGE: Tuple[float, float] = (math.tan(math.radians(2.0)), math.tan(math.radians(62.5)))
#: Robust weights: residuals above the fit beyond ``POS_K`` robust sigmas, below it beyond ``NEG_K``, weigh nothing
#: (Tukey's biweight).
POS_K = 1.5
NEG_K = 3.0
#: Reliability thresholds (module docstring).
MIN_CONTRAST = 2.0
SE_INFLATION = 3.0
MAX_SE_LOG_T = 0.15
#: The luminance and colour fits' ``|log(t_lum / t_colour)|`` beyond which the highlight is taken to disturb the fit.
MAX_DISAGREEMENT = 0.2
#: The colour fit is checked when the cells' median chroma is at least this share of their median luminance.
MIN_COLOUR = 0.1
#: A photo whose fitted fall-off is under this ratio (brightest to darkest cell used) shows no flash.
HIGHLIGHT_RATIO = 1.15
#: The foot point is out of frame beyond this many half-widths (half-heights) from the centre, with a fall-off of
#: at least OUT_CONTRAST sigmas.
OUT_MARGIN = 1.2
OUT_CONTRAST = 3.0
#: Fields of view reported as reliable lie inside this range (degrees).
FOV_LIMITS: Tuple[float, float] = (8.0, 120.0)


@dataclass(frozen=True)
class FovEstimate:
    """What :func:`estimate_fov` found.

    Attributes:
        fov_deg: field of view across the photo's width, degrees (the fit's, even when unreliable; None: no fit).
        t: ``tan(fov / 2)``.
        centre: the flash's foot point ``(x0, y0)`` in the renderer's frame (half-widths; may lie outside the photo).
        contrast: the fitted fall-off's log range over the cells used, in robust sigmas of the residuals.
        se_log_t: the standard error of ``log t`` (inflated, module docstring).
        cells: cells used / cells in all.
        reliable: the fit passes every test.
        reason: why not (empty when reliable).
        seconds: time taken.
        out_of_frame: ``"out of frame"`` when the fit's foot point lies :data:`OUT_MARGIN` times the half-width
            (half-height) from the centre or further and its fall-off stands :data:`OUT_CONTRAST` sigmas above the
            texture; ``"absent"`` when the fitted fall-off over the photo is under :data:`HIGHLIGHT_RATIO` (no
            flash seen); else ``""``. Said whether or not the fit is reliable.
    """

    fov_deg: Optional[float]
    t: Optional[float]
    centre: Optional[Tuple[float, float]]
    contrast: float
    se_log_t: float
    cells: Tuple[int, int]
    reliable: bool
    reason: str
    seconds: float
    out_of_frame: str = ""

    def to_dict(self) -> dict:
        return asdict(self)


def cell_medians(photo: np.ndarray, grid: int = GRID, signal: str = "luminance"
                 ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A signal of the photo as medians of square cells, ``grid`` across the long side.

    Args:
        photo: (H, W, 3) (or (H, W)) linear image, large enough for 2 cells a side (else ValueError).
        grid: cells across the long side.
        signal: ``"luminance"`` (the channels' mean) or ``"chroma"`` (the brightest channel less the darkest:
            ``(max - min)(rho_d) S``, free of a white specular term, which adds the same to every channel).

    Returns:
        ``(median, clipped_share, x, y)``, each (gh, gw): the cells' median signal, share of clipped pixels and
        centres in the renderer's frame (the cells tile the photo's centre; the rest of each side is left out).
    """
    img = np.asarray(photo, dtype=np.float32)
    top = img.max(axis=-1) if img.ndim == 3 else img
    if img.ndim == 2:
        lum = img
    elif signal == "chroma":
        lum = top - img.min(axis=-1)
    else:
        lum = img.mean(axis=-1)
    h, w = lum.shape
    c = max(1, max(h, w) // grid)
    gh, gw = h // c, w // c
    if gh < 2 or gw < 2:
        raise ValueError(f"photo of {w}x{h} px is too small for a {grid}-cell fall-off grid")
    y0, x0 = (h - gh * c) // 2, (w - gw * c) // 2

    def cells(a):
        return a[y0:y0 + gh * c, x0:x0 + gw * c].reshape(gh, c, gw, c).transpose(0, 2, 1, 3).reshape(gh, gw, c * c)

    med = np.median(cells(lum), axis=-1)
    clipped = (cells(top) >= CLIP).mean(axis=-1)
    cols = x0 + (np.arange(gw) + 0.5) * c
    rows = y0 + (np.arange(gh) + 0.5) * c
    xs = 2.0 * cols / w - 1.0
    ys = (h / w) * (1.0 - 2.0 * rows / h)
    return med, clipped, np.broadcast_to(xs[None, :], (gh, gw)), np.broadcast_to(ys[:, None], (gh, gw))


def _weights(r: np.ndarray, sigma: float) -> np.ndarray:
    k = np.where(r > 0, POS_K, NEG_K) * sigma
    u = np.clip(np.abs(r) / k, 0.0, 1.0)
    return (1.0 - u * u) ** 2


#: Bounds of the parameters ``q = (log A, log t, x0, y0)``.
_LOWER = np.array([-np.inf, math.log(T_RANGE[0]), -3.0, -3.0])
_UPPER = np.array([np.inf, math.log(T_RANGE[1]), 3.0, 3.0])


def _model(q: np.ndarray, x: np.ndarray, y: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Model log luminance of the cells at ``(x, y)`` and its Jacobian (n, 4) for ``q = (log A, log t, x0, y0)``."""
    c, s, x0, y0 = q
    t2 = math.exp(2.0 * s)
    dx, dy = x - x0, y - y0
    r2 = dx * dx + dy * dy
    g = 1.0 + t2 * r2
    jac = np.empty((x.size, 4))
    jac[:, 0] = 1.0
    jac[:, 1] = -3.0 * t2 * r2 / g
    jac[:, 2] = 3.0 * t2 * dx / g
    jac[:, 3] = 3.0 * t2 * dy / g
    return c - 1.5 * np.log(g), jac


def _median(a: np.ndarray) -> float:
    """The (upper) median of a 1-D array, without ``np.median``'s overhead (called twice per iteration)."""
    k = a.size // 2
    return float(np.partition(a, k)[k])


def _fit(v: np.ndarray, x: np.ndarray, y: np.ndarray, q: np.ndarray, iters: int = 30):
    """IRLS Gauss-Newton (Levenberg-damped) from ``q``; returns ``(q, weights, sigma, cost, jacobian)``. The
    residuals' scale is their median absolute deviation over all cells, so the weights cannot collapse."""
    w = np.ones_like(v)
    for k in range(iters + 1):
        m, jac = _model(q, x, y)
        r = v - m
        sigma = max(1.4826 * _median(np.abs(r - _median(r))), 1e-3)
        w = _weights(r, sigma) if k else np.ones_like(v)
        if k == iters:
            break
        jw = jac * w[:, None]
        a = jac.T @ jw
        a += 1e-2 * np.diag(np.diag(a)) + 1e-9 * np.eye(q.size)
        step = np.linalg.solve(a, jw.T @ r)
        step[1:] = np.clip(step[1:], -0.5, 0.5)
        q = np.clip(q + step, _LOWER, _UPPER)
        if np.max(np.abs(step)) < 1e-4:
            break
    u = np.clip(np.abs(r) / (np.where(r > 0, POS_K, NEG_K) * sigma), 0.0, 1.0)
    cost = float(np.mean(1.0 - (1.0 - u * u) ** 3)) * sigma * sigma  # Tukey's rho, scaled
    return q, w, sigma, cost, jac


def _fit_signal(photo: np.ndarray, grid: int, signal: str, start: Optional[np.ndarray] = None):
    """``(fit, medians, clipped shares, x, y)`` of one signal's cells (:func:`cell_medians`); ``fit`` the best
    robust fit ``(q, weights, sigma, jacobian, x, y)`` of the usable cells, None when fewer than 8 are usable.
    Started from ``start`` (``q``) alone when given, else from six guesses."""
    med, clipped, xs, ys = cell_medians(photo, grid, signal)
    ok = (clipped <= CLIPPED_SHARE) & (med > 1e-5)
    if ok.sum() < 8:
        return None, med, clipped, xs, ys
    v, x, y = np.log(med[ok]), xs[ok], ys[ok]
    bright = np.argsort(v)[-max(3, v.size // 20):]  # starts: the brightest cells' centre and the photo's centre
    foot = (float(np.mean(x[bright])), float(np.mean(y[bright])))
    starts = [np.array([0.0, math.log(math.tan(math.radians(fov) / 2.0)), x0, y0])
              for x0, y0 in {foot, (0.0, 0.0)} for fov in (20.0, 45.0, 75.0)] if start is None else [start.copy()]
    best = None
    for q0 in starts:
        q0[0] = float(np.median(v - _model(q0, x, y)[0]))
        fit = _fit(v, x, y, q0)
        if best is None or fit[3] < best[3]:
            best = fit
    q, w, sigma, _, jac = best
    return (q, w, sigma, jac, x, y), med, clipped, xs, ys


def _quality(fit) -> Tuple[float, float, float]:
    """``(contrast, span, inflated standard error of log t)`` of a fit (module docstring): ``span`` is the fitted
    fall-off's log range over the cells it uses, ``contrast`` that over the residuals' robust sigma."""
    q, w, sigma, jac, x, y = fit
    t = math.exp(q[1])
    used = w > 0
    r2 = (x - q[2]) ** 2 + (y - q[3]) ** 2
    span = 1.5 * (np.log1p(t * t * r2[used].max()) - np.log1p(t * t * r2[used].min())) if used.sum() > 1 else 0.0
    cov = np.linalg.pinv(jac.T @ (jac * w[:, None])) * sigma * sigma
    return float(span / sigma), float(span), float(math.sqrt(max(cov[1, 1], 0.0))) * SE_INFLATION


def estimate_fov(photo: np.ndarray, grid: int = GRID) -> FovEstimate:
    """The field of view across ``photo``'s width from the flash's fall-off (module docstring).

    Args:
        photo: (H, W, 3) linear photo of a flat material lit by a flash near the camera, at least ``2 * grid``
            px on its long side (pass a large photo downsized, e.g. to 256 px: the cells are coarse anyway).
        grid: cells across the long side.

    Returns:
        :class:`FovEstimate`; ``reliable`` False with a ``reason`` when the photo does not tell.

    Raises:
        ValueError: a photo too small for ``grid`` (fewer than 2 cells a side).
    """
    start = time.perf_counter()
    photo = np.asarray(photo, dtype=np.float32)
    fit, med, clipped, xs, ys = _fit_signal(photo, grid, "luminance")
    aspect = photo.shape[0] / photo.shape[1]
    total = med.size
    if fit is None:
        return FovEstimate(None, None, None, 0.0, math.inf, (0, total), False,
                           "too few unclipped, lit cells to fit the fall-off", time.perf_counter() - start)
    q, w = fit[0], fit[1]
    t = math.exp(q[1])
    fov = 2.0 * math.degrees(math.atan(t))
    contrast, span, se = _quality(fit)
    reason = ""
    lo, hi = T_RANGE
    if not (lo * 1.05 < t < hi / 1.05) or not FOV_LIMITS[0] <= fov <= FOV_LIMITS[1]:
        reason = f"the fit's field of view ({fov:.0f} deg) is at the edge of the plausible range"
    elif contrast < MIN_CONTRAST:
        reason = (f"the fall-off across the photo is too faint against its texture ({contrast:.1f} sigma, "
                  f"needs {MIN_CONTRAST:g})")
    elif se > MAX_SE_LOG_T:
        reason = (f"the fall-off fit is too uncertain (standard error {100 * (math.exp(min(se, 5.0)) - 1):.0f} % "
                  f"on tan(fov/2), at most {100 * (math.exp(MAX_SE_LOG_T) - 1):.0f} %)")
    else:  # the colour fit, free of a white highlight, must agree where the material has colour enough to tell
        colour, chroma = _fit_signal(photo, grid, "chroma", start=q)[:2]
        if colour is not None and float(np.median(chroma)) >= MIN_COLOUR * float(np.median(med)):
            t_c = math.exp(colour[0][1])
            if abs(math.log(t / t_c)) > MAX_DISAGREEMENT:
                reason = (f"the highlight disturbs the fall-off (the luminance says {fov:.0f} deg, the colour "
                          f"{2.0 * math.degrees(math.atan(t_c)):.0f} deg)")
    where = ""
    if span < math.log(HIGHLIGHT_RATIO):
        where = "absent"
    elif contrast >= OUT_CONTRAST and (abs(q[2]) > OUT_MARGIN or abs(q[3]) > OUT_MARGIN * aspect):
        where = "out of frame"
    return FovEstimate(round(fov, 3), t, (float(q[2]), float(q[3])), round(contrast, 3), round(se, 4),
                       (int((w > 0).sum()), total), not reason, reason, time.perf_counter() - start, where)


__all__ = ["FovEstimate", "estimate_fov", "cell_medians", "GRID", "T_RANGE", "FOV_LIMITS"]
