"""Writing a texture set (the four maps, a JSON sidecar, an optional relit preview) and the relit panel.

Files written by :func:`write_texture_set` into ``out_dir`` for a set called ``name``:

======================  ===========================================  ======================================
file                    content                                      encoding
======================  ===========================================  ======================================
<name>_basecolor.png    diffuse albedo                               sRGB-encoded, 8-bit PNG
<name>_normal.<ext>     unit normals, OpenGL (default) or DirectX    (n + 1) / 2, data
<name>_roughness.<ext>  perceptual roughness r (GGX alpha = r**2)    linear data, 1 channel
<name>_specular.<ext>   specular albedo rho_s (grey Schlick F0)      linear, 1 channel
<name>.json             sidecar: BRDF model, render config, files,   JSON
                        colour spaces, normal convention, metadata
<name>_relit.png        optional preview (see :func:`relit_panel`)   sRGB-encoded, 8-bit PNG
======================  ===========================================  ======================================

``<ext>`` is ``png`` (16-bit) by default or ``exr`` (32-bit float). Maps are clipped to their valid range
(:meth:`Maps.clipped`) before writing. A :class:`Maps` holding a subset of the maps writes only their files;
the sidecar's ``"maps"`` lists the maps written.

Safety: every target is checked before anything is written; if one exists and ``force`` is false, an
:class:`~svbrdf.runtime.errors.ImageError` names it and nothing is written. The files are first written into
a hidden staging folder inside ``out_dir`` and then moved into place, so a failure never leaves half a set.
"""

from __future__ import annotations

import dataclasses
import json
import os
import secrets
import shutil
from pathlib import Path
from typing import Dict, Optional, Sequence

import numpy as np

from .colour import linear_to_srgb
from .errors import ImageError
from .imageio import write_image
from .maps import SUPPORTED_NORMAL_CONVENTIONS, Maps, encode_normal, normal_gl_to_dx
from .render import ZHAO, RenderConfig, novel_lights, render

#: Sidecar format version (bump when keys change meaning).
SIDECAR_VERSION = 1

_NORMAL_AXES = {
    "opengl": "+x right, +y up the image (green up), +z out of the surface",
    "dx": "+x right, +y down the image (green down, DirectX), +z out of the surface",
}


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


def write_texture_set(
    maps: Maps,
    out_dir,
    name: str,
    *,
    normal: str = "opengl",
    fmt: str = "png",
    force: bool = False,
    extra_meta: Optional[dict] = None,
    relit: Optional[np.ndarray] = None,
) -> Dict[str, Path]:
    """Write a texture set (see the module docstring for the files), all or nothing.

    Args:
        maps: the texture set (all four maps or a subset: only the maps present are written); ``maps.meta``
            is copied into the sidecar. A ``"render_config"`` entry
            (:class:`RenderConfig` or its dict) selects the BRDF described in the sidecar (default: ``ZHAO``).
        out_dir: output folder, created (with parents) if missing.
        name: base name of the files (no path separators).
        normal: normal-map convention on disk, ``"opengl"`` (default, +y up) or ``"dx"`` (+y down).
        fmt: ``"png"`` (16-bit) or ``"exr"`` (float) for the normal, roughness and specular maps.
        force: overwrite existing files.
        extra_meta: more metadata for the sidecar (e.g. model sha256, timings); overrides ``maps.meta`` keys.
        relit: optional (h, w, 3) float image, already sRGB-encoded in [0, 1] (e.g. :func:`relit_panel`),
            written as ``<name>_relit.png``.

    Returns:
        Paths written, keyed ``basecolor``, ``normal``, ``roughness``, ``specular`` (those present), ``sidecar``
        (and ``relit``).

    Raises:
        ImageError: a target exists (and not ``force``), bad name, ``out_dir`` is not a folder, NaN/Inf in a
            map, or a write failed. Nothing is left behind in these cases.
        ValueError: unknown ``normal``/``fmt``, bad ``relit`` shape, or metadata that is not JSON-serialisable.
    """
    if normal not in SUPPORTED_NORMAL_CONVENTIONS:
        raise ValueError(f"normal must be one of {SUPPORTED_NORMAL_CONVENTIONS}, got {normal!r}")
    if fmt not in ("png", "exr"):
        raise ValueError(f"fmt must be 'png' or 'exr', got {fmt!r}")
    out_dir = Path(out_dir)
    if not name or name in (".", "..") or "/" in name or os.sep in name:
        raise ImageError(f"{out_dir}: invalid texture-set name {name!r}")
    if out_dir.exists() and not out_dir.is_dir():
        raise ImageError(f"{out_dir}: exists and is not a folder")

    data_bits = 16 if fmt == "png" else 32
    # role -> (file name, array, write_image kwargs, sidecar description)
    plan = {
        "basecolor": (f"{name}_basecolor.png", "diffuse", dict(bits=8, srgb_encode=True),
                      {"map": "diffuse", "colour_space": "sRGB", "bits": 8}),
        "normal": (f"{name}_normal.{fmt}", "normal", dict(bits=data_bits),
                   {"map": "normal", "colour_space": "data", "bits": data_bits, "encoding": "(n + 1) / 2",
                    "convention": normal}),
        "roughness": (f"{name}_roughness.{fmt}", "roughness", dict(bits=data_bits),
                      {"map": "roughness", "colour_space": "data", "bits": data_bits, "alpha": "roughness ** 2"}),
        "specular": (f"{name}_specular.{fmt}", "specular", dict(bits=data_bits),
                     {"map": "specular", "colour_space": "linear", "bits": data_bits}),
    }
    plan = {role: p for role, p in plan.items() if p[1] in maps.names}
    names = {role: p[0] for role, p in plan.items()}
    names["sidecar"] = f"{name}.json"
    if relit is not None:
        names["relit"] = f"{name}_relit.png"
    targets = {role: out_dir / fname for role, fname in names.items()}

    if not force:
        existing = [p for p in targets.values() if p.exists()]
        if existing:
            more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
            raise ImageError(f"{existing[0]}: exists{more} (use --force to overwrite)")

    for map_name, arr in maps.items():
        if not np.all(np.isfinite(arr)):
            raise ImageError(f"{out_dir / name}: map {map_name!r} has NaN/Inf values")
    if relit is not None:
        relit = np.asarray(relit, dtype=np.float32)
        if relit.ndim != 3 or relit.shape[-1] != 3:
            raise ValueError(f"relit must be (h, w, 3), got {relit.shape}")

    meta = {**maps.meta, **(extra_meta or {})}
    config = meta.get("render_config", ZHAO)
    if isinstance(config, dict):
        config = RenderConfig(**config)
    h, w = maps.shape
    clipped = maps.clipped()
    arrays = {role: getattr(clipped, p[1]) for role, p in plan.items()}
    if "normal" in arrays:
        arrays["normal"] = encode_normal(normal_gl_to_dx(arrays["normal"]) if normal == "dx" else arrays["normal"])

    sidecar = {
        "format_version": SIDECAR_VERSION,
        "name": name,
        "size": {"width": w, "height": h},
        "maps": list(maps.names),
        "brdf": _brdf_description(config),
        "normal_convention": {"name": normal, "axes": _NORMAL_AXES[normal]},
        "files": {role: {"file": plan[role][0], **plan[role][3]} for role in plan},
        "meta": {k: v for k, v in meta.items() if k != "render_config"},
    }
    if relit is not None:
        sidecar["files"]["relit"] = {"file": names["relit"], "colour_space": "sRGB", "bits": 8,
                                     "content": "renders under the flash and novel lights, side by side"}
    try:
        text = json.dumps(sidecar, indent=2, default=_json_default, allow_nan=False) + "\n"
    except (TypeError, ValueError) as exc:  # e.g. an arbitrary object or a NaN timing in the metadata
        raise ValueError(f"sidecar metadata is not JSON-serialisable: {exc}") from None

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ImageError(f"{out_dir}: cannot create folder ({exc.strerror})") from None
    stage = out_dir / f".{name}.tmp-{secrets.token_hex(4)}"
    try:
        stage.mkdir()
        for role, (fname, _, kwargs, _) in plan.items():
            write_image(stage / fname, arrays[role], **kwargs)
        if relit is not None:
            write_image(stage / names["relit"], np.clip(relit, 0.0, 1.0), bits=8)
        (stage / names["sidecar"]).write_text(text, encoding="utf-8")
        if not force:  # re-check: a file may have appeared meanwhile
            for p in targets.values():
                if p.exists():
                    raise ImageError(f"{p}: exists (use --force to overwrite)")
        for role, target in targets.items():
            os.replace(stage / names[role], target)
    except ImageError as exc:  # name the target, not the staging copy
        raise ImageError(str(exc).replace(str(stage) + os.sep, str(out_dir) + os.sep)) from None
    except OSError as exc:
        raise ImageError(f"{out_dir}: cannot write texture set ({exc.strerror or exc})") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return targets


def relit_panel(
    maps: Maps,
    config: RenderConfig = ZHAO,
    lights: Optional[Sequence[Optional[Sequence[float]]]] = None,
    exposure: Optional[float] = None,
) -> np.ndarray:
    """Renders of a texture set under several point lights, side by side, ready to save as an sRGB PNG.

    Args:
        maps: the texture set, (H, W) maps; all four are needed (``ValueError`` otherwise).
        config: renderer settings (:func:`svbrdf.runtime.render.render`).
        lights: light positions (scene units), ``None`` entries meaning the camera flash. Default: the flash,
            then two novel lights at camera height from the upper left and the lower right (the corner
            lights of :func:`svbrdf.runtime.render.novel_lights`).
        exposure: linear scale applied to every render before clamping. Default (``None``): one scale for all
            panels such that the 99th percentile of the first (flash) render maps to 1, so dark materials stay
            visible and the relative brightness of the panels is kept.

    Returns:
        (H, N * W, 3) float32, sRGB-encoded in [0, 1]: ``linear_to_srgb(clip(exposure * render_i, 0, 1))``.
    """
    maps.require(what="the relit panel")
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


__all__ = ["write_texture_set", "relit_panel", "SIDECAR_VERSION"]
