"""Material documents for a texture set: glTF 2.0 (with a unit quad), MaterialX and USD, as plain text.

No third-party library is needed to write them (the runtime stays light); the test suite checks them with the
real consumers (Khronos glTF-Validator, pygltflib, MaterialX, usd-core) where those are installed.

Geometry shared by the glTF and USD documents: a quad one unit wide and ``aspect = height / width`` units high,
centred on the origin in the XY plane and facing +Z (Y is up in both formats), so it looks like the photo
from a default camera. Its texture coordinates put the top-left image pixel at the top-left corner (glTF UV
(0, 0); USD st (0, 1), as USD's st origin is the lower-left), and its tangent frame is +X (tangent) / +Y
(bitangent) / +Z, so an OpenGL-convention normal map (+y up the image) is used as is.

Texture references are file names relative to the document (the documents are written next to the textures).
"""

from __future__ import annotations

import base64
import json
import re
import struct
from typing import Optional
from urllib.parse import quote
from xml.sax.saxutils import quoteattr

from .. import __version__

_GENERATOR = f"svbrdf {__version__}"

# glTF enums (glTF 2.0 specification, section 5).
_FLOAT, _USHORT = 5126, 5123
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_LINEAR, _LINEAR_MIPMAP_LINEAR = 9729, 9987


def _quad(aspect: float):
    """Corner positions (bottom-left, bottom-right, top-right, top-left; counter-clockwise seen from +Z)."""
    hx, hy = 0.5, 0.5 * aspect
    return [(-hx, -hy, 0.0), (hx, -hy, 0.0), (hx, hy, 0.0), (-hx, hy, 0.0)]


def _check_aspect(aspect: float) -> float:
    aspect = float(aspect)
    if not aspect > 0.0 or aspect != aspect or aspect == float("inf"):
        raise ValueError(f"aspect must be a positive finite number, got {aspect!r}")
    return aspect


def _quad_buffer(aspect: float):
    """Binary buffer (bytes) and the glTF bufferViews/accessors of the quad (one view per attribute)."""
    pos = _quad(aspect)
    attributes = [
        ("POSITION", "VEC3", pos),
        ("NORMAL", "VEC3", [(0.0, 0.0, 1.0)] * 4),
        ("TANGENT", "VEC4", [(1.0, 0.0, 0.0, 1.0)] * 4),  # w = +1: bitangent = normal x tangent = +Y
        ("TEXCOORD_0", "VEC2", [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]),  # glTF UV origin: top-left
    ]
    blob, views, accessors, names = b"", [], [], {}
    for name, kind, rows in attributes:
        data = b"".join(struct.pack(f"<{len(r)}f", *r) for r in rows)
        acc = {"bufferView": len(views), "componentType": _FLOAT, "count": len(rows), "type": kind}
        if name == "POSITION":  # required on POSITION by the spec
            acc["min"] = [min(r[i] for r in rows) for i in range(3)]
            acc["max"] = [max(r[i] for r in rows) for i in range(3)]
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": _ARRAY_BUFFER})
        names[name] = len(accessors)
        accessors.append(acc)
        blob += data
    indices = struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(indices),
                  "target": _ELEMENT_ARRAY_BUFFER})
    accessors.append({"bufferView": len(views) - 1, "componentType": _USHORT, "count": 6, "type": "SCALAR"})
    return blob + indices, views, accessors, names, len(accessors) - 1


def gltf_document(
    name: str,
    aspect: float,
    *,
    base_color: str,
    normal: str,
    metallic_roughness: str,
    metallic_factor: float,
    specular_color: Optional[str] = None,
    specular_color_factor: float = 1.0,
    occlusion: bool = False,
) -> str:
    """A glTF 2.0 JSON document: one unit quad (buffer embedded as a data URI) with one textured material.

    Args:
        name: material/mesh name.
        aspect: height / width of the texture set.
        base_color: file of ``baseColorTexture`` (RGB, sRGB-encoded).
        normal: file of ``normalTexture`` (OpenGL convention, ``(n + 1) / 2``, linear).
        metallic_roughness: file of ``metallicRoughnessTexture`` (G = roughness, B = metalness, linear).
        metallic_factor: ``metallicFactor`` (0 switches the texture's metalness off).
        specular_color: file of KHR_materials_specular ``specularColorTexture`` (sRGB), or ``None`` for a core
            glTF material without the extension.
        specular_color_factor: grey ``specularColorFactor`` (may exceed 1).
        occlusion: the red channel of ``metallic_roughness`` holds ambient occlusion (an ORM texture, 1 = open):
            the material's ``occlusionTexture`` references it too (glTF reads occlusion from R).

    Returns:
        The document as JSON text.
    """
    aspect = _check_aspect(aspect)
    blob, views, accessors, attrs, indices = _quad_buffer(aspect)
    images = [base_color, normal, metallic_roughness] + ([specular_color] if specular_color else [])
    material = {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0},
            "metallicRoughnessTexture": {"index": 2},
            "metallicFactor": float(metallic_factor),
            "roughnessFactor": 1.0,
        },
        "normalTexture": {"index": 1},
    }
    if occlusion:
        material["occlusionTexture"] = {"index": 2}
    doc = {
        "asset": {"version": "2.0", "generator": _GENERATOR},
        "scene": 0,
        "scenes": [{"name": name, "nodes": [0]}],
        "nodes": [{"name": name, "mesh": 0}],
        "meshes": [{"name": name, "primitives": [{"attributes": attrs, "indices": indices, "material": 0}]}],
        "materials": [material],
        "textures": [{"sampler": 0, "source": i} for i in range(len(images))],
        "images": [{"uri": quote(f)} for f in images],
        "samplers": [{"magFilter": _LINEAR, "minFilter": _LINEAR_MIPMAP_LINEAR}],
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")}],
        "bufferViews": views,
        "accessors": accessors,
    }
    if specular_color:
        doc["extensionsUsed"] = ["KHR_materials_specular"]  # not "required": viewers without it still load
        material["extensions"] = {"KHR_materials_specular": {
            "specularFactor": 1.0,
            "specularColorFactor": [float(specular_color_factor)] * 3,
            "specularColorTexture": {"index": 3},
        }}
    return json.dumps(doc, indent=2) + "\n"


def usd_identifier(name: str) -> str:
    """A valid USD prim / MaterialX element name made from ``name`` (other characters become ``_``)."""
    ident = re.sub(r"[^A-Za-z0-9_]", "_", name)
    return ident if ident and not ident[0].isdigit() else "_" + ident


def _usd_asset(path: str) -> str:
    if "@" in path:
        raise ValueError(f"file name {path!r} cannot be written as a USD asset path ('@')")
    return f"@./{path}@"


def usda_document(name: str, aspect: float, *, diffuse_color: str, specular_color: str, roughness: str,
                  normal: str, displacement: Optional[str] = None, height_scale: float = 0.0,
                  occlusion: Optional[str] = None) -> str:
    """A USD stage (``.usda`` text): the unit quad bound to a UsdPreviewSurface in the specular workflow.

    Args:
        name: asset name (made a valid identifier for the root prim).
        aspect: height / width of the texture set.
        diffuse_color: file for ``diffuseColor`` (RGB, sRGB-encoded; ``sourceColorSpace = "sRGB"``).
        specular_color: file for ``specularColor`` = F0 (grey, linear, ``"raw"``; a one-channel file is
            broadcast to RGB by UsdUVTexture).
        roughness: file for ``roughness`` (grey, linear, ``"raw"``; alpha = roughness^2).
        normal: file for ``normal`` (OpenGL convention, ``(n + 1) / 2``, ``"raw"``, scale 2 and bias -1).
        displacement: file for ``displacement`` (the height map, grey, ``"raw"``; white = high, 0.5 = the mean
            level), or None; read with scale ``height_scale`` and bias ``-height_scale / 2``, so the displacement is
            the height in scene units of the quad (one unit wide: the map's width).
        height_scale: the height black to white spans, in units of the map's width.
        occlusion: file for ``occlusion`` (ambient occlusion, grey, ``"raw"``, 1 = open), or None.

    Returns:
        The layer as text, ``defaultPrim`` set to the root prim.
    """
    aspect = _check_aspect(aspect)
    root = usd_identifier(name)
    mat = f"/{root}/Looks/Material"
    pts = ", ".join(f"({x:g}, {y:g}, {z:g})" for x, y, z in _quad(aspect))
    lo, hi = _quad(aspect)[0], _quad(aspect)[2]

    def texture(prim: str, file: str, colour_space: str, output: str, scale_bias: str = "") -> str:
        return f"""
            def Shader "{prim}"
            {{
                uniform token info:id = "UsdUVTexture"
                asset inputs:file = {_usd_asset(file)}
                token inputs:sourceColorSpace = "{colour_space}"
                float2 inputs:st.connect = <{mat}/StReader.outputs:result>{scale_bias}
                {output}
            }}"""

    normal_sb = """
                float4 inputs:scale = (2, 2, 2, 1)
                float4 inputs:bias = (-1, -1, -1, 0)"""
    hs = float(height_scale)
    if not hs >= 0.0 or hs == float("inf"):
        raise ValueError(f"height_scale must be a finite number >= 0, got {height_scale!r}")
    height_sb = f"""
                float4 inputs:scale = ({hs!r}, {hs!r}, {hs!r}, 1)
                float4 inputs:bias = ({-hs / 2!r}, {-hs / 2!r}, {-hs / 2!r}, 0)"""
    extra_inputs = ""
    extra_textures = ""
    if displacement:
        extra_inputs += f"\n                float inputs:displacement.connect = <{mat}/Displacement.outputs:r>"
        extra_textures += "\n" + texture("Displacement", displacement, "raw", "float outputs:r", height_sb)
    if occlusion:
        extra_inputs += f"\n                float inputs:occlusion.connect = <{mat}/Occlusion.outputs:r>"
        extra_textures += "\n" + texture("Occlusion", occlusion, "raw", "float outputs:r")
    return f"""#usda 1.0
(
    defaultPrim = "{root}"
    doc = "Generated by {_GENERATOR}"
    metersPerUnit = 1
    upAxis = "Y"
)

def Xform "{root}" (
    kind = "component"
)
{{
    def Mesh "Quad" (
        prepend apiSchemas = ["MaterialBindingAPI"]
    )
    {{
        float3[] extent = [({lo[0]:g}, {lo[1]:g}, 0), ({hi[0]:g}, {hi[1]:g}, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        rel material:binding = <{mat}>
        normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)] (
            interpolation = "vertex"
        )
        point3f[] points = [{pts}]
        texCoord2f[] primvars:st = [(0, 0), (1, 0), (1, 1), (0, 1)] (
            interpolation = "vertex"
        )
        uniform token subdivisionScheme = "none"
    }}

    def Scope "Looks"
    {{
        def Material "Material"
        {{
            token outputs:surface.connect = <{mat}/PreviewSurface.outputs:surface>

            def Shader "PreviewSurface"
            {{
                uniform token info:id = "UsdPreviewSurface"
                int inputs:useSpecularWorkflow = 1
                color3f inputs:diffuseColor.connect = <{mat}/DiffuseColor.outputs:rgb>
                color3f inputs:specularColor.connect = <{mat}/SpecularColor.outputs:rgb>
                float inputs:roughness.connect = <{mat}/Roughness.outputs:r>
                normal3f inputs:normal.connect = <{mat}/Normal.outputs:rgb>
                float inputs:metallic = 0{extra_inputs}
                token outputs:surface
            }}

            def Shader "StReader"
            {{
                uniform token info:id = "UsdPrimvarReader_float2"
                string inputs:varname = "st"
                float2 outputs:result
            }}
{texture("DiffuseColor", diffuse_color, "sRGB", "float3 outputs:rgb")}
{texture("SpecularColor", specular_color, "raw", "float3 outputs:rgb")}
{texture("Roughness", roughness, "raw", "float outputs:r")}
{texture("Normal", normal, "raw", "float3 outputs:rgb", normal_sb)}{extra_textures}
        }}
    }}
}}
"""


def mtlx_document(name: str, *, base_color: str, specular_f0: str, roughness: str, normal: str,
                  displacement: Optional[str] = None, height_scale: float = 0.0) -> str:
    """A MaterialX 1.39 document: ``standard_surface`` fed by a node graph that reads the four maps.

    ``standard_surface`` rather than ``open_pbr_surface``: it is understood by every MaterialX consumer we know
    of (OpenPBR needs MaterialX >= 1.39 and few renderers read it yet), and its dielectric specular maps our
    F0 exactly through the index of refraction: the graph computes ``specular_IOR = (1 + sqrt F0) /
    (1 - sqrt F0)`` per pixel (F0 clamped to 0.99), with ``specular = 1`` and a white ``specular_color`` so
    that F90 stays 1 as in our Schlick term. ``base = 1`` (the node's default is 0.8), ``metalness = 0``.

    Args:
        name: material name (made a valid element name).
        base_color: file of the base colour (sRGB-encoded; ``colorspace="srgb_texture"``).
        specular_f0: file of F0 (grey, linear).
        roughness: file of the roughness (grey, linear; alpha = roughness^2 in standard_surface).
        normal: file of the tangent-space normals (OpenGL convention, ``(n + 1) / 2``).
        displacement: file of the height map (grey, linear; white = high, 0.5 = the mean level), or None: the
            material then gets a ``displacement`` shader of ``value - 0.5`` with ``scale = height_scale``, the
            height in scene units for a surface one unit wide (scale it by the surface's width).
        height_scale: the height black to white spans, in units of the map's width.

    Returns:
        The document as XML text.
    """
    ident = usd_identifier(name)
    ng = f"NG_{ident}"
    def image(node: str, kind: str, file: str, colorspace: str = "") -> str:
        cs = f" colorspace={quoteattr(colorspace)}" if colorspace else ""
        return (f'    <image name="{node}" type="{kind}">\n'
                f'      <input name="file" type="filename" value={quoteattr(file)}{cs} />\n'
                f"    </image>\n")

    hs = float(height_scale)
    if not hs >= 0.0 or hs == float("inf"):
        raise ValueError(f"height_scale must be a finite number >= 0, got {height_scale!r}")
    height_nodes = height_output = displacement_shader = material_input = ""
    if displacement:
        height_nodes = (image("height_image", "float", displacement)
                        + '    <subtract name="height_centred" type="float">\n'
                          '      <input name="in1" type="float" nodename="height_image" />\n'
                          '      <input name="in2" type="float" value="0.5" />\n'
                          '    </subtract>\n')
        height_output = '    <output name="height_out" type="float" nodename="height_centred" />\n'
        displacement_shader = (f'  <displacement name="DS_{ident}" type="displacementshader">\n'
                               f'    <input name="displacement" type="float" nodegraph="{ng}" output="height_out" />\n'
                               f'    <input name="scale" type="float" value="{hs!r}" />\n'
                               f'  </displacement>\n')
        material_input = (f'    <input name="displacementshader" type="displacementshader" '
                          f'nodename="DS_{ident}" />\n')


    return f"""<?xml version="1.0"?>
<!-- Generated by {_GENERATOR} -->
<materialx version="1.39" colorspace="lin_rec709">
  <nodegraph name="{ng}">
{image("base_color_image", "color3", base_color, "srgb_texture")}{image("f0_image", "float", specular_f0)}\
{image("roughness_image", "float", roughness)}{image("normal_image", "vector3", normal)}{height_nodes}\
    <normalmap name="normal_map" type="vector3">
      <input name="in" type="vector3" nodename="normal_image" />
    </normalmap>
    <clamp name="f0" type="float">
      <input name="in" type="float" nodename="f0_image" />
      <input name="low" type="float" value="0.0" />
      <input name="high" type="float" value="0.99" />
    </clamp>
    <sqrt name="sqrt_f0" type="float">
      <input name="in" type="float" nodename="f0" />
    </sqrt>
    <add name="ior_numerator" type="float">
      <input name="in1" type="float" value="1.0" />
      <input name="in2" type="float" nodename="sqrt_f0" />
    </add>
    <subtract name="ior_denominator" type="float">
      <input name="in1" type="float" value="1.0" />
      <input name="in2" type="float" nodename="sqrt_f0" />
    </subtract>
    <divide name="ior" type="float">
      <input name="in1" type="float" nodename="ior_numerator" />
      <input name="in2" type="float" nodename="ior_denominator" />
    </divide>
    <output name="base_color_out" type="color3" nodename="base_color_image" />
    <output name="roughness_out" type="float" nodename="roughness_image" />
    <output name="ior_out" type="float" nodename="ior" />
    <output name="normal_out" type="vector3" nodename="normal_map" />
{height_output}  </nodegraph>
  <standard_surface name="SR_{ident}" type="surfaceshader">
    <input name="base" type="float" value="1.0" />
    <input name="base_color" type="color3" nodegraph="{ng}" output="base_color_out" />
    <input name="metalness" type="float" value="0.0" />
    <input name="specular" type="float" value="1.0" />
    <input name="specular_color" type="color3" value="1.0, 1.0, 1.0" />
    <input name="specular_roughness" type="float" nodegraph="{ng}" output="roughness_out" />
    <input name="specular_IOR" type="float" nodegraph="{ng}" output="ior_out" />
    <input name="normal" type="vector3" nodegraph="{ng}" output="normal_out" />
  </standard_surface>
{displacement_shader}  <surfacematerial name="M_{ident}" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="SR_{ident}" />
{material_input}  </surfacematerial>
</materialx>
"""


__all__ = ["gltf_document", "usda_document", "mtlx_document", "usd_identifier"]
