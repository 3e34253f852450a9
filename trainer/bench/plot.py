"""The benchmark's Pareto plot: two panels of error against seconds (log axis), drawn with OpenImageIO (no
matplotlib): :func:`plot_pareto`."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Dict, List, Mapping, Sequence, Tuple

import OpenImageIO as oiio

from svbrdf.runtime.io.images import text_supported, write_image

_PALETTE = [(0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16), (0.58, 0.4, 0.74),
            (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.5, 0.5, 0.5), (0.74, 0.74, 0.13), (0.09, 0.75, 0.81)]
_MARKERS = {"baseline": "square", "preview": "diamond", "finetune": "circle", "scratch": "cross"}


def _marker(buf, x: int, y: int, shape: str, colour, r: int = 4) -> None:
    A = oiio.ImageBufAlgo
    if shape == "square":
        A.render_box(buf, x - r, y - r, x + r, y + r, colour, True)
    elif shape == "diamond":
        for dy in range(-r - 1, r + 2):
            w = r + 1 - abs(dy)
            A.render_line(buf, x - w, y + dy, x + w, y + dy, colour)
    elif shape == "circle":
        for dy in range(-r, r + 1):
            w = int(round(math.sqrt(r * r - dy * dy)))
            A.render_line(buf, x - w, y + dy, x + w, y + dy, colour)
    else:  # cross
        for o in (-1, 0, 1):
            A.render_line(buf, x - r, y - r + o, x + r, y + r + o, colour)
            A.render_line(buf, x - r, y + r + o, x + r, y - r + o, colour)


def _nice_max(v: float) -> float:
    if v <= 0:
        return 1.0
    e = 10 ** math.floor(math.log10(v))
    for m in (1, 1.2, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10):
        if m * e >= v:
            return m * e
    return 10 * e


def plot_pareto(series: Sequence[Mapping[str, Any]], path: Path, *, titles: Tuple[str, str],
                force: bool = False) -> Tuple[List[Dict[str, str]], str]:
    """Draw two panels (x = seconds on a log axis; y = ``y[0]`` and ``y[1]`` of each point) into a PNG.

    Args:
        series: ``{label, method, points: [(seconds, y0 or None, y1 or None), ...]}`` (points joined by lines
            in the given order).
        path: output PNG.
        titles: y-axis titles of the two panels.
        force: overwrite.

    Returns:
        ``(legend, note)``: one ``{label, colour (hex), marker}`` per series, and a note when text could not
        be drawn (no font).
    """
    A = oiio.ImageBufAlgo
    pw, ph, ml, mr, mt, mb = 520, 420, 70, 20, 40, 50
    cols = 4
    leg_h = 22 * math.ceil(len(series) / cols) + 10 if series else 0
    width, height = 2 * pw, ph + leg_h
    buf = oiio.ImageBuf(oiio.ImageSpec(width, height, 3, oiio.FLOAT))
    A.fill(buf, (1.0, 1.0, 1.0))
    text = text_supported()
    ink, grid = (0.0, 0.0, 0.0), (0.85, 0.85, 0.85)
    legend = []
    for i, s in enumerate(series):
        c = _PALETTE[i % len(_PALETTE)]
        legend.append({"label": s["label"], "colour": "#%02x%02x%02x" % tuple(int(round(255 * v)) for v in c),
                       "marker": _MARKERS.get(s["method"], "cross"), "rgb": c})
    xs = [p[0] for s in series for p in s["points"] if p[0] is not None and p[0] > 0]
    lo = math.floor(math.log10(min(xs))) if xs else -2
    hi = math.ceil(math.log10(max(xs))) if xs else 2
    hi = max(hi, lo + 1)
    for panel in (0, 1):
        x0, x1, y0, y1 = panel * pw + ml, panel * pw + pw - mr, mt, ph - mb
        ys = [p[1 + panel] for s in series for p in s["points"] if p[1 + panel] is not None]
        ymax = _nice_max(max(ys)) if ys else 1.0

        def X(sec: float) -> int:
            return int(round(x0 + (math.log10(max(sec, 10.0 ** lo)) - lo) / (hi - lo) * (x1 - x0)))

        def Y(v: float) -> int:
            return int(round(y1 - min(max(v, 0.0), ymax) / ymax * (y1 - y0)))

        for k in range(lo, hi + 1):
            A.render_line(buf, X(10.0 ** k), y0, X(10.0 ** k), y1, grid)
            if text:
                A.render_text(buf, X(10.0 ** k) - 14, y1 + 18, f"{10.0 ** k:g}", 13, "", ink)
        for j in range(6):
            v = ymax * j / 5
            A.render_line(buf, x0, Y(v), x1, Y(v), grid)
            if text:
                A.render_text(buf, x0 - 52, Y(v) + 5, f"{v:.3g}", 13, "", ink)
        A.render_box(buf, x0, y0, x1, y1, ink)
        if text:
            A.render_text(buf, (x0 + x1) // 2 - 60, ph - 10, "seconds (log scale)", 14, "", ink)
            A.render_text(buf, x0, y0 - 12, titles[panel], 15, "", ink)
        for s, leg in zip(series, legend):
            pts = [(X(p[0]), Y(p[1 + panel])) for p in s["points"] if p[0] and p[1 + panel] is not None]
            for (ax, ay), (bx, by) in zip(pts, pts[1:]):
                A.render_line(buf, ax, ay, bx, by, leg["rgb"])
            for px, py in pts:
                _marker(buf, px, py, leg["marker"], leg["rgb"])
    for k, leg in enumerate(legend):  # legend strip under the panels (markers even without a font)
        lx, ly = ml + (k % cols) * (width - ml) // cols, ph + 14 + 22 * (k // cols)
        _marker(buf, lx, ly, leg["marker"], leg["rgb"])
        if text:
            A.render_text(buf, lx + 12, ly + 5, leg["label"], 13, "", ink)
    write_image(path, buf.get_pixels(oiio.FLOAT), bits=8, force=force)
    for leg in legend:
        del leg["rgb"]
    return legend, "" if text else "(No font available to OpenImageIO here: the plot has no text; read the " \
                                    "legend below. x axis: decades of seconds.)"


__all__ = ["plot_pareto"]
