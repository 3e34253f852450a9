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

__all__ = ["VIEWER_FILE", "VIEWER_SIZE", "TILED_REPEATS", "read_texture_set", "viewer_html", "write_viewer",
           "write_maps_viewer"]


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
    shader = _FRAGMENT.replace("@ALPHA_MIN@", repr(float(ALPHA_MIN))).replace("@COS_EPS@", repr(float(COS_EPS)))
    shader = shader.replace("@NORM_EPS@", repr(float(NORM_EPS)))
    page = _PAGE.replace("@TITLE@", html.escape(name)).replace("@NOTE@", html.escape(note))
    page = page.replace("@SETTINGS@", json.dumps(settings)).replace("@DATA@", json.dumps(data))
    page = page.replace("@FRAGMENT@", shader).replace("@VERTEX@", _VERTEX)
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


_VERTEX = """#version 300 es
in vec2 aPos;
void main() { gl_Position = vec4(aPos, 0.0, 1.0); }
"""

# A port of svbrdf.runtime.core.render.shade, line by line (same names), with the scene of render().
_FRAGMENT = """#version 300 es
precision highp float;
precision highp int;
uniform sampler2D uTex0;   // rgb: base colour, sRGB codes / 255; a: specular (linear)
uniform sampler2D uTex1;   // rgb: stored normal (n + 1) / 2; a: roughness
uniform sampler2D uTex2;   // r: height (0.5 = mean level), g: ambient occlusion (1 = open); read when uHasRelief
uniform int uHasRelief;
uniform float uRelief;     // height gain: 0 flat, 1 the true scale
uniform float uHeightScale;  // the height black to white spans, map widths (= 2 scene units)
uniform float uAmbient;    // ambient sky radiance, in units of intensity / pi
uniform vec2 uSize;        // maps (W, H)
uniform vec2 uCanvas;      // drawing buffer (W, H)
uniform float uReps;       // plane half-width in half-photo-widths: 1 = the photo, N = N x N repeats
uniform int uExact;        // 1: one canvas pixel per map pixel, read with texelFetch
uniform vec3 uLight;
uniform float uCamD;       // d of the render config
uniform float uIntensity;
uniform int uFalloff;
uniform int uConserve;
uniform int uGeometry;     // 0 schlick, 1 smith
uniform int uFresnel;      // 0 schlick, 1 none
uniform float uDx;         // -1: stored normals are DirectX (y down)
uniform float uExposure;
out vec4 outColor;

const float PI = 3.141592653589793;
const float ALPHA_MIN = @ALPHA_MIN@;
const float COS_EPS = @COS_EPS@;
const float NORM_EPS = @NORM_EPS@;

vec3 normalize3(vec3 a) { return a * inversesqrt(dot(a, a) + NORM_EPS); }

float srgbToLinear(float c) { return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4); }
float linearToSrgb(float c) { return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055; }

void main() {
  vec2 fc = gl_FragCoord.xy;  // pixel centres, origin at the bottom left
  // render(): x = 2 (j + 0.5) / W - 1, y = (H / W)(1 - 2 (i + 0.5) / H), i counted from the top
  float x = uReps * (2.0 * fc.x / uCanvas.x - 1.0);
  float y = uReps * (2.0 * fc.y - uCanvas.y) / uCanvas.x;
  vec3 p = vec3(x, y, 0.0);
  vec3 cam = vec3(0.0, 0.0, uReps * uCamD);
  vec3 v = normalize(cam - p);
  bool lift = uHasRelief == 1 && uRelief != 0.0;
  vec4 t0, t1, t2 = vec4(0.5, 1.0, 0.0, 1.0);
  if (uExact == 1) {
    ivec2 ij = ivec2(int(fc.x), int(uSize.y) - 1 - int(fc.y));
    if (lift) {  // parallax offset: where the view ray meets the height z of this pixel
      float z = uRelief * uHeightScale * 2.0 * (texelFetch(uTex2, ij, 0).r - 0.5);
      p = vec3(p.xy + z * v.xy / v.z, z);
      ivec2 s = ivec2(uSize);
      ij = ivec2(floor(vec2((p.x + 1.0) * 0.5, (1.0 - p.y * uSize.x / uSize.y) * 0.5) * uSize));
      ij = ((ij % s) + s) % s;
    }
    t0 = texelFetch(uTex0, ij, 0);
    t1 = texelFetch(uTex1, ij, 0);
    if (uHasRelief == 1) t2 = texelFetch(uTex2, ij, 0);
  } else {
    vec2 uv = vec2((x + 1.0) * 0.5, (1.0 - y * uSize.x / uSize.y) * 0.5);  // repeats wrap (REPEAT)
    if (lift) {
      float z = uRelief * uHeightScale * 2.0 * (texture(uTex2, uv).r - 0.5);
      p = vec3(p.xy + z * v.xy / v.z, z);
      uv = vec2((p.x + 1.0) * 0.5, (1.0 - p.y * uSize.x / uSize.y) * 0.5);
    }
    t0 = texture(uTex0, uv);
    t1 = texture(uTex1, uv);
    if (uHasRelief == 1) t2 = texture(uTex2, uv);
  }
  vec3 diffuse = vec3(srgbToLinear(t0.r), srgbToLinear(t0.g), srgbToLinear(t0.b));
  float specular = t0.a;
  float roughness = t1.a;
  // decode_normal: 2 v - 1, z >= 0, unit length (a zero vector -> (0, 0, 1)); DirectX -> OpenGL
  vec3 nd = t1.rgb * 2.0 - 1.0;
  nd.y *= uDx;
  nd.z = max(nd.z, 0.0);
  float nlen = length(nd);
  vec3 n = nlen < 1e-8 ? vec3(0.0, 0.0, 1.0) : nd / nlen;

  vec3 ld = uLight - p;
  float light_dist2 = dot(ld, ld);
  vec3 l = ld / sqrt(light_dist2);

  // shade()
  n = normalize3(n);
  vec3 h = normalize3(v + l);
  float n_l = max(dot(n, l), COS_EPS);
  float n_v = max(dot(n, v), COS_EPS);
  float n_h = max(dot(n, h), COS_EPS);
  float v_h = max(dot(v, h), COS_EPS);
  float alpha = max(roughness * roughness, ALPHA_MIN);
  float a2 = alpha * alpha;
  float denom = n_h * n_h * (a2 - 1.0) + 1.0;
  float d_term = a2 / (PI * denom * denom);
  float vis;
  if (uGeometry == 0) {
    float k = alpha * 0.5;
    vis = 1.0 / ((n_l * (1.0 - k) + k) * (n_v * (1.0 - k) + k));
  } else {
    float g1_l = 2.0 / (1.0 + sqrt(a2 + (1.0 - a2) * n_l * n_l) / n_l);
    float g1_v = 2.0 / (1.0 + sqrt(a2 + (1.0 - a2) * n_v * n_v) / n_v);
    vis = g1_l * g1_v / (n_l * n_v);
  }
  float fres = uFresnel == 0 ? specular + (1.0 - specular) * exp2((-5.55473 * v_h - 6.98316) * v_h) : specular;
  float light = uIntensity * n_l;
  if (uFalloff == 1) { light = light * (uCamD * uCamD) / light_dist2; }
  float spec_radiance = light * fres * vis * d_term * 0.25;
  float diff_weight = light / PI;
  if (uConserve == 1) { diff_weight = diff_weight * (1.0 - specular); }
  vec3 radiance = diff_weight * diffuse + spec_radiance;
  radiance += (uAmbient * uIntensity / PI * t2.g) * diffuse;  // ambient sky, occluded by the AO (0 by default)

  vec3 c = clamp(radiance * uExposure, 0.0, 1.0);
  outColor = vec4(linearToSrgb(c.r), linearToSrgb(c.g), linearToSrgb(c.b), 1.0);
}
"""

_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>@TITLE@: svbrdf viewer</title>
<style>
body { font: 14px sans-serif; margin: 12px; background: #222; color: #ddd; }
#views { display: flex; gap: 16px; align-items: flex-start; flex-wrap: wrap; }
canvas { background: #000; display: block; cursor: crosshair; }
#tiled { width: 640px; }
#material { width: 320px; }
#maps { display: grid; grid-template-columns: 150px 150px; gap: 6px; }
#maps canvas { width: 150px; cursor: default; }
.cap { font-size: 12px; color: #aaa; margin: 2px 0 6px; }
#err { color: #f88; }
a { color: #aaa; }
</style></head><body>
<h2 style="margin:0 0 4px">@TITLE@</h2>
<div class="cap">@NOTE@. Move the pointer over a view to move the light; the wheel moves it up and down.</div>
<div id="err"></div>
<div id="views">
 <div><canvas id="tiled"></canvas><div class="cap">repeated <span id="reps"></span> x <span id="reps2"></span></div></div>
 <div><canvas id="material"></canvas><div class="cap">the material (one tile)</div>
  <div>exposure <input id="exp" type="range" min="-4" max="4" step="0.05" value="0"></div>
  <div id="reliefctl" style="display:none">relief <input id="relief" type="range" min="0" max="16" step="0.25"
   value="1"> <span id="reliefval"></span></div>
  <div id="ambientctl" style="display:none">ambient (AO) <input id="ambient" type="range" min="0" max="1"
   step="0.05" value="0"> <span id="ambientval"></span></div>
  <div class="cap"><a id="lightpos" href="#" title="this view's link (light and exposure)"></a></div></div>
 <div id="maps">
  <div><canvas id="m_basecolor"></canvas><div class="cap">base colour (sRGB)</div></div>
  <div><canvas id="m_normal"></canvas><div class="cap">normal</div></div>
  <div><canvas id="m_roughness"></canvas><div class="cap">roughness</div></div>
  <div><canvas id="m_specular"></canvas><div class="cap">specular (shown sRGB)</div></div>
  <div id="c_height" style="display:none"><canvas id="m_height"></canvas><div class="cap">height (white = high)</div></div>
  <div id="c_ao" style="display:none"><canvas id="m_ao"></canvas><div class="cap">ambient occlusion</div></div>
 </div>
</div>
<script id="vs" type="x-shader/x-vertex">@VERTEX@</script>
<script id="fs" type="x-shader/x-fragment">@FRAGMENT@</script>
<script>
"use strict";
(function () {
  var S = @SETTINGS@;
  var D = @DATA@;
  var W = D.width, H = D.height, d = S.cameraDistance;
  var light = [0, 0, d];
  var exposure = S.exposure;
  var R = S.relief;  // null, or {heightScale, height, ao}
  var relief = R && R.height ? 1 : 0, ambient = 0;
  var views = {};
  var resolveReady, rejectReady;
  var ready = new Promise(function (res, rej) { resolveReady = res; rejectReady = rej; });

  function fail(msg) { document.getElementById("err").textContent = msg; rejectReady(new Error(msg)); }

  // The maps are zlib streams (RFC 1950/1951), inflated here synchronously so that the page has drawn before its
  // load event: a browser's plain screenshot (chromium --headless --screenshot) shows the relit views.
  var LBASE = [3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163,
               195, 227, 258];
  var LEXTRA = [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0];
  var DBASE = [1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025, 1537, 2049,
               3073, 4097, 6145, 8193, 12289, 16385, 24577];
  var DEXTRA = [0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13];
  var CLORDER = [16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15];

  function inflate(src, size) {
    var out = new Uint8Array(size), n = 0, pos = 2, acc = 0, cnt = 0;  // past the 2-byte zlib header
    function fill(k) { while (cnt < k) { acc |= (pos < src.length ? src[pos] : 0) << cnt; pos++; cnt += 8; } }
    function take(k) { fill(k); var v = acc & ((1 << k) - 1); acc >>>= k; cnt -= k; return v; }
    function code(lengths) {  // canonical Huffman code -> lookup on the next `max` bits (LSB first): sym << 4 | len
      var max = 1, count = new Uint16Array(16), next = new Uint16Array(16), i, len, c;
      for (i = 0; i < lengths.length; i++) { count[lengths[i]]++; if (lengths[i] > max) max = lengths[i]; }
      count[0] = 0;
      for (c = 0, len = 1; len < 16; len++) { c = (c + count[len - 1]) << 1; next[len] = c; }
      var t = new Int32Array(1 << max);
      for (i = 0; i < lengths.length; i++) {
        len = lengths[i];
        if (!len) continue;
        var k = next[len]++, rev = 0;
        for (var b = 0; b < len; b++) { rev = (rev << 1) | (k & 1); k >>= 1; }
        for (var j = rev; j < t.length; j += 1 << len) t[j] = (i << 4) | len;
      }
      return {t: t, max: max};
    }
    function symbol(h) {
      fill(h.max);
      var e = h.t[acc & ((1 << h.max) - 1)];
      if (!(e & 15)) throw new Error("corrupt map data");
      acc >>>= e & 15; cnt -= e & 15;
      return e >> 4;
    }
    var fixedLit = new Uint8Array(288), fixedDist = new Uint8Array(30).fill(5);
    fixedLit.fill(8, 0, 144); fixedLit.fill(9, 144, 256); fixedLit.fill(7, 256, 280); fixedLit.fill(8, 280, 288);
    var last = 0;
    while (!last) {
      last = take(1);
      var type = take(2), lit, dist;
      if (type === 0) {  // stored: byte-aligned LEN, NLEN, then LEN bytes
        pos -= cnt >> 3; acc = 0; cnt = 0;
        var len = src[pos] | (src[pos + 1] << 8);
        out.set(src.subarray(pos + 4, pos + 4 + len), n); n += len; pos += 4 + len;
        continue;
      }
      if (type === 1) { lit = code(fixedLit); dist = code(fixedDist); }
      else if (type === 2) {
        var hlit = take(5) + 257, hdist = take(5) + 1, hclen = take(4) + 4, cl = new Uint8Array(19), i;
        for (i = 0; i < hclen; i++) cl[CLORDER[i]] = take(3);
        var clc = code(cl), lengths = new Uint8Array(hlit + hdist);
        for (i = 0; i < hlit + hdist;) {
          var s = symbol(clc), rep = 0, val = 0;
          if (s < 16) { lengths[i++] = s; continue; }
          if (s === 16) { val = lengths[i - 1]; rep = 3 + take(2); }
          else if (s === 17) rep = 3 + take(3);
          else rep = 11 + take(7);
          while (rep--) lengths[i++] = val;
        }
        lit = code(lengths.subarray(0, hlit)); dist = code(lengths.subarray(hlit));
      } else throw new Error("corrupt map data");
      for (;;) {
        var sym = symbol(lit);
        if (sym < 256) { out[n++] = sym; continue; }
        if (sym === 256) break;
        sym -= 257;
        var length = LBASE[sym] + take(LEXTRA[sym]), ds = symbol(dist), back = DBASE[ds] + take(DEXTRA[ds]);
        for (var m = 0; m < length; m++, n++) out[n] = out[n - back];
      }
    }
    if (n !== size) throw new Error("corrupt map data (" + n + " bytes, expected " + size + ")");
    return out;
  }

  function unpack(b64, bits, channels) {
    var bin = atob(b64), bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    var buf = inflate(bytes, W * H * channels * (bits / 8)).buffer;
    return bits === 8 ? new Uint8Array(buf) : new Uint16Array(buf);
  }

  function makeView(id, reps, exact, width, height) {
    var canvas = document.getElementById(id);
    canvas.width = width; canvas.height = height;
    var gl = canvas.getContext("webgl2", {antialias: false, preserveDrawingBuffer: true});
    if (!gl) throw new Error("this browser gives the page no WebGL 2 (turned off, or not offered for this " +
                             "graphics driver): the relit views cannot be drawn; the maps are shown");
    function compile(type, src) {
      var s = gl.createShader(type); gl.shaderSource(s, src.trim()); gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    }
    var prog = gl.createProgram();
    gl.attachShader(prog, compile(gl.VERTEX_SHADER, document.getElementById("vs").textContent));
    gl.attachShader(prog, compile(gl.FRAGMENT_SHADER, document.getElementById("fs").textContent));
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog));
    gl.useProgram(prog);
    var buf = gl.createBuffer();
    gl.bindBuffer(gl.ARRAY_BUFFER, buf);
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
    var loc = gl.getAttribLocation(prog, "aPos");
    gl.enableVertexAttribArray(loc);
    gl.vertexAttribPointer(loc, 2, gl.FLOAT, false, 0, 0);
    var linear = !exact && gl.getExtension("OES_texture_float_linear");
    return {gl: gl, prog: prog, canvas: canvas, reps: reps, exact: exact, linear: !!linear, tex: []};
  }

  function upload(view, unit, pixels) {
    var gl = view.gl, tex = gl.createTexture();
    gl.activeTexture(gl.TEXTURE0 + unit);
    gl.bindTexture(gl.TEXTURE_2D, tex);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, W, H, 0, gl.RGBA, gl.FLOAT, pixels);
    var f = view.linear ? gl.LINEAR : gl.NEAREST;
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, f);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, f);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.REPEAT);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.REPEAT);
    view.tex.push(tex);
  }

  function draw(view) {
    var gl = view.gl, p = view.prog, c = S.config;
    function u(name) { return gl.getUniformLocation(p, name); }
    gl.viewport(0, 0, view.canvas.width, view.canvas.height);
    gl.uniform1i(u("uTex0"), 0); gl.uniform1i(u("uTex1"), 1); gl.uniform1i(u("uTex2"), 2);
    gl.uniform1i(u("uHasRelief"), R ? 1 : 0);
    gl.uniform1f(u("uRelief"), R && R.height ? relief : 0);
    gl.uniform1f(u("uHeightScale"), R ? R.heightScale : 0);
    gl.uniform1f(u("uAmbient"), ambient);
    gl.uniform2f(u("uSize"), W, H);
    gl.uniform2f(u("uCanvas"), view.canvas.width, view.canvas.height);
    gl.uniform1f(u("uReps"), view.reps);
    gl.uniform1i(u("uExact"), view.exact ? 1 : 0);
    gl.uniform3f(u("uLight"), light[0], light[1], light[2]);
    gl.uniform1f(u("uCamD"), d);
    gl.uniform1f(u("uIntensity"), c.intensity);
    gl.uniform1i(u("uFalloff"), c.falloff ? 1 : 0);
    gl.uniform1i(u("uConserve"), c.diffuse_conservation ? 1 : 0);
    gl.uniform1i(u("uGeometry"), c.geometry === "smith" ? 1 : 0);
    gl.uniform1i(u("uFresnel"), c.fresnel === "none" ? 1 : 0);
    gl.uniform1f(u("uDx"), S.normal === "dx" ? -1 : 1);
    gl.uniform1f(u("uExposure"), exposure);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  function drawAll() {
    for (var k in views) draw(views[k]);
    document.getElementById("reliefval").textContent = relief.toFixed(2) + " x";
    document.getElementById("ambientval").textContent = ambient.toFixed(2);
    var l = light.map(function (v) { return v.toFixed(3); }), a = document.getElementById("lightpos");
    a.textContent = "light (" + l.join(", ") + "), exposure " + exposure.toFixed(3);
    a.href = "#light=" + l.join(",") + "&exposure=" + exposure.toFixed(3);
  }

  function showMap(id, rgbaOf) {
    var c = document.getElementById(id); c.width = W; c.height = H;
    var ctx = c.getContext("2d"), img = ctx.createImageData(W, H);
    for (var i = 0; i < W * H; i++) { var px = rgbaOf(i); img.data.set(px, 4 * i); }
    ctx.putImageData(img, 0, 0);
  }

  // #light=x,y,z (scene units) and exposure=e in the URL's fragment, e.g. view.html#light=-1.2,0.8,0.6&exposure=2
  function fromFragment() {
    var q = new URLSearchParams(location.hash.replace(/^#/, ""));
    var l = (q.get("light") || "").split(",").map(Number), e = Number(q.get("exposure"));
    if (l.length === 3 && l.every(isFinite)) light = l;
    if (q.has("exposure") && isFinite(e) && e > 0) {
      exposure = e; document.getElementById("exp").value = Math.log2(exposure);
    }
  }

  function lin2srgb(c) { return c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055; }

  function start() {
    var base = unpack(D.basecolor, 8, 3), nrm = unpack(D.normal, 16, 3);
    var rough = unpack(D.roughness, 16, 1), spec = unpack(D.specular, 16, 1);
    var t0 = new Float32Array(4 * W * H), t1 = new Float32Array(4 * W * H);
    for (var i = 0; i < W * H; i++) {
      t0[4 * i] = base[3 * i] / 255; t0[4 * i + 1] = base[3 * i + 1] / 255; t0[4 * i + 2] = base[3 * i + 2] / 255;
      t0[4 * i + 3] = spec[i] / 65535;
      t1[4 * i] = nrm[3 * i] / 65535; t1[4 * i + 1] = nrm[3 * i + 1] / 65535; t1[4 * i + 2] = nrm[3 * i + 2] / 65535;
      t1[4 * i + 3] = rough[i] / 65535;
    }
    // the maps first: they need no WebGL
    showMap("m_basecolor", function (i) { return [base[3 * i], base[3 * i + 1], base[3 * i + 2], 255]; });
    showMap("m_normal", function (i) { return [nrm[3 * i] >> 8, nrm[3 * i + 1] >> 8, nrm[3 * i + 2] >> 8, 255]; });
    showMap("m_roughness", function (i) { var g = rough[i] >> 8; return [g, g, g, 255]; });
    showMap("m_specular", function (i) { var g = Math.round(255 * lin2srgb(spec[i] / 65535)); return [g, g, g, 255]; });
    var t2 = null;
    if (R) {
      var hgt = R.height ? unpack(D.height_map, 16, 1) : null, occ = R.ao ? unpack(D.ao_map, 16, 1) : null;
      t2 = new Float32Array(4 * W * H);
      for (var i = 0; i < W * H; i++) {
        t2[4 * i] = hgt ? hgt[i] / 65535 : 0.5; t2[4 * i + 1] = occ ? occ[i] / 65535 : 1; t2[4 * i + 3] = 1;
      }
      if (hgt) {
        document.getElementById("c_height").style.display = "";
        document.getElementById("reliefctl").style.display = "";
        showMap("m_height", function (i) { var g = hgt[i] >> 8; return [g, g, g, 255]; });
      }
      if (occ) {
        document.getElementById("c_ao").style.display = "";
        document.getElementById("ambientctl").style.display = "";
        showMap("m_ao", function (i) { var g = occ[i] >> 8; return [g, g, g, 255]; });
      }
    }
    // the tiled view: one canvas pixel per map pixel up to 1200 px, else 1024 px wide
    var tw = S.repeats * W <= 1200 ? S.repeats * W : 1024, th = Math.round(tw * H / W);
    views.material = makeView("material", 1, true, W, H);
    views.tiled = makeView("tiled", S.repeats, false, tw, th);
    for (var k in views) { upload(views[k], 0, t0); upload(views[k], 1, t1); if (t2) upload(views[k], 2, t2); }
    document.getElementById("reps").textContent = S.repeats;
    document.getElementById("reps2").textContent = S.repeats;
    fromFragment();
    window.addEventListener("hashchange", function () { fromFragment(); drawAll(); });
    var slider = document.getElementById("exp");
    slider.value = Math.log2(exposure);
    slider.addEventListener("input", function () { exposure = Math.pow(2, parseFloat(slider.value)); drawAll(); });
    var rs = document.getElementById("relief"), am = document.getElementById("ambient");
    rs.value = relief; am.value = ambient;
    rs.addEventListener("input", function () { relief = parseFloat(rs.value); drawAll(); });
    am.addEventListener("input", function () { ambient = parseFloat(am.value); drawAll(); });
    Object.keys(views).forEach(function (k) {
      var v = views[k];
      v.canvas.addEventListener("pointermove", function (e) {
        var r = v.canvas.getBoundingClientRect();
        var fx = (e.clientX - r.left) / r.width, fy = (e.clientY - r.top) / r.height;
        light[0] = v.reps * (2 * fx - 1);
        light[1] = v.reps * (H / W) * (1 - 2 * fy);
        drawAll();
      });
      v.canvas.addEventListener("wheel", function (e) {
        e.preventDefault();
        light[2] = Math.max(0.05, light[2] * (e.deltaY > 0 ? 1.1 : 1 / 1.1));
        drawAll();
      }, {passive: false});
    });
    drawAll();
  }

  window.svbrdfViewer = {
    ready: ready, config: S.config, size: [W, H], cameraDistance: d,
    setLight: function (x, y, z) { light = [+x, +y, +z]; drawAll(); return light.slice(); },
    getLight: function () { return light.slice(); },
    setExposure: function (e) { exposure = +e; document.getElementById("exp").value = Math.log2(exposure); drawAll(); },
    getExposure: function () { return exposure; },
    relief: R,
    setRelief: function (g) { relief = +g; document.getElementById("relief").value = relief; drawAll(); },
    getRelief: function () { return relief; },
    setAmbient: function (a) { ambient = +a; document.getElementById("ambient").value = ambient; drawAll(); },
    getAmbient: function () { return ambient; },
    readPixels: function (which) {
      var v = views[which || "material"], gl = v.gl, w = v.canvas.width, h = v.canvas.height;
      draw(v);
      var px = new Uint8Array(4 * w * h);
      gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
      var rows = new Uint8Array(4 * w * h);  // top row first, as an image file
      for (var y = 0; y < h; y++) rows.set(px.subarray(4 * w * (h - 1 - y), 4 * w * (h - y)), 4 * w * y);
      var s = "", chunk = 0x8000;
      for (var i = 0; i < rows.length; i += chunk) s += String.fromCharCode.apply(null, rows.subarray(i, i + chunk));
      return btoa(s);
    }
  };
  try { start(); resolveReady(true); } catch (e) { fail("viewer: " + e.message); }  // drawn before the load event
})();
</script>
</body></html>
"""
