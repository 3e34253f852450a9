"""Artist-ready output: one texture set written the way a given tool expects it (``--target`` presets).

A preset fixes the file names, the normal-map convention, the packing, the bit depth and the colour space of
every file, and the material document written next to the textures (layouts and import notes:
``docs/targets.md``; field conventions: the research notes, section 3):

* ``generic``: exactly :func:`~svbrdf.runtime.texture_set.write_texture_set` (OpenGL normal, 16-bit data maps);
* ``gltf``: ``<n>_basecolor``, ``_normal``, ``_orm`` (R 1, G roughness, B metallic), ``_specularcolor``,
  ``_metalrough_basecolor``; 8-bit (web); ``<n>.gltf`` (unit quad, KHR_materials_specular) and
  ``<n>_metalrough.gltf`` (core metal-rough fallback, Khronos conversion);
* ``blender``: ``<n>_diff``, ``_nor_gl``, ``_rough``, ``_metal`` (Poly Haven names, Node Wrangler tags;
  metal-rough); 16-bit;
* ``unreal``: ``<n>_BaseColor``, ``_Normal`` (DirectX), ``_OcclusionRoughnessMetallic``; 16-bit;
* ``unity``: ``<n>_Albedo``, ``_Normal``, ``_SpecularSmoothness`` (RGB F0, A = 1 - roughness; specular
  setup); 16-bit;
* ``usd``: ``<n>_Color``, ``_NormalGL``, ``_Roughness``, ``_Specular`` (ambientCG names); 16-bit;
  ``<n>.usda`` (unit quad, UsdPreviewSurface in the specular workflow);
* ``mtlx``: the same files; ``<n>.mtlx`` (``standard_surface``).

All files are PNG; base colours are 8-bit sRGB, data maps linear ("Non-Color") and untagged. Every preset
also writes the ``<n>.json`` sidecar of :func:`write_texture_set` (BRDF model, render config, metadata) with
its ``files`` entry describing the preset's files and a ``target`` entry (conversion, import notes), and the
optional ``<n>_relit.png`` preview.

The parameter conversions (base colour, F0, metal-rough, smoothness) are those of
:mod:`svbrdf.runtime.conversions`.

Safety is that of :func:`write_texture_set`: all files are made in a hidden staging folder inside ``out_dir``
(the four maps and the sidecar by :func:`write_texture_set` itself) and only moved into place when all were
written; an existing file is never replaced unless ``force``.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, Mapping, Optional, Tuple

import numpy as np

from .choices import TARGETS
from .conversions import (
    roughness_to_smoothness,
    specgloss_to_metalrough,
    to_khr_specular,
    to_weighted_base,
)
from .errors import ImageError
from .imageio import write_image
from .maps import Maps, encode_normal
from .materials import gltf_document, mtlx_document, usda_document
from .render import ZHAO, RenderConfig
from .texture_set import write_texture_set



@dataclass(frozen=True)
class TargetPreset:
    """What a target writes.

    Attributes:
        name: target name (a key of :data:`PRESETS`).
        description: one line for ``--help`` and the sidecar.
        normal: normal convention on disk, ``"opengl"`` or ``"dx"``.
        data_bits: bit depth of the data maps (normal, roughness, specular, packed maps).
        files: role -> file name template (``{name}`` is the set's name); also lists the documents.
        notes: import settings the consumer needs (copied into the sidecar).
    """

    name: str
    description: str
    normal: str
    data_bits: int
    files: Mapping[str, str]
    notes: Tuple[str, ...] = field(default=())


_AMBIENTCG = {"basecolor": "{name}_Color.png", "normal": "{name}_NormalGL.png",
              "roughness": "{name}_Roughness.png", "specular": "{name}_Specular.png"}

#: The presets (``generic`` is :func:`write_texture_set` with its defaults).
PRESETS: Mapping[str, TargetPreset] = {
    "generic": TargetPreset(
        "generic", "the project's own layout: diffuse, specular (F0), roughness, normal (OpenGL), JSON sidecar",
        "opengl", 16,
        {"basecolor": "{name}_basecolor.png", "normal": "{name}_normal.png", "roughness": "{name}_roughness.png",
         "specular": "{name}_specular.png"}),
    "gltf": TargetPreset(
        "gltf", "web glTF 2.0: unit quad, KHR_materials_specular material and a metal-rough fallback, 8-bit PNG",
        "opengl", 8,
        {"basecolor": "{name}_basecolor.png", "normal": "{name}_normal.png", "orm": "{name}_orm.png",
         "specularcolor": "{name}_specularcolor.png", "fallback_basecolor": "{name}_metalrough_basecolor.png",
         "gltf": "{name}.gltf", "gltf_fallback": "{name}_metalrough.gltf"},
        ("open <name>.gltf; viewers without KHR_materials_specular show F0 = 0.04 everywhere: use "
         "<name>_metalrough.gltf there (Khronos spec-gloss -> metal-rough conversion)",)),
    "blender": TargetPreset(
        "blender", "Blender (Node Wrangler names, metal-rough via the Khronos conversion), 16-bit PNG",
        "opengl", 16,
        {"basecolor": "{name}_diff.png", "normal": "{name}_nor_gl.png", "roughness": "{name}_rough.png",
         "metallic": "{name}_metal.png"},
        ("Shader editor: select the Principled BSDF, Node Wrangler > Add Principled Setup (Ctrl+Shift+T), pick "
         "the four files; roughness, metallic and normal are set to Non-Color by Node Wrangler",
         "Normal Map node in Tangent Space (OpenGL convention, Blender's own)")),
    "unreal": TargetPreset(
        "unreal", "Unreal Engine: DirectX normal, packed ORM (R occlusion = 1, G roughness, B metallic), 16-bit PNG",
        "dx", 16,
        {"basecolor": "{name}_BaseColor.png", "normal": "{name}_Normal.png",
         "orm": "{name}_OcclusionRoughnessMetallic.png"},
        ("BaseColor: sRGB on", "Normal: compression Normalmap, sRGB off (green already flipped, do not flip again)",
         "OcclusionRoughnessMetallic: compression Masks, sRGB off; R -> Ambient Occlusion, G -> Roughness, "
         "B -> Metallic", "Specular input: leave at 0.5 (F0 0.04, as the conversion assumes)")),
    "unity": TargetPreset(
        "unity", "Unity specular setup: albedo, specular RGB + smoothness in alpha, OpenGL normal, 16-bit PNG",
        "opengl", 16,
        {"basecolor": "{name}_Albedo.png", "normal": "{name}_Normal.png",
         "specular_smoothness": "{name}_SpecularSmoothness.png"},
        ("Shader: Standard (Specular setup), or URP Lit with Workflow Mode = Specular",
         "Albedo: sRGB (Color Texture) on; SpecularSmoothness: sRGB on (RGB is a colour; alpha is always linear), "
         "Smoothness Source = Specular Alpha; Normal: Texture Type = Normal map")),
    "usd": TargetPreset(
        "usd", "USD: UsdPreviewSurface in the specular workflow on a unit quad (ambientCG names), 16-bit PNG",
        "opengl", 16, {**_AMBIENTCG, "usda": "{name}.usda"},
        ("open <name>.usda (usdview, Omniverse, Houdini, Blender's USD import); the material is bound to the quad",)),
    "mtlx": TargetPreset(
        "mtlx", "MaterialX standard_surface (ambientCG names), 16-bit PNG",
        "opengl", 16, {**_AMBIENTCG, "mtlx": "{name}.mtlx"},
        ("load <name>.mtlx (MaterialX Viewer, Houdini, Maya, Arnold, Omniverse); texture paths are relative to it",)),
}

_SIDECAR = "{name}.json"
_RELIT = "{name}_relit.png"


@dataclass
class _Plan:
    """How one target is made from a :func:`write_texture_set` output written in the staging folder."""

    maps: Maps  # what write_texture_set writes (its base colour is the target's base colour)
    keep: Dict[str, str]  # write_texture_set role -> target role (file kept, renamed)
    images: Dict[str, Tuple[np.ndarray, int, bool]]  # target role -> (array, bits, sRGB-encode)
    files: Dict[str, dict]  # target role -> sidecar description of the file
    documents: Dict[str, Callable[[str, Mapping[str, str]], str]] = field(default_factory=dict)  # (name, files)
    conversion: str = ""


def _describe(content: str, colour_space: str, bits: int, channels: int, **more) -> dict:
    return {"content": content, "colour_space": colour_space, "bits": bits, "channels": channels, **more}


def _normal_file(p: TargetPreset) -> dict:
    return _describe(f"normals, {p.normal} convention", "data", p.data_bits, 3, encoding="(n + 1) / 2")


def _grey3(a: np.ndarray) -> np.ndarray:
    return np.repeat(a, 3, axis=-1)


def _metal_rough(m: Maps, config: RenderConfig) -> Tuple[np.ndarray, np.ndarray]:
    return specgloss_to_metalrough(to_weighted_base(m.diffuse, m.specular, config), m.specular)


_WEIGHTED_BASE = "base colour = diffuse * w_d / (1 - specular) (diffuse lobe weighted by 1 - F0)"
_KHRONOS_MR = ("metal-rough by the Khronos spec-gloss conversion of (diffuse * w_d / (1 - specular), "
               "specular); roughness unchanged")


def _plan_gltf(m: Maps, config: RenderConfig, p: TargetPreset) -> _Plan:
    base = to_weighted_base(m.diffuse, m.specular, config)
    factor, spec_tex = to_khr_specular(m.specular)
    fb_base, metallic = specgloss_to_metalrough(base, m.specular)
    orm = np.concatenate([np.ones_like(m.roughness), m.roughness, metallic], axis=-1)
    aspect = m.shape[0] / m.shape[1]

    def main(name, f):
        return gltf_document(name, aspect, base_color=f["basecolor"], normal=f["normal"],
                             metallic_roughness=f["orm"], metallic_factor=0.0, specular_color=f["specularcolor"],
                             specular_color_factor=factor)

    def fallback(name, f):
        return gltf_document(name + "_metalrough", aspect, base_color=f["fallback_basecolor"], normal=f["normal"],
                             metallic_roughness=f["orm"], metallic_factor=1.0)

    return _Plan(
        maps=Maps(base, m.specular, m.roughness, m.normal),
        keep={"basecolor": "basecolor"},
        images={"normal": (encode_normal(m.normal), p.data_bits, False), "orm": (orm, p.data_bits, False),
                "specularcolor": (spec_tex, 8, True), "fallback_basecolor": (fb_base, 8, True)},
        files={
            "basecolor": _describe(_WEIGHTED_BASE, "sRGB", 8, 3),
            "normal": _normal_file(p),
            "orm": _describe("R = 1 (no occlusion), G = roughness, B = metallic of the fallback material",
                             "data", p.data_bits, 3),
            "specularcolor": _describe(f"KHR_materials_specular specularColorTexture: specular / max(specular); "
                                       f"specularColorFactor = max(specular) / 0.04 = {factor:.6g}", "sRGB", 8, 1),
            "fallback_basecolor": _describe("base colour of the metal-rough fallback (Khronos conversion)",
                                            "sRGB", 8, 3),
            "gltf": {"content": "glTF 2.0, unit quad, KHR_materials_specular material, metallicFactor 0"},
            "gltf_fallback": {"content": "glTF 2.0 core metal-rough fallback (Khronos conversion)"},
        },
        documents={"gltf": main, "gltf_fallback": fallback},
        conversion=f"{_WEIGHTED_BASE}; F0 = 0.04 * specularColorFactor * specularColorTexture; fallback: "
                   f"{_KHRONOS_MR}",
    )


def _plan_metal_rough(m: Maps, config: RenderConfig, p: TargetPreset) -> _Plan:
    base, metallic = _metal_rough(m, config)
    plan = _Plan(
        maps=Maps(base, m.specular, m.roughness, m.normal),
        keep={"basecolor": "basecolor", "normal": "normal"},
        images={},
        files={"basecolor": _describe("metal-rough base colour (Khronos conversion)", "sRGB", 8, 3),
               "normal": _normal_file(p)},
        conversion=_KHRONOS_MR,
    )
    if p.name == "unreal":
        orm = np.concatenate([np.ones_like(m.roughness), m.roughness, metallic], axis=-1)
        plan.images["orm"] = (orm, p.data_bits, False)
        plan.files["orm"] = _describe("R = ambient occlusion (1, none estimated), G = roughness, B = metallic",
                                      "data", p.data_bits, 3)
    else:
        plan.keep["roughness"] = "roughness"
        plan.images["metallic"] = (metallic, p.data_bits, False)
        plan.files["roughness"] = _describe("roughness (alpha = roughness^2)", "data", p.data_bits, 1)
        plan.files["metallic"] = _describe("metallic (Khronos conversion)", "data", p.data_bits, 1)
    return plan


def _plan_unity(m: Maps, config: RenderConfig, p: TargetPreset) -> _Plan:
    albedo = to_weighted_base(m.diffuse, m.specular, config)
    spec_smooth = np.concatenate([_grey3(m.specular), roughness_to_smoothness(m.roughness)], axis=-1)
    return _Plan(
        maps=Maps(albedo, m.specular, m.roughness, m.normal),
        keep={"basecolor": "basecolor", "normal": "normal"},
        images={"specular_smoothness": (spec_smooth, p.data_bits, True)},
        files={"basecolor": _describe(_WEIGHTED_BASE, "sRGB", 8, 3),
               "normal": _normal_file(p),
               "specular_smoothness": _describe("RGB = specular F0 (grey), A = smoothness = 1 - roughness",
                                                "sRGB (RGB), linear (A)", p.data_bits, 4)},
        conversion=f"{_WEIGHTED_BASE}; smoothness = 1 - roughness",
    )


def _plan_specular_workflow(m: Maps, config: RenderConfig, p: TargetPreset) -> _Plan:
    base = to_weighted_base(m.diffuse, m.specular, config)
    aspect = m.shape[0] / m.shape[1]
    if p.name == "usd":
        documents = {"usda": lambda name, f: usda_document(
            name, aspect, diffuse_color=f["basecolor"], specular_color=f["specular"], roughness=f["roughness"],
            normal=f["normal"])}
        doc = {"content": "USD stage: unit quad + UsdPreviewSurface (useSpecularWorkflow = 1)"}
    else:
        documents = {"mtlx": lambda name, f: mtlx_document(
            name, base_color=f["basecolor"], specular_f0=f["specular"], roughness=f["roughness"],
            normal=f["normal"])}
        doc = {"content": "MaterialX standard_surface, specular_IOR computed from F0"}
    return _Plan(
        maps=Maps(base, m.specular, m.roughness, m.normal),
        keep={r: r for r in ("basecolor", "normal", "roughness", "specular")},
        images={},
        files={"basecolor": _describe(_WEIGHTED_BASE, "sRGB", 8, 3),
               "normal": _normal_file(p),
               "roughness": _describe("roughness (alpha = roughness^2)", "data", p.data_bits, 1),
               "specular": _describe("specular F0 (grey)", "linear", p.data_bits, 1),
               next(iter(documents)): doc},
        documents=documents,
        conversion=f"{_WEIGHTED_BASE}; F0, roughness and normal unchanged"
                   + ("; specular_IOR = (1 + sqrt F0) / (1 - sqrt F0)" if p.name == "mtlx" else ""),
    )


_PLANS = {"gltf": _plan_gltf, "blender": _plan_metal_rough, "unreal": _plan_metal_rough, "unity": _plan_unity,
          "usd": _plan_specular_workflow, "mtlx": _plan_specular_workflow}


def target_files(name: str, target: str = "generic", relit: bool = False) -> Dict[str, str]:
    """File names a target writes for a set called ``name``: role -> file name (sidecar and relit included)."""
    if target not in PRESETS:
        raise ValueError(f"unknown target {target!r}; expected one of {', '.join(TARGETS)}")
    names = {role: t.format(name=name) for role, t in PRESETS[target].files.items()}
    names["sidecar"] = _SIDECAR.format(name=name)
    if relit:
        names["relit"] = _RELIT.format(name=name)
    return names


def write_target(
    maps: Maps,
    out_dir,
    name: str,
    target: str = "generic",
    *,
    force: bool = False,
    extra_meta: Optional[dict] = None,
    relit: Optional[np.ndarray] = None,
) -> Dict[str, Path]:
    """Write a texture set for a target tool (see the module docstring), all or nothing.

    Args:
        maps: the texture set (our model; ``maps.meta["render_config"]`` selects the diffuse weighting used by
            the conversions, default ``ZHAO``).
        out_dir: output folder, created (with parents) if missing.
        name: base name of the files (no path separators).
        target: one of :data:`TARGETS`. ``"generic"`` is exactly :func:`write_texture_set` with its defaults.
        force: overwrite existing files.
        extra_meta: more metadata for the sidecar (see :func:`write_texture_set`).
        relit: optional sRGB-encoded (h, w, 3) preview, written as ``<name>_relit.png``.

    Returns:
        Paths written, keyed by role (:func:`target_files`).

    Raises:
        ValueError: unknown target, a subset of the maps for a target other than ``generic`` (and the argument
            errors of :func:`write_texture_set`).
        ImageError: a target file exists (and not ``force``), bad name or folder, NaN/Inf in a map, or a write
            failed. Nothing is left behind in these cases.
    """
    if target not in PRESETS:
        raise ValueError(f"unknown target {target!r}; expected one of {', '.join(TARGETS)}")
    if target == "generic":
        return write_texture_set(maps, out_dir, name, force=force, extra_meta=extra_meta, relit=relit)
    maps.require(what=f"target {target!r}")  # every preset's base colour / packing converts all four maps
    preset = PRESETS[target]
    out_dir = Path(out_dir)
    if not name or name in (".", "..") or "/" in name or os.sep in name:
        raise ImageError(f"{out_dir}: invalid texture-set name {name!r}")
    if out_dir.exists() and not out_dir.is_dir():
        raise ImageError(f"{out_dir}: exists and is not a folder")
    names = target_files(name, target, relit is not None)
    targets = {role: out_dir / f for role, f in names.items()}
    if not force:
        existing = [p for p in targets.values() if p.exists()]
        if existing:
            more = f" (and {len(existing) - 1} more)" if len(existing) > 1 else ""
            raise ImageError(f"{existing[0]}: exists{more} (use --force to overwrite)")
    for map_name, arr in maps.items():
        if not np.all(np.isfinite(arr)):
            raise ImageError(f"{out_dir / name}: map {map_name!r} has NaN/Inf values")

    meta = {**maps.meta, **(extra_meta or {})}
    config = meta.get("render_config", ZHAO)
    if isinstance(config, dict):
        config = RenderConfig(**config)
    clipped = maps.clipped()
    plan = _PLANS[target](clipped, config, preset)
    plan.maps.meta = dict(maps.meta)

    created = not out_dir.exists()
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ImageError(f"{out_dir}: cannot create folder ({exc.strerror})") from None
    stage = out_dir / f".{name}.{target}.tmp-{secrets.token_hex(4)}"
    try:
        stage.mkdir()
        written = write_texture_set(plan.maps, stage, name, normal=preset.normal, fmt="png",
                                    extra_meta=extra_meta, relit=relit)
        sidecar = json.loads(written["sidecar"].read_text(encoding="utf-8"))
        written["sidecar"].unlink()
        kept = {}
        for role, path in written.items():  # park the kept files, drop the others
            if role in plan.keep:
                kept[plan.keep[role]] = path.rename(stage / f".keep-{role}{path.suffix}")
            elif role == "relit":
                kept["relit"] = path.rename(stage / f".keep-relit{path.suffix}")
            elif role != "sidecar":
                path.unlink()
        for role, path in kept.items():
            path.rename(stage / names[role])
        for role, (arr, bits, srgb) in plan.images.items():
            write_image(stage / names[role], arr, bits=bits, srgb_encode=srgb)
        for role, make in plan.documents.items():
            (stage / names[role]).write_text(make(name, names), encoding="utf-8")
        files = {role: {"file": names[role], **desc} for role, desc in plan.files.items()}
        if relit is not None:
            files["relit"] = sidecar["files"]["relit"]
        sidecar["files"] = files
        sidecar["target"] = {"name": target, "description": preset.description, "conversion": plan.conversion,
                             "import_notes": list(preset.notes)}
        (stage / names["sidecar"]).write_text(json.dumps(sidecar, indent=2) + "\n", encoding="utf-8")
        if not force:  # re-check: a file may have appeared meanwhile
            for p in targets.values():
                if p.exists():
                    raise ImageError(f"{p}: exists (use --force to overwrite)")
        for role, target_path in targets.items():
            os.replace(stage / names[role], target_path)
    except ImageError as exc:  # name the target, not the staging copy
        _remove_created(stage, out_dir if created else None)
        raise ImageError(str(exc).replace(str(stage) + os.sep, str(out_dir) + os.sep)) from None
    except OSError as exc:
        _remove_created(stage, out_dir if created else None)
        raise ImageError(f"{out_dir}: cannot write texture set ({exc.strerror or exc})") from None
    except BaseException:
        _remove_created(stage, out_dir if created else None)
        raise
    shutil.rmtree(stage, ignore_errors=True)
    return targets


def _remove_created(stage: Path, created_dir: Optional[Path]) -> None:
    shutil.rmtree(stage, ignore_errors=True)
    if created_dir is not None:
        try:
            created_dir.rmdir()  # only if still empty
        except OSError:
            pass


__all__ = ["TARGETS", "PRESETS", "TargetPreset", "write_target", "target_files"]
