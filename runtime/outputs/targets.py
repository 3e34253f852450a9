"""Artist-ready output: one texture set written the way a given tool expects it (``--target`` presets).

A preset fixes the file names, the normal-map convention, the packing, the bit depth and the colour space of
every file, and the material document written next to the textures (layouts and import notes:
``docs/targets.md``; field conventions: the research notes, section 3):

* ``generic``: exactly :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set` (OpenGL normal, 16-bit data maps);
* ``gltf``: ``<n>_basecolor``, ``_normal``, ``_orm`` (R 1, G roughness, B metallic), ``_specularcolor``,
  ``_metalrough_basecolor``; 8-bit (web); ``<n>.gltf`` (unit quad, KHR_materials_specular) and
  ``<n>_metalrough.gltf`` (core metal-rough fallback, Khronos conversion);
* ``blender``: ``<n>_diff``, ``_nor_gl``, ``_rough``, ``_spec`` (Poly Haven names, Node Wrangler tags): the
  inputs of Blender's Principled BSDF (base colour, Roughness, ``Specular = F0 / 0.08``, Metallic 0), what the
  add-on (``svbrdf.runtime.outputs.blender``) loads; 16-bit;
* ``unreal``: ``<n>_BaseColor``, ``_Normal`` (DirectX), ``_OcclusionRoughnessMetallic``; 16-bit;
* ``unity``: ``<n>_Albedo``, ``_Normal``, ``_SpecularSmoothness`` (RGB F0, A = 1 - roughness; specular
  setup); 16-bit;
* ``usd``: ``<n>_Color``, ``_NormalGL``, ``_Roughness``, ``_Specular`` (ambientCG names); 16-bit;
  ``<n>.usda`` (unit quad, UsdPreviewSurface in the specular workflow);
* ``mtlx``: the same files; ``<n>.mtlx`` (``standard_surface``);
* ``ambientcg``: the CC0 libraries' set: ``_Color``, ``_NormalGL`` and ``_NormalDX``, ``_Roughness``, ``_Specular``,
  ``_Displacement``, ``_AmbientOcclusion``, ``<n>.mtlx``.

Height and AO (when ``maps.relief`` is set, :func:`~svbrdf.runtime.core.relief.with_relief`): ``generic``
``_height``/``_ao``; ``gltf`` the AO in the ORM red channel (``occlusionTexture``); ``blender`` ``_disp``/``_ao``;
``unreal`` the AO in the ORM, ``_Height``; ``unity`` ``_MaskMap`` (G = AO, A = smoothness) and ``_Height``; ``usd``,
``mtlx``, ``ambientcg`` ``_Displacement``/``_AmbientOcclusion``, wired into the USD and MaterialX documents
(:attr:`TargetPreset.relief_files`). The AO never darkens a base colour.

All files are PNG; base colours are 8-bit sRGB, data maps linear ("Non-Color", tagged with a gAMA chunk of 1.0).
Every preset also writes the ``<n>.json`` sidecar of :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set` (BRDF model,
render config, metadata) with its ``files`` entry describing the preset's files and a ``target`` entry
(conversion, import notes), and the optional ``<n>_relit.png`` preview.

The parameter conversions (base colour, F0, metal-rough, smoothness) are those of
:mod:`svbrdf.runtime.outputs.conversions`.

Each preset is a layout (:class:`~svbrdf.runtime.outputs.texture_set.Layout`: file role -> image or document) that
the one texture-set writer, :func:`~svbrdf.runtime.outputs.texture_set.write_layout`, plans and commits; ``generic``
is :func:`~svbrdf.runtime.outputs.texture_set.generic_layout`. Safety is therefore that of every texture set: all
files are made in a hidden staging folder inside ``out_dir`` and only moved into place when all were
written; an existing file is never replaced unless ``force``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Dict, Mapping, Optional, Tuple

import numpy as np

from .choices import TARGETS
from .conversions import (
    roughness_to_smoothness,
    specgloss_to_metalrough,
    to_khr_specular,
    to_principled_base,
    to_principled_specular,
    to_weighted_base,
)
from ..core.maps import Maps, encode_normal, normal_gl_to_dx
from .materials import gltf_document, mtlx_document, usda_document
from ..core.render import RenderConfig
from .texture_set import (
    GENERIC_FILES,
    RELIEF_FILES,
    RELIT_FILE,
    SIDECAR_FILE,
    Layout,
    TextureFile,
    generic_layout,
    relief_file_info,
    write_layout,
)



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
        relief_files: relief map (``"height"``, ``"ao"``) -> (role, file name template) of the files written when
            the maps carry that relief map (:attr:`~svbrdf.runtime.core.maps.Maps.relief`); a relief map not listed
            is packed into another file (the AO in an ORM texture) or not used by the target.
        relief_notes: import settings of the relief files (added to ``notes`` when they are written).
    """

    name: str
    description: str
    normal: str
    data_bits: int
    files: Mapping[str, str]
    notes: Tuple[str, ...] = field(default=())
    relief_files: Mapping[str, Tuple[str, str]] = field(default_factory=dict)
    relief_notes: Tuple[str, ...] = field(default=())


_AMBIENTCG = {"basecolor": "{name}_Color.png", "normal": "{name}_NormalGL.png",
              "roughness": "{name}_Roughness.png", "specular": "{name}_Specular.png"}
_AMBIENTCG_RELIEF = {"height": ("height", "{name}_Displacement.png"), "ao": ("ao", "{name}_AmbientOcclusion.png")}
_HEIGHT_NOTE = ("height: linear data (Non-Color / sRGB off); white = high, 0.5 = the mean level; it spans "
                "the sidecar's relief.height_scale map widths black to white (displacement scale = height_scale x "
                "the surface's width, midlevel 0.5)")

_MTLX_RELIEF_NOTES = ("the material's displacement shader reads the Displacement file (value - 0.5, scale "
                      "relief.height_scale: scene units for a surface one unit wide); standard_surface has no "
                      "occlusion input: the AmbientOcclusion file is for the renderers that take one",
                      _HEIGHT_NOTE)

#: The presets (``generic`` is :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set` with its defaults).
PRESETS: Mapping[str, TargetPreset] = {
    "generic": TargetPreset(
        "generic", "the project's own layout: diffuse, specular (F0), roughness, normal (OpenGL), JSON sidecar",
        "opengl", 16,
        {role: template.replace("{ext}", "png") for role, (_, template) in GENERIC_FILES.items()},
        relief_files={m: (m, t.replace("{ext}", "png")) for m, t in RELIEF_FILES.items()}),
    "gltf": TargetPreset(
        "gltf", "web glTF 2.0: unit quad, KHR_materials_specular material and a metal-rough fallback, 8-bit PNG",
        "opengl", 8,
        {"basecolor": "{name}_basecolor.png", "normal": "{name}_normal.png", "orm": "{name}_orm.png",
         "specularcolor": "{name}_specularcolor.png", "fallback_basecolor": "{name}_metalrough_basecolor.png",
         "gltf": "{name}.gltf", "gltf_fallback": "{name}_metalrough.gltf"},
        ("open <name>.gltf; viewers without KHR_materials_specular show F0 = 0.04 everywhere: use "
         "<name>_metalrough.gltf there (Khronos spec-gloss -> metal-rough conversion)",),
        relief_notes=("ambient occlusion in the ORM texture's red channel, referenced as occlusionTexture "
                      "(glTF has no displacement; the generic target writes the height)",)),
    "blender": TargetPreset(
        "blender", "Blender's Principled BSDF (Node Wrangler names): base colour, roughness, Specular = F0 / 0.08, "
                   "OpenGL normal, 16-bit PNG",
        "opengl", 16,
        {"basecolor": "{name}_diff.png", "normal": "{name}_nor_gl.png", "roughness": "{name}_rough.png",
         "specular": "{name}_spec.png"},
        ("svbrdf add-on (svbrdf-blender addon): Material from texture set, pick <name>.json; or Shader editor: "
         "select the Principled BSDF, Node Wrangler > Add Principled Setup (Ctrl+Shift+T), pick the four files "
         "(roughness, spec and normal are set to Non-Color by Node Wrangler)",
         "Specular = principled_specular_scale x <name>_spec.png (the sidecar's files.specular; when the scale is "
         "not 1, put a Math Multiply node by it between the texture and Specular); Metallic 0, Specular Tint 0",
         "Principled BSDF distribution GGX (Multiscatter GGX adds energy our model has not); Blender 2.8-3.x: the "
         "base colour is the diffuse albedo; Blender 4.x: Specular IOR Level takes the same value at IOR 1.5",
         "Normal Map node in Tangent Space (OpenGL convention, Blender's own)"),
        relief_files={"height": ("height", "{name}_disp.png"), "ao": ("ao", "{name}_ao.png")},
        relief_notes=("<name>_disp.png: Displacement node (Non-Color) into Material Output > Displacement, "
                      "Midlevel 0.5, Scale = relief.height_scale x the object's width; Cycles: Displacement and "
                      "Bump (or Displacement Only with an adaptively subdivided plane)",
                      "<name>_ao.png: Non-Color; Node Wrangler multiplies it into the base colour, which "
                      "already holds no occlusion: leave it unconnected unless you want the extra darkening",
                      _HEIGHT_NOTE)),
    "unreal": TargetPreset(
        "unreal", "Unreal Engine: DirectX normal, packed ORM (R ambient occlusion, G roughness, B metallic), "
                  "height, 16-bit PNG",
        "dx", 16,
        {"basecolor": "{name}_BaseColor.png", "normal": "{name}_Normal.png",
         "orm": "{name}_OcclusionRoughnessMetallic.png"},
        ("BaseColor: sRGB on", "Normal: compression Normalmap, sRGB off (green already flipped, do not flip again)",
         "OcclusionRoughnessMetallic: compression Masks, sRGB off; R -> Ambient Occlusion, G -> Roughness, "
         "B -> Metallic", "Specular input: leave at 0.5 (F0 0.04, as the conversion assumes)"),
        relief_files={"height": ("height", "{name}_Height.png")},
        relief_notes=("Height: sRGB off, compression Grayscale or Masks; for parallax occlusion mapping or "
                      "Nanite displacement (magnitude = relief.height_scale x the surface's width, center 0.5)",
                      _HEIGHT_NOTE)),
    "unity": TargetPreset(
        "unity", "Unity specular setup: albedo, specular RGB + smoothness in alpha, OpenGL normal, 16-bit PNG",
        "opengl", 16,
        {"basecolor": "{name}_Albedo.png", "normal": "{name}_Normal.png",
         "specular_smoothness": "{name}_SpecularSmoothness.png"},
        ("Shader: Standard (Specular setup), or URP Lit with Workflow Mode = Specular",
         "Albedo: sRGB (Color Texture) on; SpecularSmoothness: sRGB on (RGB is a colour; alpha is always linear), "
         "Smoothness Source = Specular Alpha; Normal: Texture Type = Normal map"),
        relief_files={"height": ("height", "{name}_Height.png"), "ao": ("mask", "{name}_MaskMap.png")},
        relief_notes=("MaskMap: sRGB off; R = 0 (metallic: specular setup), G = ambient occlusion, B = 0 (detail "
                      "mask), A = smoothness. HDRP Lit (Material Type Specular Color): Mask Map. Standard and URP "
                      "Lit: Occlusion Map (they read G)",
                      "Height: sRGB off; Standard / URP Lit Height Map (parallax, reads G), or HDRP Height Map "
                      "(Parametrization Amplitude = relief.height_scale x the surface's width, base 0.5)",
                      _HEIGHT_NOTE)),
    "usd": TargetPreset(
        "usd", "USD: UsdPreviewSurface in the specular workflow on a unit quad (ambientCG names), 16-bit PNG",
        "opengl", 16, {**_AMBIENTCG, "usda": "{name}.usda"},
        ("open <name>.usda (usdview, Omniverse, Houdini, Blender's USD import); the material is bound to the quad",),
        relief_files=_AMBIENTCG_RELIEF,
        relief_notes=("displacement: the height in scene units of the unit quad (UsdUVTexture scale height_scale, "
                      "bias -height_scale / 2); occlusion: the ambient occlusion (1 = open)", _HEIGHT_NOTE)),
    "mtlx": TargetPreset(
        "mtlx", "MaterialX standard_surface (ambientCG names), 16-bit PNG",
        "opengl", 16, {**_AMBIENTCG, "mtlx": "{name}.mtlx"},
        ("load <name>.mtlx (MaterialX Viewer, Houdini, Maya, Arnold, Omniverse); texture paths are relative to it",),
        relief_files=_AMBIENTCG_RELIEF, relief_notes=_MTLX_RELIEF_NOTES),
    "ambientcg": TargetPreset(
        "ambientcg", "the CC0 libraries' texture set (ambientCG / Poly Haven names): Color, NormalGL and NormalDX, "
                     "Roughness, Specular, Displacement, AmbientOcclusion, MaterialX document, 16-bit PNG",
        "opengl", 16, {**_AMBIENTCG, "normal_dx": "{name}_NormalDX.png", "mtlx": "{name}.mtlx"},
        ("NormalGL: OpenGL convention (Blender, Unity, Godot); NormalDX: DirectX convention (Unreal, Substance "
         "by default); use one of the two",
         "load <name>.mtlx (MaterialX Viewer, Houdini, Maya, Arnold, Omniverse); texture paths are relative to it",
         "Color: sRGB; every other file linear (Non-Color)"),
        relief_files=_AMBIENTCG_RELIEF, relief_notes=_MTLX_RELIEF_NOTES),
}

Builder = Callable[[Maps, RenderConfig, TargetPreset, str], Layout]


def _describe(content: str, colour_space: str, bits: int, channels: int, **more) -> dict:
    return {"content": content, "colour_space": colour_space, "bits": bits, "channels": channels, **more}


def _normal_file(p: TargetPreset) -> dict:
    return _describe(f"normals, {p.normal} convention", "data", p.data_bits, 3, encoding="(n + 1) / 2")


def _grey3(a: np.ndarray) -> np.ndarray:
    return np.repeat(a, 3, axis=-1)


def _generic_files(p: TargetPreset, name: str, files: Mapping[str, str], info: Mapping[str, dict],
                   **maps: np.ndarray) -> Dict[str, TextureFile]:
    """Files of the project's own layout (base colour 8-bit sRGB, data maps 16-bit PNG, normal in the
    preset's convention) for ``maps``, renamed and described as the preset's roles ``info``."""
    layout = generic_layout(Maps(**maps), name, p.normal).files
    return {role: replace(layout[role], file=files[role], info=info[role]) for role in info}


def _layout(p: TargetPreset, files: Dict[str, TextureFile], conversion: str, maps: Optional[Maps] = None,
            name: str = "") -> Layout:
    """The preset's layout of ``files``, plus its separate relief files when ``maps`` carry a relief."""
    notes = list(p.notes)
    if maps is not None and maps.relief is not None:
        files = {**files, **_relief_files(maps, p, name)}
        notes += list(p.relief_notes)
    return Layout(files, p.normal, {"name": p.name, "description": p.description, "conversion": conversion,
                                    "import_notes": notes})


def _relief_files(maps: Maps, p: TargetPreset, name: str) -> Dict[str, TextureFile]:
    """The separate files of the relief maps present (``p.relief_files``; the Unity mask map is its plan's)."""
    r = maps.relief
    info = relief_file_info(r, p.data_bits)
    out = {}
    for m in r.names:
        if m not in p.relief_files or p.relief_files[m][0] == "mask":
            continue
        role, template = p.relief_files[m]
        out[role] = TextureFile(template.format(name=name), info[m], getattr(r, m)[..., None], p.data_bits)
    return out


def _occlusion(m: Maps) -> Optional[np.ndarray]:
    """(H, W, 1) ambient occlusion of the set (1 = open), or None without it."""
    return None if m.relief is None or m.relief.ao is None else m.relief.ao[..., None]


_WEIGHTED_BASE = "base colour = diffuse * w_d / (1 - specular) (diffuse lobe weighted by 1 - F0)"
_PRINCIPLED_BASE = "Principled base colour = diffuse * w_d (its diffuse lobe is not weighted by the Fresnel term)"
_KHRONOS_MR = ("metal-rough by the Khronos spec-gloss conversion of (diffuse * w_d / (1 - specular), "
               "specular); roughness unchanged")


def _plan_generic(maps: Maps, config: RenderConfig, p: TargetPreset, name: str) -> Layout:
    return generic_layout(maps, name, p.normal)


def _plan_gltf(maps: Maps, config: RenderConfig, p: TargetPreset, name: str) -> Layout:
    m = maps.clipped()
    f = target_files(name, p.name)
    base = to_weighted_base(m.diffuse, m.specular, config)
    factor, spec_tex = to_khr_specular(m.specular)
    fb_base, metallic = specgloss_to_metalrough(base, m.specular)
    ao = _occlusion(m)
    orm = np.concatenate([np.ones_like(m.roughness) if ao is None else ao, m.roughness, metallic], axis=-1)
    aspect = m.shape[0] / m.shape[1]
    files = _generic_files(p, name, f, {"basecolor": _describe(_WEIGHTED_BASE, "sRGB", 8, 3)}, diffuse=base)
    files.update(
        normal=TextureFile(f["normal"], _normal_file(p), encode_normal(m.normal), p.data_bits),
        orm=TextureFile(f["orm"], _describe(("R = 1 (no occlusion)" if ao is None else
                                             "R = ambient occlusion (occlusionTexture, 1 = open)")
                                            + ", G = roughness, B = metallic of the fallback material", "data",
                                            p.data_bits, 3), orm, p.data_bits),
        specularcolor=TextureFile(f["specularcolor"], _describe(
            f"KHR_materials_specular specularColorTexture: specular / max(specular); "
            f"specularColorFactor = max(specular) / 0.04 = {factor:.6g}", "sRGB", 8, 1), spec_tex, 8, srgb=True),
        fallback_basecolor=TextureFile(f["fallback_basecolor"], _describe(
            "base colour of the metal-rough fallback (Khronos conversion)", "sRGB", 8, 3), fb_base, 8, srgb=True),
        gltf=TextureFile(f["gltf"],
                         {"content": "glTF 2.0, unit quad, KHR_materials_specular material, metallicFactor 0"},
                         text=gltf_document(name, aspect, base_color=f["basecolor"], normal=f["normal"],
                                            metallic_roughness=f["orm"], metallic_factor=0.0,
                                            specular_color=f["specularcolor"], specular_color_factor=factor,
                                            occlusion=ao is not None)),
        gltf_fallback=TextureFile(f["gltf_fallback"],
                                  {"content": "glTF 2.0 core metal-rough fallback (Khronos conversion)"},
                                  text=gltf_document(name + "_metalrough", aspect, base_color=f["fallback_basecolor"],
                                                     normal=f["normal"], metallic_roughness=f["orm"],
                                                     metallic_factor=1.0, occlusion=ao is not None)),
    )
    return _layout(p, files, f"{_WEIGHTED_BASE}; F0 = 0.04 * specularColorFactor * specularColorTexture; "
                             f"fallback: {_KHRONOS_MR}", m, name)


def _plan_metal_rough(maps: Maps, config: RenderConfig, p: TargetPreset, name: str) -> Layout:
    """Unreal's metal-rough set: base colour, normal, ORM (the Khronos conversion)."""
    m = maps.clipped()
    f = target_files(name, p.name)
    base, metallic = specgloss_to_metalrough(to_weighted_base(m.diffuse, m.specular, config), m.specular)
    info = {"basecolor": _describe("metal-rough base colour (Khronos conversion)", "sRGB", 8, 3),
            "normal": _normal_file(p)}
    files = _generic_files(p, name, f, info, diffuse=base, normal=m.normal)
    ao = _occlusion(m)
    orm = np.concatenate([np.ones_like(m.roughness) if ao is None else ao, m.roughness, metallic], axis=-1)
    files["orm"] = TextureFile(f["orm"], _describe(("R = ambient occlusion (1, none estimated)" if ao is None
                                                    else "R = ambient occlusion (1 = open)")
                                                   + ", G = roughness, B = metallic", "data", p.data_bits, 3),
                               orm, p.data_bits)
    return _layout(p, files, _KHRONOS_MR, m, name)


def _plan_principled(maps: Maps, config: RenderConfig, p: TargetPreset, name: str) -> Layout:
    """Blender's Principled BSDF inputs: base colour ``rho_d w_d``, ``Specular / scale`` with the scale in the
    sidecar, roughness and OpenGL normal (:func:`~.conversions.to_principled_base`,
    :func:`~.conversions.to_principled_specular`)."""
    m = maps.clipped()
    f = target_files(name, p.name)
    base = to_principled_base(m.diffuse, m.specular, config)
    scale, spec_tex = to_principled_specular(m.specular)
    files = _generic_files(p, name, f, {
        "basecolor": _describe(_PRINCIPLED_BASE, "sRGB", 8, 3),
        "normal": _normal_file(p),
        "roughness": _describe("Principled Roughness = roughness (alpha = roughness^2)", "data", p.data_bits, 1),
    }, diffuse=base, roughness=m.roughness, normal=m.normal)
    files["specular"] = TextureFile(f["specular"], _describe(
        "Principled Specular / principled_specular_scale (F0 = 0.08 x principled_specular_scale x value)", "data",
        p.data_bits, 1, principled_specular_scale=scale), spec_tex, p.data_bits)
    return _layout(p, files, f"{_PRINCIPLED_BASE}; Specular = F0 / 0.08 = principled_specular_scale x the spec "
                             f"file (scale {scale:.6g}); roughness and normal unchanged; Metallic 0", m, name)


def _plan_unity(maps: Maps, config: RenderConfig, p: TargetPreset, name: str) -> Layout:
    m = maps.clipped()
    f = target_files(name, p.name)
    albedo = to_weighted_base(m.diffuse, m.specular, config)
    spec_smooth = np.concatenate([_grey3(m.specular), roughness_to_smoothness(m.roughness)], axis=-1)
    files = _generic_files(p, name, f, {"basecolor": _describe(_WEIGHTED_BASE, "sRGB", 8, 3),
                                        "normal": _normal_file(p)}, diffuse=albedo, normal=m.normal)
    files["specular_smoothness"] = TextureFile(
        f["specular_smoothness"], _describe("RGB = specular F0 (grey), A = smoothness = 1 - roughness",
                                            "sRGB (RGB), linear (A)", p.data_bits, 4), spec_smooth, p.data_bits,
        srgb=True)
    ao = _occlusion(m)
    if ao is not None:
        role, template = p.relief_files["ao"]
        mask = np.concatenate([np.zeros_like(ao), ao, np.zeros_like(ao), roughness_to_smoothness(m.roughness)], -1)
        files[role] = TextureFile(template.format(name=name), _describe(
            "mask map: R = 0 (metallic), G = ambient occlusion (1 = open), B = 0 (detail mask), A = smoothness = "
            "1 - roughness", "data", p.data_bits, 4), mask, p.data_bits)
    return _layout(p, files, f"{_WEIGHTED_BASE}; smoothness = 1 - roughness", m, name)


def _plan_specular_workflow(maps: Maps, config: RenderConfig, p: TargetPreset, name: str) -> Layout:
    m = maps.clipped()
    f = target_files(name, p.name)
    base = to_weighted_base(m.diffuse, m.specular, config)
    files = _generic_files(p, name, f, {
        "basecolor": _describe(_WEIGHTED_BASE, "sRGB", 8, 3),
        "normal": _normal_file(p),
        "roughness": _describe("roughness (alpha = roughness^2)", "data", p.data_bits, 1),
        "specular": _describe("specular F0 (grey)", "linear", p.data_bits, 1),
    }, diffuse=base, specular=m.specular, roughness=m.roughness, normal=m.normal)
    if "normal_dx" in f:
        files["normal_dx"] = TextureFile(f["normal_dx"], _describe("normals, dx convention", "data", p.data_bits, 3,
                                                                   encoding="(n + 1) / 2"),
                                         encode_normal(normal_gl_to_dx(m.normal)), p.data_bits)
    relief = {}
    if m.relief is not None:
        for key, r_name in (("displacement", "height"), ("occlusion", "ao")):
            if getattr(m.relief, r_name) is not None:
                relief[key] = p.relief_files[r_name][1].format(name=name)
    if p.name == "usd":
        files["usda"] = TextureFile(
            f["usda"], {"content": "USD stage: unit quad + UsdPreviewSurface (useSpecularWorkflow = 1)"
                                   + (", displacement" if "displacement" in relief else "")
                                   + (", occlusion" if "occlusion" in relief else "")},
            text=usda_document(name, m.shape[0] / m.shape[1], diffuse_color=f["basecolor"],
                               specular_color=f["specular"], roughness=f["roughness"], normal=f["normal"],
                               height_scale=m.relief.scale if m.relief is not None else 0.0, **relief))
    else:
        files["mtlx"] = TextureFile(
            f["mtlx"], {"content": "MaterialX standard_surface, specular_IOR computed from F0"
                                   + (", displacement shader" if "displacement" in relief else "")},
            text=mtlx_document(name, base_color=f["basecolor"], specular_f0=f["specular"], roughness=f["roughness"],
                               normal=f["normal"], displacement=relief.get("displacement"),
                               height_scale=m.relief.scale if m.relief is not None else 0.0))
    return _layout(p, files, f"{_WEIGHTED_BASE}; F0, roughness and normal unchanged"
                   + ("; specular_IOR = (1 + sqrt F0) / (1 - sqrt F0)" if p.name != "usd" else ""), m, name)


#: Target -> layout builder ``(maps, config, preset, name) -> Layout``.
_PLANS: Mapping[str, Builder] = {
    "generic": _plan_generic, "gltf": _plan_gltf, "blender": _plan_principled, "unreal": _plan_metal_rough,
    "unity": _plan_unity, "usd": _plan_specular_workflow, "mtlx": _plan_specular_workflow,
    "ambientcg": _plan_specular_workflow}


def target_files(name: str, target: str = "generic", relit: bool = False,
                 relief: Tuple[str, ...] = ()) -> Dict[str, str]:
    """File names a target writes for a set called ``name``: role -> file name (sidecar and relit included), in
    the order written; ``relief``: the relief maps of the set (:data:`~svbrdf.runtime.core.relief.RELIEF_NAMES`),
    whose separate files the target writes."""
    if target not in PRESETS:
        raise ValueError(f"unknown target {target!r}; expected one of {', '.join(TARGETS)}")
    p = PRESETS[target]
    names = {role: t.format(name=name) for role, t in p.files.items()}
    for r_name in ("height", "ao"):
        if r_name in relief and r_name in p.relief_files:
            role, template = p.relief_files[r_name]
            names[role] = template.format(name=name)
    names["sidecar"] = SIDECAR_FILE.format(name=name)
    if relit:
        names["relit"] = RELIT_FILE.format(name=name)
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
        maps: the texture set (our model; ``maps.render_config`` selects the diffuse weighting used by the
            conversions, default ``ZHAO``).
        out_dir: output folder, created (with parents) if missing.
        name: base name of the files (no path separators).
        target: one of :data:`TARGETS`. ``"generic"`` is exactly
            :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set` with its defaults.
        force: overwrite existing files.
        extra_meta: more metadata for the sidecar (see :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set`).
        relit: optional sRGB-encoded (h, w, 3) preview, written as ``<name>_relit.png``.

    Returns:
        Paths written, keyed by role (:func:`target_files`).

    Raises:
        ValueError: unknown target, a subset of the maps for a target other than ``generic`` (and the argument
            errors of :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set`).
        ImageError: a target file exists (and not ``force``), bad name or folder, NaN/Inf in a map, or a write
            failed. Nothing is left behind in these cases.
    """
    if target not in PRESETS:
        raise ValueError(f"unknown target {target!r}; expected one of {', '.join(TARGETS)}")
    if target != "generic":
        maps.require(what=f"target {target!r}")  # every preset's base colour / packing converts all four maps
    preset = PRESETS[target]
    order = list(target_files(name, target, relief=maps.relief.names if maps.relief is not None else ()))

    def plan(m: Maps, config: RenderConfig) -> Layout:
        layout = _PLANS[target](m, config, preset, name)
        return replace(layout, files={role: layout.files[role] for role in sorted(layout.files, key=order.index)})

    return write_layout(maps, out_dir, name, plan, force=force, extra_meta=extra_meta, relit=relit)


__all__ = ["TARGETS", "PRESETS", "TargetPreset", "write_target", "target_files", "RELIEF_FILES"]
