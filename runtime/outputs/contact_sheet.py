"""The contact sheet of a material library (:mod:`svbrdf.runtime.batch`): ``index.html`` and ``index.png``.

Each material is shown as one strip of small views (:func:`strip`, :data:`STRIP_VIEWS`), saved by the batch as
``thumbs/<name>.png``. ``index.html`` is one self-contained page (inline CSS and JavaScript, relative links only,
so it opens from disk with no server): a table of every photo with its strip, status and scores, sorted worst
first by the re-render error and sortable by any column with a click; a material whose set holds a viewer page
(``svbrdf-batch --view``, :data:`svbrdf.runtime.outputs.viewer.VIEWER_FILE`) gets a "view" link to it beside its name.
``index.png`` stacks the same strips with each material's name and scores drawn beside it (OpenImageIO; no text
where it has no usable font), worst first, at most :data:`PNG_ROWS` rows.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional
from urllib.parse import quote

import numpy as np

#: The views of a strip, left to right.
STRIP_VIEWS = ("photo", "basecolor", "normal", "roughness", "specular", "relit")
#: Side of one view of a strip, in pixels.
THUMB = 128
#: Most rows of ``index.png`` (the worst materials first).
PNG_ROWS = 200
LABEL_WIDTH = 260


def _fit(image: np.ndarray, size: int = THUMB) -> np.ndarray:
    """An (H, W, 3) image in [0, 1] downsized into a ``size`` x ``size`` square (aspect kept, centred on grey)."""
    from ..io.images import resize_long_side

    image = np.clip(resize_long_side(np.ascontiguousarray(image, dtype=np.float32), size), 0.0, 1.0)
    out = np.full((size, size, 3), 0.2, dtype=np.float32)
    h, w = image.shape[:2]
    y, x = (size - h) // 2, (size - w) // 2
    out[y:y + h, x:x + w] = image
    return out


def strip(photo: np.ndarray, maps, relit: Optional[np.ndarray]) -> np.ndarray:
    """The views of :data:`STRIP_VIEWS` side by side: (THUMB, 6 THUMB, 3) float32, sRGB-encoded in [0, 1].

    Args:
        photo: (H, W, 3) linear photo.
        maps: :class:`~svbrdf.runtime.core.maps.Maps` (missing maps are shown as a dark tile).
        relit: the relit panel (:func:`svbrdf.runtime.outputs.texture_set.relit_panel`, sRGB, three views); its second view
            (a light from the upper left) is shown, or a dark tile when None.
    """
    from ..core.colour import linear_to_srgb
    from ..core.maps import encode_normal

    blank = np.full((THUMB, THUMB, 3), 0.1, dtype=np.float32)

    def grey(a):
        return np.repeat(a, 3, axis=-1)

    views = [_fit(linear_to_srgb(photo, clip=True))]
    views.append(_fit(linear_to_srgb(maps.diffuse, clip=True)) if maps.diffuse is not None else blank)
    views.append(_fit(encode_normal(maps.normal)) if maps.normal is not None else blank)
    views.append(_fit(grey(maps.roughness)) if maps.roughness is not None else blank)
    views.append(_fit(grey(linear_to_srgb(maps.specular, clip=True))) if maps.specular is not None else blank)
    if relit is not None:
        w = relit.shape[1] // 3
        views.append(_fit(relit[:, w:2 * w]))
    else:
        views.append(blank)
    return np.concatenate(views, axis=1)


def _rows(records: Mapping[str, Mapping[str, Any]]) -> List[Dict[str, Any]]:
    """One row per record, worst first: failed, then by re-render RMSE (highest first), then by name."""
    rows = []
    for name, rec in records.items():
        scores = rec.get("scores") or {}
        rows.append({"name": name, "status": rec.get("status", "?"), "source": rec.get("source", ""),
                     "rmse": scores.get("rerender_rmse"), "burn_in": scores.get("burn_in"),
                     "seconds": (rec.get("timings") or {}).get("total"), "error": rec.get("error") or "",
                     "refine": bool((rec.get("options") or {}).get("refine"))})
    rows.sort(key=lambda r: (r["status"] == "done", -(r["rmse"] if r["rmse"] is not None else np.inf), r["name"]))
    return rows


def _num(v: Optional[float], fmt: str) -> str:
    return "" if v is None else format(v, fmt)


def render_html(root: Path, records: Mapping[str, Mapping[str, Any]]) -> str:
    """The text of ``index.html`` for the library ``root`` (see the module docstring)."""
    from .viewer import VIEWER_FILE

    rows = _rows(records)
    body = []
    for i, r in enumerate(rows, 1):
        link = quote(r["name"])
        page = VIEWER_FILE.format(name=r["name"])
        view = f' <a class="view" href="{link}/{quote(page)}">view</a>' if (root / r["name"] / page).is_file() \
            else ""
        thumb = f"thumbs/{quote(r['name'])}.png"
        has_thumb = (root / "thumbs" / f"{r['name']}.png").is_file()
        img = f'<a href="{thumb}"><img src="{thumb}" alt="{html.escape(r["name"])}" loading="lazy"></a>' \
            if has_thumb else ""
        body.append(
            f'<tr class="{r["status"]}"><td data-v="{i}">{i}</td>'
            f'<td data-v="{html.escape(r["name"])}"><a href="{link}/">{html.escape(r["name"])}</a>{view}<br>'
            f'<small>{html.escape(r["source"])}</small></td>'
            f'<td>{img}</td><td data-v="{r["status"]}">{r["status"]}{" (refine)" if r["refine"] else ""}</td>'
            f'<td data-v="{_num(r["rmse"], ".6f") or -1}">{_num(r["rmse"], ".4f")}</td>'
            f'<td data-v="{_num(r["burn_in"], ".6f") or -1}">{_num(r["burn_in"], ".3f")}</td>'
            f'<td data-v="{_num(r["seconds"], ".3f") or -1}">{_num(r["seconds"], ".1f")}</td>'
            f'<td>{html.escape(r["error"])}</td></tr>')
    done = sum(r["status"] == "done" for r in rows)
    views = ", ".join(STRIP_VIEWS)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(root.name)}: material library</title>
<style>
body {{ font: 14px sans-serif; margin: 1em; }}
table {{ border-collapse: collapse; }}
th, td {{ border-bottom: 1px solid #ccc; padding: 4px 8px; text-align: left; vertical-align: middle; }}
th {{ cursor: pointer; background: #eee; position: sticky; top: 0; }}
tr.failed {{ background: #fdd; }}
img {{ height: 96px; image-rendering: auto; }}
</style></head><body>
<h1>{html.escape(root.name)}</h1>
<p>{len(rows)} photos, {done} done, {len(rows) - done} failed. Worst first (failed, then highest re-render RMSE);
click a column to sort. Strip: {views} (relit under a light from the upper left). RMSE: sRGB error of the maps
re-rendered under the photo's flash; burn-in: flash highlight left in the maps, as a disc or rings (the worst
map's score; 0.1-0.3 for a stationary material).</p>
<table id="lib"><thead><tr><th>#</th><th>material</th><th>{views}</th><th>status</th>
<th>re-render RMSE</th><th>burn-in</th><th>seconds</th><th>error</th></tr></thead>
<tbody>
{chr(10).join(body)}
</tbody></table>
<script>
document.querySelectorAll("#lib th").forEach(function (th, col) {{
  th.addEventListener("click", function () {{
    var tbody = document.querySelector("#lib tbody");
    var rows = Array.prototype.slice.call(tbody.rows);
    var down = th.dataset.dir !== "down";
    th.dataset.dir = down ? "down" : "up";
    rows.sort(function (a, b) {{
      var x = a.cells[col].dataset.v || a.cells[col].textContent, y = b.cells[col].dataset.v || b.cells[col].textContent;
      var nx = parseFloat(x), ny = parseFloat(y);
      var c = (!isNaN(nx) && !isNaN(ny)) ? nx - ny : x.localeCompare(y);
      return down ? -c : c;
    }});
    rows.forEach(function (r) {{ tbody.appendChild(r); }});
  }});
}});
</script>
</body></html>
"""


def render_png(root: Path, records: Mapping[str, Mapping[str, Any]]) -> Optional[np.ndarray]:
    """The ``index.png`` image (sRGB (rows x THUMB, LABEL_WIDTH + 6 THUMB, 3) float32), or None with no strip."""
    import OpenImageIO as oiio

    from ..io.images import read_image, text_supported

    rows = [r for r in _rows(records) if (root / "thumbs" / f"{r['name']}.png").is_file()][:PNG_ROWS]
    if not rows:
        return None
    row_h, width = THUMB + 4, LABEL_WIDTH + len(STRIP_VIEWS) * THUMB
    buf = oiio.ImageBuf(oiio.ImageSpec(width, row_h * len(rows), 3, oiio.FLOAT))
    oiio.ImageBufAlgo.fill(buf, (1.0, 1.0, 1.0))
    canvas = np.asarray(buf.get_pixels(oiio.FLOAT)).reshape(row_h * len(rows), width, 3).copy()
    for i, r in enumerate(rows):
        tile = read_image(root / "thumbs" / f"{r['name']}.png", raw=True)[..., :3]
        h, w = min(THUMB, tile.shape[0]), min(width - LABEL_WIDTH, tile.shape[1])
        canvas[i * row_h + 2:i * row_h + 2 + h, LABEL_WIDTH:LABEL_WIDTH + w] = tile[:h, :w]
    buf.set_pixels(oiio.ROI(), canvas)
    if text_supported():
        ink = (0.0, 0.0, 0.0)
        for i, r in enumerate(rows):
            y = i * row_h + 24
            oiio.ImageBufAlgo.render_text(buf, 8, y, r["name"][:30], 15, "", ink)
            oiio.ImageBufAlgo.render_text(buf, 8, y + 26, f"RMSE {_num(r['rmse'], '.4f') or '-'}", 14, "", ink)
            oiio.ImageBufAlgo.render_text(buf, 8, y + 48, f"burn-in {_num(r['burn_in'], '.3f') or '-'}", 14, "",
                                          ink)
            if r["status"] != "done":
                oiio.ImageBufAlgo.render_text(buf, 8, y + 70, r["status"], 14, "", (0.8, 0.0, 0.0))
    return np.asarray(buf.get_pixels(oiio.FLOAT)).reshape(row_h * len(rows), width, 3)


def write_contact_sheet(root: Path, records: Mapping[str, Mapping[str, Any]]) -> Dict[str, Path]:
    """Write (replace) ``root/index.html`` and ``root/index.png`` atomically; returns the paths written."""
    from ..io.files import atomic_write
    from ..io.images import write_image

    root = Path(root)
    out = {}
    with atomic_write(root / "index.html", force=True) as tmp:
        tmp.write_text(render_html(root, records), encoding="utf-8")
    out["html"] = root / "index.html"
    image = render_png(root, records)
    if image is not None:
        out["png"] = write_image(root / "index.png", image, bits=8, colour_space="sRGB", force=True)
    return out


__all__ = ["STRIP_VIEWS", "THUMB", "PNG_ROWS", "strip", "render_html", "render_png", "write_contact_sheet"]
