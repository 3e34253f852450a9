"""Writing a texture set (the four maps, a JSON sidecar, an optional relit preview) and the relit panel.

Files written by :func:`write_texture_set` into ``out_dir`` for a set called ``name``:

======================  ===========================================  ======================================
file                    content                                      encoding
======================  ===========================================  ======================================
<name>_basecolor.png    diffuse albedo                               sRGB-encoded, 8-bit PNG
<name>_normal.<ext>     unit normals, OpenGL (default) or DirectX    (n + 1) / 2, data
<name>_roughness.<ext>  perceptual roughness r (GGX alpha = r**2)    linear data, 1 channel
<name>_specular.<ext>   specular albedo rho_s (grey Schlick F0)      linear, 1 channel
<name>_height.<ext>     height from the normal map (``maps.relief``)  linear data, 1 channel; white = high,
                        0.5 = the mean level; the sidecar's           ``h = (v - 0.5) * height_scale`` in
                        ``relief.height_scale`` gives the span        units of the map's width
<name>_ao.<ext>         ambient occlusion of that height              linear data, 1 channel, 1 = open
<name>.json             sidecar: BRDF model, render config, files,   JSON
                        colour spaces, normal convention, metadata
<name>_relit.png        optional preview (see :func:`relit_panel`)   sRGB-encoded, 8-bit PNG
======================  ===========================================  ======================================

``<ext>`` is ``png`` (16-bit) by default or ``exr`` (32-bit float). Maps are clipped to their valid range
(:meth:`Maps.clipped`) before writing. The height and AO files are written when the maps carry their relief
(:func:`~svbrdf.runtime.core.relief.with_relief`, what ``svbrdf-preview`` does by default); the base colour is never
darkened by the AO. A :class:`Maps` holding a subset of the maps writes only their files;
the sidecar's ``"maps"`` lists the maps written.

How it is written: a layout (this module's :func:`generic_layout`, or a ``--target`` preset of
:mod:`svbrdf.runtime.outputs.targets`) turns the maps into a *plan*, file role -> :class:`TextureFile` (an image with
its bit depth and colour encoding, or a document), and :func:`commit` writes any plan all or nothing.

Safety: if a file of the plan exists and ``force`` is false, an :class:`~svbrdf.runtime.errors.ImageError`
names it and nothing is written. The files are first written into a hidden staging folder inside ``out_dir``
and then moved into place (:func:`svbrdf.runtime.io.files.staged_write`), so a failure never leaves half a set.
The files of a plan are encoded concurrently (:data:`WRITE_WORKERS` threads): OpenImageIO releases the GIL
while it compresses (decision: docs/decisions/015-texture-set-writes.md).

The relit panel (:func:`relit_panel`) is rendered at its display size, :data:`PANEL_SIZE` pixels on the long
side of each view, from maps downsized for it: a side-by-side panel is looked at, not measured
(015-texture-set-writes.md).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
from concurrent.futures import ThreadPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, Mapping, Optional, Sequence, Union

import numpy as np

from ..core.colour import linear_to_srgb
from ..core.filters import all_finite
from ..errors import ImageError
from ..io.files import staged_write
from ..io.images import write_image
from ..core.maps import MAP_RANGES, SUPPORTED_NORMAL_CONVENTIONS, Maps, encode_normal, normal_gl_to_dx, normalize_normals
from ..core.render import ZHAO, RenderConfig, novel_lights, render

#: Sidecar format version (bump when keys change meaning).
SIDECAR_VERSION = 1
#: File name templates of the sidecar and the relit preview, shared by every layout (``{name}``: the set).
SIDECAR_FILE = "{name}.json"
RELIT_FILE = "{name}_relit.png"
#: Long side, in pixels, of each view of the relit panel (smaller sets keep their size; ``None``: full size).
PANEL_SIZE = 512
#: Threads that encode the files of a plan (1: one after the other).
WRITE_WORKERS = 2

_NORMAL_AXES = {
    "opengl": "+x right, +y up the image (green up), +z out of the surface",
    "dx": "+x right, +y down the image (green down, DirectX), +z out of the surface",
}


@dataclass(frozen=True)
class TextureFile:
    """One file of a texture-set plan: an image (``pixels``) or a document (``text``).

    Attributes:
        file: file name inside the output folder.
        info: its entry in the sidecar's ``"files"`` (content, colour space, bits, ...; ``"file"`` is added).
        pixels: image as (H, W, C) float, C in 1, 3, 4 (see :func:`~svbrdf.runtime.io.images.write_image`).
        bits: bit depth of the image (PNG 8 or 16, EXR 16 or 32).
        srgb: the image is linear colour to sRGB-encode (RGB only; alpha stays linear); otherwise the values
            are stored as given (data maps, or an image already sRGB-encoded).
        text: a document (glTF, USD, MaterialX, the sidecar), written as UTF-8.
        transform: applied to each strip of ``pixels`` as it is written (clipping, the normals' encoding), so a
            layout takes no full-size copy of a map (``transform`` of :func:`~svbrdf.runtime.io.images.write_image`).
    """

    file: str
    info: Mapping[str, Any]
    pixels: Optional[np.ndarray] = None
    bits: int = 8
    srgb: bool = False
    text: Optional[str] = None
    transform: Optional[Callable[[np.ndarray], np.ndarray]] = None


@dataclass(frozen=True)
class Layout:
    """What a layout makes of a texture set: its files and what the sidecar says about them.

    Attributes:
        files: role -> file, in the order the sidecar lists them (sidecar and relit preview excluded).
        normal: normal convention on disk, ``"opengl"`` or ``"dx"``.
        target: the sidecar's ``"target"`` entry (``None`` for the project's own layout: no entry).
    """

    files: Mapping[str, TextureFile]
    normal: str
    target: Optional[Mapping[str, Any]] = None


#: The project's own layout: role -> (map, file name template; ``{ext}`` is the format of the data maps).
GENERIC_FILES: Mapping[str, tuple] = {
    "basecolor": ("diffuse", "{name}_basecolor.png"),
    "normal": ("normal", "{name}_normal.{ext}"),
    "roughness": ("roughness", "{name}_roughness.{ext}"),
    "specular": ("specular", "{name}_specular.{ext}"),
}
#: The relief maps' files in the project's own layout: relief map -> file name template.
RELIEF_FILES: Mapping[str, str] = {"height": "{name}_height.{ext}", "ao": "{name}_ao.{ext}"}


def relief_file_info(relief, bits: int, channels: int = 1, **more) -> Dict[str, dict]:
    """The sidecar ``files`` entries of the relief maps present in ``relief`` (a
    :class:`~svbrdf.runtime.core.relief.Relief`), by relief map name."""
    out = {}
    if relief.height is not None:
        out["height"] = {"map": "height", "content": "height from the normal map, white = high, 0.5 = mean level",
                         "colour_space": "data", "bits": bits, "channels": channels,
                         "encoding": "h = (value - 0.5) * height_scale (map widths)",
                         "height_scale": relief.scale, **more}
    if relief.ao is not None:
        out["ao"] = {"map": "ao", "content": "ambient occlusion of the height, 1 = open", "colour_space": "data",
                     "bits": bits, "channels": channels, **more}
    return out


def _json_default(obj):
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return dataclasses.asdict(obj)
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    raise TypeError(f"value of type {type(obj).__name__}")


def _brdf_description(config: RenderConfig) -> dict:
    geometry = {
        "schlick": "Smith-Schlick, k = alpha / 2",
        "smith": "exact separable Smith GGX",
    }[config.geometry]
    fresnel = {
        "schlick": "Schlick (spherical-Gaussian exponent), F0 = specular",
        "none": "F = F0 = specular",
    }[config.fresnel]
    return {
        "model": "Cook-Torrance microfacet + Lambert diffuse",
        "distribution": "GGX",
        "alpha": "roughness ** 2",
        "geometry": geometry,
        "fresnel": fresnel,
        "diffuse": "(1 - specular) * diffuse / pi" if config.diffuse_conservation else "diffuse / pi",
        "render_config": config.to_dict(),
    }


def generic_layout(maps: Maps, name: str, normal: str = "opengl", fmt: str = "png") -> Layout:
    """The project's own layout (module docstring) of the maps present in ``maps``, clipped to their ranges as they
    are written (strip by strip: no full-size copy).

    Args:
        maps: the texture set (unclipped: each file clips and encodes its rows as it is written).
        name: base name of the files.
        normal: normal convention on disk, ``"opengl"`` or ``"dx"``.
        fmt: ``"png"`` (16-bit) or ``"exr"`` (32-bit float) for the data maps.
    """
    data_bits = 16 if fmt == "png" else 32
    info = {
        "basecolor": {"map": "diffuse", "colour_space": "sRGB", "bits": 8},
        "normal": {"map": "normal", "colour_space": "data", "bits": data_bits, "encoding": "(n + 1) / 2",
                   "convention": normal},
        "roughness": {"map": "roughness", "colour_space": "data", "bits": data_bits, "alpha": "roughness ** 2"},
        "specular": {"map": "specular", "colour_space": "linear", "bits": data_bits},
    }
    files = {}
    for role, (map_name, template) in GENERIC_FILES.items():
        arr = getattr(maps, map_name)
        if arr is None:
            continue
        bits = 8 if role == "basecolor" else data_bits
        files[role] = TextureFile(template.format(name=name, ext=fmt), info[role], arr, bits,
                                  srgb=role == "basecolor", transform=functools.partial(file_rows, map_name, normal))
    if maps.relief is not None:
        for role, entry in relief_file_info(maps.relief, data_bits).items():
            files[role] = TextureFile(RELIEF_FILES[role].format(name=name, ext=fmt), entry,
                                      getattr(maps.relief, role)[..., None], data_bits)
    return Layout(files, normal)


def file_rows(map_name: str, normal: str, rows: np.ndarray) -> np.ndarray:
    """Rows of a map as its file stores them (before the base colour's sRGB encoding): clipped to the map's range (:meth:`Maps.clipped`), normals made unit
    length and encoded ``(n + 1) / 2`` in ``normal``'s convention."""
    out = np.clip(rows, *MAP_RANGES[map_name])
    if map_name == "normal":
        out = normalize_normals(out)
        out = encode_normal(normal_gl_to_dx(out) if normal == "dx" else out)
    return out


def commit(out_dir, plan: Mapping[str, TextureFile], *, force: bool = False) -> Dict[str, Path]:
    """Write a plan (role -> :class:`TextureFile`) into ``out_dir``, all or nothing.

    The files are written into a hidden staging folder inside ``out_dir`` (created with its parents when
    missing), :data:`WRITE_WORKERS` at a time, and moved into place, in the plan's order, once all were
    written (:func:`~svbrdf.runtime.io.files.staged_write`). When several writes fail, the error of the first
    file in plan order is raised.

    Returns:
        Paths written, keyed by role.

    Raises:
        ImageError: a file exists (and not ``force``), ``out_dir`` is not a folder, or a write failed. The
            message names the target file; nothing is left behind.
    """
    out_dir = Path(out_dir)
    with staged_write(out_dir, [f.file for f in plan.values()], force=force, error=ImageError) as stage:
        workers = max(1, min(WRITE_WORKERS, len(plan)))
        if workers == 1:
            for f in plan.values():
                _write_file(stage, f)
        else:
            with ThreadPoolExecutor(workers) as pool:  # leaving the block waits for every write
                jobs = [pool.submit(_write_file, stage, f) for f in plan.values()]
            for job in jobs:
                job.result()
    return {role: out_dir / f.file for role, f in plan.items()}


def _write_file(folder: Path, f: TextureFile) -> None:
    """Write one file of a plan into ``folder``."""
    if f.text is not None:
        (folder / f.file).write_text(f.text, encoding="utf-8")
    else:
        write_image(folder / f.file, f.pixels, bits=f.bits, srgb_encode=f.srgb,
                    colour_space="sRGB" if f.srgb or f.info.get("colour_space") == "sRGB" else "linear",
                    transform=f.transform)


def write_layout(
    maps: Maps,
    out_dir,
    name: str,
    layout: Callable[[Maps, RenderConfig], Layout],
    *,
    force: bool = False,
    extra_meta: Optional[dict] = None,
    relit: Union[None, np.ndarray, Callable[[], np.ndarray]] = None,
    relief: Optional[Callable[[Maps], Maps]] = None,
) -> Dict[str, Path]:
    """Check the inputs, plan a texture set with ``layout`` (plus the sidecar and the relit preview) and
    :func:`commit` it. The writer behind :func:`write_texture_set` and
    :func:`~svbrdf.runtime.outputs.targets.write_target`; their docs give the arguments.

    Args:
        layout: ``layout(maps, config) -> Layout`` with ``config`` the maps' render config (``ZHAO`` when
            ``maps.render_config`` is ``None``).
        relit: the relit panel, or a function that returns it (called on a writer thread).
        relief: a function returning ``maps`` with their relief (``lambda m: with_relief(m)``), called on the
            calling thread while the layout's files of ``maps`` are written; the files the layout adds for the
            relief, the sidecar and the relit panel follow.
            The layout must only add files for the relief (the project's own layout does; a target that packs the
            AO into another file gets maps that carry their relief instead: ``ValueError``). Still all or nothing,
            but for a file of ``out_dir`` that appears while the last files are moved into place.
    """
    out_dir = Path(out_dir)
    if not name or name in (".", "..") or "/" in name or os.sep in name:
        raise ImageError(f"{out_dir}: invalid texture-set name {name!r}")
    if out_dir.exists() and not out_dir.is_dir():
        raise ImageError(f"{out_dir}: exists and is not a folder")
    for map_name, arr in maps.items():
        if not all_finite(arr):
            raise ImageError(f"{out_dir / name}: map {map_name!r} has NaN/Inf values")
    _check_relief(maps, out_dir / name)
    if relit is not None and not callable(relit):
        relit = _relit_pixels(relit)
    config = maps.render_config or ZHAO
    if relief is not None:
        return _write_beside_relief(maps, out_dir, name, layout, config, relief, force, extra_meta, relit)
    plan = layout(maps, config)
    if callable(relit):
        relit = _relit_pixels(relit())
    ordered = {**plan.files, "sidecar": _sidecar(maps, name, plan, config, extra_meta, relit is not None)}
    if relit is not None:
        ordered["relit"] = _relit_file(name, relit)
    return commit(out_dir, ordered, force=force)


def _check_relief(maps: Maps, where: Path) -> None:
    if maps.relief is not None:
        for map_name in maps.relief.names:
            if not all_finite(getattr(maps.relief, map_name)):
                raise ImageError(f"{where}: relief map {map_name!r} has NaN/Inf values")


def _relit_pixels(relit) -> np.ndarray:
    relit = np.asarray(relit, dtype=np.float32)
    if relit.ndim != 3 or relit.shape[-1] != 3:
        raise ValueError(f"relit must be (h, w, 3), got {relit.shape}")
    return np.clip(relit, 0.0, 1.0)


_RELIT_INFO = {"colour_space": "sRGB", "bits": 8, "content": "renders under the flash and novel lights, side by side"}


def _relit_file(name: str, pixels: Optional[np.ndarray]) -> TextureFile:
    return TextureFile(RELIT_FILE.format(name=name), _RELIT_INFO, pixels, bits=8)


def _sidecar(maps: Maps, name: str, plan: Layout, config: RenderConfig, extra_meta: Optional[dict],
             relit: bool) -> TextureFile:
    """The sidecar of ``maps`` written with ``plan`` (and the relit panel)."""
    files = dict(plan.files)
    if relit:
        files["relit"] = _relit_file(name, None)
    h, w = maps.shape
    sidecar = {
        "format_version": SIDECAR_VERSION,
        "name": name,
        "size": {"width": w, "height": h},
        "maps": list(maps.names),
        "brdf": _brdf_description(config),
        "normal_convention": {"name": plan.normal, "axes": _NORMAL_AXES[plan.normal]},
        "files": {role: {"file": f.file, **f.info} for role, f in files.items()},
        "meta": {k: v for k, v in {**maps.meta, **(extra_meta or {})}.items() if k != "camera"},
    }
    if "camera" in maps.meta:  # the photo's camera (fov_deg, fov_source): brdf.render_config has the same fov_deg
        sidecar["camera"] = maps.meta["camera"]
    if maps.relief is not None:
        sidecar["relief"] = maps.relief.info()
    if plan.target is not None:
        sidecar["target"] = dict(plan.target)
    try:
        text = json.dumps(sidecar, indent=2, default=_json_default, allow_nan=False) + "\n"
    except (TypeError, ValueError) as exc:  # e.g. an arbitrary object or a NaN timing in the metadata
        raise ValueError(f"sidecar metadata is not JSON-serialisable: {exc}") from None
    return TextureFile(SIDECAR_FILE.format(name=name), {}, text=text)


def _settle(jobs) -> None:
    """Cancel the jobs not started and wait for the others."""
    for job in jobs:
        job.cancel()
    wait(jobs)


def _write_beside_relief(maps: Maps, out_dir: Path, name: str, layout, config: RenderConfig,
                         relief: Callable[[Maps], Maps], force: bool, extra_meta: Optional[dict], relit) -> Dict[str, Path]:
    """:func:`write_layout` with ``relief``: the layout's files of ``maps`` on the writers' threads while ``relief``
    runs here, then the files it adds (staged apart, moved in first), the sidecar and the relit panel."""
    first = dict(layout(maps, config).files)
    names = [f.file for f in first.values()] + [SIDECAR_FILE.format(name=name)]
    if relit is not None:
        names.append(RELIT_FILE.format(name=name))
    with staged_write(out_dir, names, force=force, error=ImageError) as stage, \
            ThreadPoolExecutor(max(1, WRITE_WORKERS)) as pool:  # leaving the blocks waits for every write
        panel = pool.submit(relit) if callable(relit) else None  # first: its file is the last to wait for it
        jobs = [pool.submit(_write_file, stage, f) for f in first.values()]
        try:
            full = relief(maps)
            _check_relief(full, out_dir / name)
            plan = layout(full, config)
            if any(r not in plan.files or plan.files[r].file != f.file or plan.files[r].pixels is not f.pixels
                   for r, f in first.items()):
                raise ValueError("this layout changes its other files with the relief: give it maps that carry "
                                 "their relief (core.relief.with_relief) instead of relief=")
            added = {r: f for r, f in plan.files.items() if r not in first}
            with staged_write(out_dir, [f.file for f in added.values()], force=force, error=ImageError) as more:
                try:
                    jobs += [pool.submit(_write_file, more, f) for f in added.values()]
                    if relit is not None:
                        relit = _relit_pixels(panel.result()) if panel is not None else relit
                        jobs.append(pool.submit(_write_file, stage, _relit_file(name, relit)))
                    _write_file(stage, _sidecar(full, name, plan, config, extra_meta, relit is not None))
                    for job in jobs:
                        job.result()
                except BaseException:
                    _settle(jobs)  # no write may go on into a staging folder being removed
                    raise
        except BaseException:
            _settle(jobs)
            raise
    paths = {role: out_dir / f.file for role, f in plan.files.items()}
    paths["sidecar"] = out_dir / SIDECAR_FILE.format(name=name)
    if relit is not None:
        paths["relit"] = out_dir / RELIT_FILE.format(name=name)
    return paths


def write_texture_set(
    maps: Maps,
    out_dir,
    name: str,
    *,
    normal: str = "opengl",
    fmt: str = "png",
    force: bool = False,
    extra_meta: Optional[dict] = None,
    relit: Union[None, np.ndarray, Callable[[], np.ndarray]] = None,
    relief: Optional[Callable[[Maps], Maps]] = None,
) -> Dict[str, Path]:
    """Write a texture set in the project's own layout (see the module docstring for the files), all or nothing.

    Args:
        maps: the texture set (all four maps or a subset: only the maps present are written); ``maps.meta``
            is copied into the sidecar and ``maps.render_config`` selects the BRDF it describes (default:
            ``ZHAO``); ``maps.relief`` (:func:`~svbrdf.runtime.core.relief.with_relief`) adds the height and AO
            files and the sidecar's ``relief`` entry (height scale, method, AO parameters).
        out_dir: output folder, created (with parents) if missing.
        name: base name of the files (no path separators).
        normal: normal-map convention on disk, ``"opengl"`` (default, +y up) or ``"dx"`` (+y down).
        fmt: ``"png"`` (16-bit) or ``"exr"`` (float) for the normal, roughness, specular, height and AO maps.
        force: overwrite existing files.
        extra_meta: more metadata for the sidecar (e.g. model sha256, timings); overrides ``maps.meta`` keys.
        relit: optional (h, w, 3) float image, already sRGB-encoded in [0, 1] (e.g. :func:`relit_panel`),
            written as ``<name>_relit.png``; or a function returning it, called on a writer thread.
        relief: a function returning ``maps`` with their relief (e.g. ``lambda m: with_relief(m)``), called while
            the four maps' files are written (:func:`write_layout`); instead of maps that carry it.

    Returns:
        Paths written, keyed ``basecolor``, ``normal``, ``roughness``, ``specular``, ``height``, ``ao`` (those
        present), ``sidecar`` (and ``relit``).

    Raises:
        ImageError: a target exists (and not ``force``), bad name, ``out_dir`` is not a folder, NaN/Inf in a
            map, or a write failed. Nothing is left behind in these cases.
        ValueError: unknown ``normal``/``fmt``, bad ``relit`` shape, or metadata that is not JSON-serialisable.
    """
    if normal not in SUPPORTED_NORMAL_CONVENTIONS:
        raise ValueError(f"normal must be one of {SUPPORTED_NORMAL_CONVENTIONS}, got {normal!r}")
    if fmt not in ("png", "exr"):
        raise ValueError(f"fmt must be 'png' or 'exr', got {fmt!r}")
    return write_layout(maps, out_dir, name, lambda m, config: generic_layout(m, name, normal, fmt),
                        force=force, extra_meta=extra_meta, relit=relit, relief=relief)


def relit_panel(
    maps: Maps,
    config: RenderConfig = ZHAO,
    lights: Optional[Sequence[Optional[Sequence[float]]]] = None,
    exposure: Optional[float] = None,
    size: Optional[int] = PANEL_SIZE,
) -> np.ndarray:
    """Renders of a texture set under several point lights, side by side, ready to save as an sRGB PNG.

    Args:
        maps: the texture set, (H, W) maps; all four are needed (``ValueError`` otherwise).
        config: renderer settings (:func:`svbrdf.runtime.core.render.render`).
        lights: light positions (scene units), ``None`` entries meaning the camera flash. Default: the flash,
            then two novel lights at camera height from the upper left and the lower right (the corner
            lights of :func:`svbrdf.runtime.core.render.novel_lights`).
        exposure: linear scale applied to every render before clamping. Default (``None``): one scale for all
            panels such that the 99th percentile of the first (flash) render maps to 1, so dark materials stay
            visible and the relative brightness of the panels is kept.
        size: largest long side of each view in pixels: larger maps are first averaged over k x k pixel blocks,
            the smallest ``k`` that brings them to at most ``size`` (aspect kept, normals renormalised), so the
            cost no longer grows with the photo. Default :data:`PANEL_SIZE`; ``None`` renders at the maps' size.

    Returns:
        (h, N * w, 3) float32, sRGB-encoded in [0, 1]: ``linear_to_srgb(clip(exposure * render_i, 0, 1))``, with
        (h, w) = ``(ceil(H / k), ceil(W / k))``, ``max(h, w) <= size``.
    """
    maps.require(what="the relit panel")
    if size is not None:
        if size < 1:
            raise ValueError(f"size must be >= 1 or None, got {size}")
        maps = _downsized(maps, size)
    if lights is None:
        corners = novel_lights(config)
        lights = (None, corners[0], corners[-1])
    if not lights:
        raise ValueError("lights must not be empty")
    renders = [render(maps, lp, config) for lp in lights]
    if exposure is None:
        p99 = float(np.percentile(renders[0], 99))
        exposure = 1.0 / p99 if p99 > 0 else 1.0
    panel = np.concatenate([np.clip(r * exposure, 0.0, 1.0) for r in renders], axis=1)
    return np.clip(linear_to_srgb(panel), 0.0, 1.0)


def _downsized(maps: Maps, size: int) -> Maps:
    """The maps averaged over k x k pixel blocks, ``k = ceil(long side / size)``, so that the long side is at most
    ``size`` (the last block of a row or column over the pixels it has; normals renormalised); the same object when
    it is not longer. A block mean of a 1024 px set takes 0.02 s, OpenImageIO's resize of it 0.24 s, and the panel
    is looked at, not measured."""
    k = -(-max(maps.shape) // size)
    if k <= 1:
        return maps
    from ..core.filters import block_mean

    return maps._with({n: block_mean(a, k, partial=True) for n, a in maps.items()}).clipped()


__all__ = ["PANEL_SIZE", "WRITE_WORKERS", "write_texture_set", "relit_panel", "SIDECAR_VERSION", "TextureFile", "Layout", "generic_layout",
           "commit", "write_layout", "GENERIC_FILES", "RELIEF_FILES", "relief_file_info", "SIDECAR_FILE", "RELIT_FILE"]
