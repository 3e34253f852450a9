"""A texture set in the browser: one self-contained HTML page that relights the maps with the project's renderer.

:func:`write_viewer` reads a texture set written in the project's own layout (its JSON sidecar and the files it
names) and writes ``<name>_view.html``: no network, no other file. The page shows

* the material at its own resolution under a point light that follows the pointer (the wheel moves the light up
  and down), rendered by a WebGL 2 fragment shader that is a port of :func:`svbrdf.runtime.core.render.shade` with the
  scene of :func:`svbrdf.runtime.core.render.render` (plane z = 0, pixel centres, +y up the image, camera at (0, 0, d),
  ``d = 1 / tan(fov / 2)``);
* the same maps repeated :data:`TILED_REPEATS` x :data:`TILED_REPEATS` on a larger plane, seen from
  ``TILED_REPEATS`` times higher with the same field of view (what a tileable set looks like on a wall);
* the four maps beside them (and the height and AO maps when the set has them).

Relief (a set with ``<name>_height`` and ``<name>_ao``, :meth:`~svbrdf.runtime.core.maps.Maps.with_relief`): the
*relief* control lifts each point of the plane to its height (``gain x (h - 0.5) x height_scale`` map widths; 1 =
the true scale the sidecar records, 0 = flat) and shows it by parallax offset mapping: the maps are read where the
view ray through the pixel meets that height, ``q = p + z v_xy / v_z``, and the point is shaded at ``q`` (one step;
exact for a locally flat height, a fair approximation for the shallow relief the network predicts). The *ambient*
control adds a uniform sky of radiance ``a x intensity / pi`` reflected by the diffuse albedo and occluded by the AO,
``a x intensity / pi x AO x rho_d``: the AO darkens only that ambient light, as in an engine, never the base
colour or the point light. With relief 0 and ambient 0 the page is exactly ``render``; the defaults are relief 1
and ambient 0.

The shaders and the page are package data files beside this module (``viewer_assets/``: ``shader.vert``,
``shader.frag``, ``page.html``), read with :mod:`importlib.resources`; :func:`viewer_html` fills their ``@NAME@``
placeholders.

One source of truth: the render settings (field of view, intensity, fall-off, diffuse weighting, geometry and
Fresnel terms) are the sidecar's ``brdf.render_config``, the normal convention its ``normal_convention``, and the
clamps (``ALPHA_MIN``, ``COS_EPS``, ``NORM_EPS``) are written into the shader from :mod:`svbrdf.runtime.core.render`.
The maps are embedded as the stored values (zlib-compressed, base64): the base colour as its 8-bit sRGB codes,
decoded in the shader with the exact sRGB curve (:mod:`svbrdf.runtime.core.colour`); normal, roughness and specular as
16-bit data. The page's output is ``srgb(clip(exposure * L, 0, 1))`` with ``L`` the linear radiance of
``render``; the default exposure is the relit panel's (:func:`svbrdf.runtime.outputs.texture_set.relit_panel`: the 99th
percentile of the flash render maps to 1). ``tests/runtime/outputs/test_viewer.py`` checks the shader against ``render``
in headless Chromium and headless Firefox, from a ``file://`` URL.

The URL's fragment sets the light and the exposure when the page opens (and when it changes), so that a view can
be shared or scripted: ``<name>_view.html#light=x,y,z&exposure=e`` (scene units as in ``setLight``; either part
may be left out). The caption under the material view is that link for the current view.

Without WebGL 2 (turned off, or refused for the graphics driver, as headless Firefox does on a machine without a
GPU unless told otherwise: tests/support/browser.py) the page says so in red above the views and still
shows the four maps.

Script API of the page (``window.svbrdfViewer``, for tests and automation): ``ready`` (a Promise),
``setLight(x, y, z)`` (scene units; renders both views at once), ``getLight()``, ``setExposure(e)``,
``getExposure()``, ``setRelief(gain)``, ``getRelief()``, ``setAmbient(a)``, ``getAmbient()``, ``relief`` (``null``, or
``{heightScale, height, ao}``: what the set has), ``config`` (the render config), ``size`` ([W, H] of the embedded maps)
and ``readPixels(view)`` (``"material"`` or ``"tiled"``: the view's RGBA bytes, top row first, base64).
"""

from __future__ import annotations

import base64
import html
import json
import zlib
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Optional, Tuple

import numpy as np

from ..errors import ImageError, SvbrdfError
from ..core.maps import MAP_NAMES, Maps, decode_normal, normal_dx_to_gl
from ..core.render import ALPHA_MIN, COS_EPS, NORM_EPS, RenderConfig

#: File name template of the page, beside the texture set's files.
VIEWER_FILE = "{name}_view.html"
#: Long side, in pixels, of the maps embedded in the page (larger sets are downsized for it).
VIEWER_SIZE = 1024
#: Repeats per side of the tiled view.
TILED_REPEATS = 3
#: The generic layout's file roles the page needs.
ROLES = ("basecolor", "normal", "roughness", "specular")
#: The relief roles the page shows when the set has them.
RELIEF_ROLES = ("height", "ao")

#: The page's data files (package data beside this module): the WebGL 2 vertex shader, the fragment shader (a port
#: of :func:`svbrdf.runtime.core.render.shade`, line by line with the same names, with the scene of ``render``) and
#: the page (HTML, style and script), with ``@NAME@`` placeholders that :func:`viewer_html` fills.
ASSETS = "viewer_assets"
VERTEX_FILE, FRAGMENT_FILE, PAGE_FILE = "shader.vert", "shader.frag", "page.html"

__all__ = ["VIEWER_FILE", "VIEWER_SIZE", "TILED_REPEATS", "read_texture_set", "viewer_html", "write_viewer",
           "write_maps_viewer"]


@lru_cache(maxsize=None)
def _asset(name: str) -> str:
    """The text of one of the page's data files (:data:`ASSETS`)."""
    return resources.files(__package__).joinpath(ASSETS, name).read_text(encoding="utf-8")


def _sidecar(path: Path) -> dict:
    try:
        meta = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise ImageError(f"{path}: cannot read the sidecar ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise ImageError(f"{path}: not a texture-set sidecar (invalid JSON: {exc})") from None
    if not isinstance(meta, dict) or "files" not in meta or "brdf" not in meta:
        raise ImageError(f"{path}: not a texture-set sidecar (no 'files' or 'brdf' entry)")
    if "target" in meta:
        raise ImageError(f"{path}: a --target {meta['target'].get('name', '?')} set; the viewer reads the "
                         f"project's own layout (--target generic)")
    missing = [r for r in ROLES if r not in meta["files"]]
    if missing:
        raise ImageError(f"{path}: the viewer needs all four maps; this set has no {', '.join(missing)}")
    return meta


def _stored(sidecar_path: Path, meta: dict) -> Tuple[dict, RenderConfig, str]:
    """The stored values of each role ((H, W, C) float32 in [0, 1], as in the files), the config, the convention."""
    from ..io.images import read_image

    folder = Path(sidecar_path).parent
    stored = {}
    for role in ROLES + tuple(r for r in RELIEF_ROLES if r in meta["files"]):
        stored[role] = read_image(folder / meta["files"][role]["file"], raw=True)
    try:
        config = RenderConfig(**meta["brdf"]["render_config"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ImageError(f"{sidecar_path}: invalid brdf.render_config ({exc})") from None
    convention = meta.get("normal_convention", {}).get("name", "opengl")
    if convention not in ("opengl", "dx"):
        raise ImageError(f"{sidecar_path}: unknown normal convention {convention!r}")
    return stored, config, convention


def read_texture_set(sidecar_path) -> Tuple[Maps, RenderConfig]:
    """Read a texture set in the project's own layout from its sidecar, decoded as the project decodes it.

    Returns:
        ``(maps, config)``: :class:`Maps` (base colour sRGB-decoded to linear with the exact curve, normals
        ``2 v - 1`` renormalised and turned to OpenGL, roughness and specular as stored) and the sidecar's
        :class:`RenderConfig`.

    Raises:
        ImageError: not a generic sidecar with all four maps, or a file that cannot be read.
    """
    meta = _sidecar(Path(sidecar_path))
    stored, config, convention = _stored(Path(sidecar_path), meta)
    return _decoded(stored, convention, config), config


def _pack(arr: np.ndarray, bits: int) -> str:
    """(H, W, C) values in [0, 1] -> base64 of the zlib-compressed little-endian uint8/uint16 codes."""
    scale = 255.0 if bits == 8 else 65535.0
    codes = np.rint(np.clip(arr, 0.0, 1.0) * scale).astype("<u1" if bits == 8 else "<u2")
    return base64.b64encode(zlib.compress(np.ascontiguousarray(codes).tobytes(), 6)).decode("ascii")


def _downsized(stored: dict, size: int) -> dict:
    h, w = stored["basecolor"].shape[:2]
    if max(h, w) <= size:
        return stored
    from ..io.images import resize_long_side

    return {role: np.clip(resize_long_side(np.ascontiguousarray(a, dtype=np.float32), size), 0.0, 1.0)
            for role, a in stored.items()}


def viewer_html(stored: dict, config: RenderConfig, name: str, normal: str = "opengl",
                exposure: Optional[float] = None, note: str = "", height_scale: float = 0.0) -> str:
    """The page for the stored values of a texture set (see the module docstring).

    Args:
        stored: role (:data:`ROLES`) -> (H, W, C) float array of the values as stored in the files, in [0, 1]:
            the base colour sRGB-encoded (quantised to 8 bits here), the normal ``(n + 1) / 2``, roughness and
            specular linear (16 bits here); optionally ``"height"`` (white = high, 0.5 = the mean level) and ``"ao"``
            (1 = open), (H, W, 1) linear (16 bits here).
        config: the render settings (the sidecar's).
        name: the set's name (page title).
        normal: the stored normal convention, ``"opengl"`` or ``"dx"``.
        exposure: default exposure (linear scale before clipping); ``None``: 1.
        note: one line shown under the title (e.g. whether the maps tile).
        height_scale: the height black to white spans, in map widths (the sidecar's ``relief.height_scale``).
    """
    h, w = stored["basecolor"].shape[:2]
    data = {
        "width": w, "height": h,
        "basecolor": _pack(stored["basecolor"][..., :3], 8),
        "normal": _pack(stored["normal"][..., :3], 16),
        "roughness": _pack(stored["roughness"][..., :1], 16),
        "specular": _pack(stored["specular"][..., :1], 16),
    }
    relief = None
    if any(r in stored for r in RELIEF_ROLES):
        relief = {"heightScale": float(height_scale), "height": "height" in stored, "ao": "ao" in stored}
        for role in RELIEF_ROLES:
            if role in stored:
                data[role + "_map"] = _pack(stored[role][..., :1], 16)  # "height" is the size
    settings = {
        "config": config.to_dict(), "cameraDistance": config.camera_distance, "normal": normal,
        "exposure": 1.0 if exposure is None else float(exposure), "repeats": TILED_REPEATS, "relief": relief,
    }
    shader = _asset(FRAGMENT_FILE).replace("@ALPHA_MIN@", repr(float(ALPHA_MIN)))
    shader = shader.replace("@COS_EPS@", repr(float(COS_EPS))).replace("@NORM_EPS@", repr(float(NORM_EPS)))
    page = _asset(PAGE_FILE).replace("@TITLE@", html.escape(name)).replace("@NOTE@", html.escape(note))
    page = page.replace("@SETTINGS@", json.dumps(settings)).replace("@DATA@", json.dumps(data))
    page = page.replace("@FRAGMENT@", shader).replace("@VERTEX@", _asset(VERTEX_FILE))
    return page


def _default_exposure(maps: Maps, config: RenderConfig) -> float:
    """The relit panel's exposure: the 99th percentile of the flash render maps to 1."""
    from ..core.render import render

    p99 = float(np.percentile(render(maps, None, config), 99))
    return 1.0 / p99 if p99 > 0 else 1.0


def _tileable_note(tiled) -> str:
    return (f"tileable maps ({tiled.get('method')})" if isinstance(tiled, dict)
            else "these maps were not made tileable (svbrdf-preview --tileable): the repeats show seams")


def _write_page(page: str, out: Path, force: bool) -> Path:
    from ..io.files import atomic_write

    with atomic_write(out, force=force, error=ImageError) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return out


def write_viewer(sidecar_path, out: Optional[Path] = None, *, force: bool = False,
                 size: Optional[int] = VIEWER_SIZE) -> Path:
    """Write the viewer page of the texture set described by ``sidecar_path`` (module docstring).

    Args:
        sidecar_path: ``<name>.json`` of a set in the project's own layout with all four maps.
        out: the page (default: :data:`VIEWER_FILE` beside the sidecar).
        force: overwrite an existing page.
        size: long side of the embedded maps (larger sets are downsized; ``None``: as stored).

    Returns:
        The written path.

    Raises:
        ImageError: not such a sidecar, a file cannot be read, or the page exists and not ``force``.
    """
    sidecar_path = Path(sidecar_path)
    meta = _sidecar(sidecar_path)
    stored, config, convention = _stored(sidecar_path, meta)
    if size is not None:
        stored = _downsized(stored, size)
    maps, _ = read_texture_set(sidecar_path)
    if size is not None and max(maps.shape) > size:
        maps = _decoded(stored, convention)
    relief = meta.get("relief") if isinstance(meta.get("relief"), dict) else {}
    page = viewer_html(stored, config, str(meta.get("name") or sidecar_path.stem), convention,
                       _default_exposure(maps, config), _tileable_note((meta.get("meta") or {}).get("tileable")),
                       float(relief.get("height_scale") or 0.0))
    out = Path(out) if out is not None else sidecar_path.parent / VIEWER_FILE.format(name=sidecar_path.stem)
    return _write_page(page, out, force)


def _decoded(stored: dict, convention: str = "opengl", config: Optional[RenderConfig] = None) -> Maps:
    """The :class:`Maps` of stored values (as :func:`read_texture_set` decodes the files)."""
    from ..core.colour import srgb_to_linear

    normal = decode_normal(stored["normal"][..., :3])
    return Maps(diffuse=srgb_to_linear(stored["basecolor"][..., :3]), specular=stored["specular"][..., :1],
                roughness=stored["roughness"][..., :1], normal=normal_dx_to_gl(normal) if convention == "dx" else normal,
                render_config=config)


def write_maps_viewer(maps: Maps, out: Path, *, name: str, config: Optional[RenderConfig] = None,
                      force: bool = False, size: Optional[int] = VIEWER_SIZE) -> Path:
    """Write the viewer page of ``maps`` in memory, whatever layout their files were written in (a ``--target``
    set): the same page :func:`write_viewer` makes of the project's own files, from the values those files would
    store (base colour sRGB-encoded, normals ``(n + 1) / 2`` in OpenGL's convention, roughness and specular
    clipped to their ranges; the relief maps when ``maps.relief`` has them).

    Args:
        maps: all four maps (and optionally their relief).
        out: the page's path.
        name: the set's name (page title).
        config: the render settings (default ``maps.render_config``, else the renderer's default).
        force: overwrite an existing page.
        size: long side of the embedded maps (larger sets are downsized; ``None``: as they are).

    Raises:
        ImageError: the page exists and not ``force``, or it cannot be written.
        ValueError: a map is missing.
    """
    from ..core.colour import linear_to_srgb
    from .texture_set import GENERIC_FILES, file_rows

    maps.require(what="the viewer")
    config = config or maps.render_config or RenderConfig()
    stored = {role: file_rows(name, "opengl", getattr(maps, name)) for role, (name, _) in GENERIC_FILES.items()}
    stored["basecolor"] = np.clip(linear_to_srgb(stored["basecolor"]), 0.0, 1.0)
    height_scale = 0.0
    if maps.relief is not None:
        height_scale = float(maps.relief.scale)
        stored.update({role: getattr(maps.relief, role)[..., None] for role in maps.relief.names})
    stored = {role: np.asarray(a, np.float32) for role, a in stored.items()}
    if size is not None:
        stored = _downsized(stored, size)
    page = viewer_html(stored, config, name, "opengl", _default_exposure(_decoded(stored), config),
                       _tileable_note(maps.meta.get("tileable")), height_scale)
    return _write_page(page, Path(out), force)
