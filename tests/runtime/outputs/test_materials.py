"""Material documents, checked by their real consumers where installed (each check skips with the reason).

* glTF: the Khronos glTF-Validator (npm package ``gltf-validator``, run with ``node``; found through
  ``NODE_PATH``, e.g. ``npm install --prefix /opt/npm gltf-validator`` and ``NODE_PATH=/opt/npm/node_modules``),
  and ``pygltflib`` as a second reader;
* MaterialX: the ``MaterialX`` package (document ``validate()`` against the standard libraries, texture paths
  resolve, GLSL generation);
* USD: ``usd-core`` (``pxr``): the stage opens, the material binds, shader inputs point at the right files with
  the right colour spaces, and OpenUSD's own validators (``UsdValidation``) report no error.
"""

import base64
import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from svbrdf.runtime.core.maps import Maps, normalize_normals
from svbrdf.runtime.core.relief import with_relief
from svbrdf.runtime.outputs.materials import gltf_document, mtlx_document, usd_identifier, usda_document
from svbrdf.runtime.outputs.targets import write_target

H, W = 12, 16
_VALIDATE_JS = r"""
const fs = require('fs'), path = require('path'), validator = require('gltf-validator');
const file = process.argv[1];
validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
  uri: path.basename(file), format: 'gltf', writeTimestamp: false, maxIssues: 0,
  externalResourceFunction: (uri) => new Promise((resolve, reject) => fs.readFile(
      path.resolve(path.dirname(file), decodeURIComponent(uri)), (e, d) => e ? reject(e.toString()) : resolve(d)))
}).then((r) => console.log(JSON.stringify(r)), (e) => { console.error(String(e)); process.exit(2); });
"""


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The gltf, usd, mtlx and ambientcg targets of one small texture set with its height and AO (a name with a
    space, to test URI quoting)."""
    rng = np.random.default_rng(0)
    n = rng.normal(size=(H, W, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 1.0
    maps = with_relief(Maps(rng.uniform(0.05, 0.5, (H, W, 3)), rng.uniform(0.02, 0.5, (H, W, 1)),
                            rng.uniform(0.1, 0.9, (H, W, 1)), normalize_normals(n)))
    root = tmp_path_factory.mktemp("targets")
    return {t: write_target(maps, root / t, "oak floor", t) for t in ("gltf", "usd", "mtlx", "ambientcg")}


def _buffer_floats(doc, accessor):
    acc = doc["accessors"][accessor]
    view = doc["bufferViews"][acc["bufferView"]]
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    width = {"VEC2": 2, "VEC3": 3, "VEC4": 4}[acc["type"]]
    data = blob[view["byteOffset"]:view["byteOffset"] + view["byteLength"]]
    return np.array(struct.unpack(f"<{acc['count'] * width}f", data)).reshape(acc["count"], width)


# ------------------------------------------------------------------------------------------- our own checks


def test_gltf_quad_geometry():
    doc = json.loads(gltf_document("m", 0.75, base_color="b.png", normal="n.png", metallic_roughness="o.png",
                                   metallic_factor=0.0, specular_color="s.png", specular_color_factor=7.5))
    attrs = doc["meshes"][0]["primitives"][0]["attributes"]
    pos, uv = _buffer_floats(doc, attrs["POSITION"]), _buffer_floats(doc, attrs["TEXCOORD_0"])
    np.testing.assert_allclose(pos[:, :2].min(0), [-0.5, -0.375])  # one unit wide, aspect 0.75
    np.testing.assert_allclose(pos[:, :2].max(0), [0.5, 0.375])
    top_left = np.argmin(pos[:, 0] - pos[:, 1])
    np.testing.assert_array_equal(uv[top_left], [0, 0])  # glTF UV origin = top-left image pixel
    np.testing.assert_array_equal(_buffer_floats(doc, attrs["TANGENT"]), [[1, 0, 0, 1]] * 4)
    a, b, c = pos[:3]
    assert np.cross(b - a, c - a)[2] > 0  # counter-clockwise seen from +Z: front face towards the viewer
    assert doc["materials"][0]["extensions"]["KHR_materials_specular"]["specularColorFactor"] == [7.5] * 3
    with pytest.raises(ValueError, match="aspect"):
        gltf_document("m", 0.0, base_color="b", normal="n", metallic_roughness="o", metallic_factor=0)


def test_names_and_paths():
    assert usd_identifier("oak floor-2") == "oak_floor_2" and usd_identifier("3d") == "_3d"
    doc = json.loads(gltf_document("m", 1, base_color="a b#.png", normal="n", metallic_roughness="o",
                                   metallic_factor=0))
    assert doc["images"][0]["uri"] == "a%20b%23.png"
    with pytest.raises(ValueError, match="USD asset path"):
        usda_document("m", 1, diffuse_color="a@b.png", specular_color="s", roughness="r", normal="n")
    assert 'value="a &amp; b.png"' in mtlx_document("m", base_color="a & b.png", specular_f0="s",
                                                   roughness="r", normal="n")


# ------------------------------------------------------------------------------------------------- glTF


def _node_with_validator():
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed (needed for the Khronos glTF-Validator)")
    res = subprocess.run([node, "-e", "require.resolve('gltf-validator')"], capture_output=True, text=True,
                         timeout=60)
    if res.returncode != 0:
        pytest.skip("npm package gltf-validator not found (install it and put its node_modules on NODE_PATH)")
    return node


@pytest.mark.parametrize("role", ["gltf", "gltf_fallback"])
def test_khronos_gltf_validator(written, role):
    node = _node_with_validator()
    res = subprocess.run([node, "-e", _VALIDATE_JS, str(written["gltf"][role])], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    report = json.loads(res.stdout)
    issues = report["issues"]
    assert issues["numErrors"] == 0 and issues["numWarnings"] == 0, issues["messages"]
    # Only "image is not a power of two" infos are expected at this size.
    assert {m["code"] for m in issues["messages"]} <= {"IMAGE_NPOT_DIMENSIONS"}
    images = [r for r in report["info"]["resources"] if r["pointer"].startswith("/images/")]
    assert len(images) == (4 if role == "gltf" else 3)
    assert all(r["image"]["width"] == W and r["image"]["height"] == H for r in images)  # every file was loaded


def test_pygltflib_reads_it(written):
    pygltflib = pytest.importorskip("pygltflib")
    paths = written["gltf"]
    gltf = pygltflib.GLTF2().load(str(paths["gltf"]))
    mat = gltf.materials[0]
    assert mat.extensions["KHR_materials_specular"]["specularColorTexture"]["index"] == 3
    assert mat.pbrMetallicRoughness.metallicFactor == 0.0 and mat.normalTexture.index == 1
    folder = paths["gltf"].parent
    uris = [gltf.images[gltf.textures[i].source].uri for i in range(4)]
    assert [(folder / u.replace("%20", " ")).is_file() for u in uris] == [True] * 4
    assert uris[0] == "oak%20floor_basecolor.png"
    prim = gltf.meshes[0].primitives[0]
    acc = gltf.accessors[prim.attributes.POSITION]
    assert acc.count == 4 and acc.min[:2] == [-0.5, -0.375]
    fallback = pygltflib.GLTF2().load(str(paths["gltf_fallback"]))
    assert not fallback.materials[0].extensions and fallback.materials[0].pbrMetallicRoughness.metallicFactor == 1.0
    for doc in (gltf, fallback):  # the ORM texture's red channel is the occlusion
        occlusion = doc.materials[0].occlusionTexture
        assert occlusion is not None and occlusion.index == doc.materials[0].pbrMetallicRoughness.\
            metallicRoughnessTexture.index == 2


# -------------------------------------------------------------------------------------------- MaterialX


def _mtlx_document(mx, path):
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(path))
    libs = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), libs)
    doc.importLibrary(libs)
    return doc


@pytest.mark.parametrize("target", ["mtlx", "ambientcg"])
def test_materialx_validates_and_resolves(written, target):
    mx = pytest.importorskip("MaterialX")
    path = written[target]["mtlx"]
    doc = _mtlx_document(mx, path)
    ok, message = doc.validate()
    assert ok, message
    material = doc.getMaterialNodes()
    assert [m.getName() for m in material] == ["M_oak_floor"]
    shader = mx.getShaderNodes(material[0])[0]
    assert shader.getCategory() == "standard_surface"
    assert shader.getInputValue("base") == 1.0 and shader.getInputValue("metalness") == 0.0
    images = {n.getName(): n for n in doc.getNodeGraph("NG_oak_floor").getNodes("image")}
    expect = {"base_color_image": ("basecolor", "srgb_texture"), "f0_image": ("specular", ""),
              "roughness_image": ("roughness", ""), "normal_image": ("normal", ""), "height_image": ("height", "")}
    assert set(images) == set(expect)
    for node, (role, colour_space) in expect.items():
        inp = images[node].getInput("file")
        assert (path.parent / inp.getResolvedValueString()).resolve() == written[target][role].resolve()
        assert inp.getActiveColorSpace() == (colour_space or "lin_rec709"), node
    # the height drives the material's displacement shader: (value - 0.5) * height_scale
    displacement = material[0].getInput("displacementshader").getConnectedNode()
    assert displacement.getCategory() == "displacement"
    scale = json.loads(written[target]["sidecar"].read_text())["relief"]["height_scale"]
    assert displacement.getInputValue("scale") == pytest.approx(scale) and scale > 0
    centred = doc.getNodeGraph("NG_oak_floor").getNode("height_centred")
    assert centred.getCategory() == "subtract" and centred.getInputValue("in2") == 0.5


def test_materialx_validate_catches_a_broken_graph(written):
    mx = pytest.importorskip("MaterialX")
    text = written["mtlx"]["mtlx"].read_text().replace('<sqrt name="sqrt_f0" type="float">',
                                                       '<sqrt name="sqrt_f0" type="color3">')
    broken = written["mtlx"]["mtlx"].with_name("broken.mtlx")
    broken.write_text(text)
    try:
        ok, _ = _mtlx_document(mx, broken).validate()
    finally:
        broken.unlink()
    assert not ok  # so the check above can fail


def test_materialx_generates_glsl(written):
    mx = pytest.importorskip("MaterialX")
    gen_glsl = pytest.importorskip("MaterialX.PyMaterialXGenGlsl")
    gen_shader = pytest.importorskip("MaterialX.PyMaterialXGenShader")
    doc = _mtlx_document(mx, written["mtlx"]["mtlx"])
    gen = gen_glsl.GlslShaderGenerator.create()
    context = gen_shader.GenContext(gen)
    context.registerSourceCodeSearchPath(mx.getDefaultDataSearchPath())
    cms = gen_shader.DefaultColorManagementSystem.create(gen.getTarget())
    cms.loadLibrary(doc)
    gen.setColorManagementSystem(cms)
    shader = gen.generate("M_oak_floor", doc.getMaterialNodes()[0], context)
    source = shader.getSourceCode(gen_shader.PIXEL_STAGE)
    # The base colour, and only it, goes through the sRGB decode (one definition + one call).
    assert source.count("srgb_texture_to_lin_rec709_color3(") == 2
    assert "srgb_texture_to_lin_rec709_color3(base_color_image_out" in source


# -------------------------------------------------------------------------------------------------- USD


def test_usd_stage_binds_and_points_at_the_files(written):
    pytest.importorskip("pxr", reason="usd-core is not installed")
    from pxr import Usd, UsdGeom, UsdShade

    paths = written["usd"]
    stage = Usd.Stage.Open(str(paths["usda"]))
    assert stage is not None and stage.GetDefaultPrim().GetName() == "oak_floor"
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    quad = stage.GetPrimAtPath("/oak_floor/Quad")
    material, _ = UsdShade.MaterialBindingAPI(quad).ComputeBoundMaterial()
    assert material and material.GetPath() == "/oak_floor/Looks/Material"
    surface = material.ComputeSurfaceSource()[0]
    assert surface.GetIdAttr().Get() == "UsdPreviewSurface"
    assert surface.GetInput("useSpecularWorkflow").Get() == 1
    expect = {"diffuseColor": ("basecolor", "sRGB", "rgb"), "specularColor": ("specular", "raw", "rgb"),
              "roughness": ("roughness", "raw", "r"), "normal": ("normal", "raw", "rgb"),
              "displacement": ("height", "raw", "r"), "occlusion": ("ao", "raw", "r")}
    for name, (role, colour_space, output) in expect.items():
        source, out_name, _ = surface.GetInput(name).GetConnectedSource()
        texture = UsdShade.Shader(source.GetPrim())
        assert texture.GetIdAttr().Get() == "UsdUVTexture" and out_name == output
        asset = texture.GetInput("file").Get()
        assert Path(asset.resolvedPath) == paths[role].resolve(), name
        assert texture.GetInput("sourceColorSpace").Get() == colour_space, name
    normal_tex = UsdShade.Shader(surface.GetInput("normal").GetConnectedSource()[0].GetPrim())
    assert tuple(normal_tex.GetInput("scale").Get()) == (2, 2, 2, 1)
    assert tuple(normal_tex.GetInput("bias").Get()) == (-1, -1, -1, 0)
    scale = json.loads(paths["sidecar"].read_text())["relief"]["height_scale"]
    height_tex = UsdShade.Shader(surface.GetInput("displacement").GetConnectedSource()[0].GetPrim())
    np.testing.assert_allclose(height_tex.GetInput("scale").Get(), (scale, scale, scale, 1), rtol=1e-6)
    np.testing.assert_allclose(height_tex.GetInput("bias").Get(), (-scale / 2, -scale / 2, -scale / 2, 0), rtol=1e-6)
    st = UsdGeom.PrimvarsAPI(quad).GetPrimvar("st").Get()
    points = UsdGeom.Mesh(quad).GetPointsAttr().Get()
    top_left = min(range(4), key=lambda i: points[i][0] - points[i][1])
    assert tuple(st[top_left]) == (0, 1)  # USD st origin is the lower-left: the top-left pixel is at t = 1


def test_usd_validators_report_no_error(written):
    pytest.importorskip("pxr", reason="usd-core is not installed")
    from pxr import Usd

    try:
        from pxr import UsdValidation
    except ImportError:
        pytest.skip("this usd-core has no UsdValidation framework")
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    names = {v.GetMetadata().name for v in validators}
    assert "usdShadeValidators:NormalMapTextureValidator" in names  # checks normal colour space and scale/bias
    stage = Usd.Stage.Open(str(written["usd"]["usda"]))
    errors = UsdValidation.ValidationContext(validators).Validate(stage)
    assert [(e.GetName(), e.GetMessage()) for e in errors] == []


def test_usd_validators_catch_an_srgb_normal_map(written, tmp_path):
    pytest.importorskip("pxr", reason="usd-core is not installed")
    from pxr import Usd

    try:
        from pxr import UsdValidation
    except ImportError:
        pytest.skip("this usd-core has no UsdValidation framework")
    text = written["usd"]["usda"].read_text()
    at = text.index('def Shader "Normal"')
    text = text[:at] + text[at:].replace('"raw"', '"sRGB"', 1)
    broken = tmp_path / "broken.usda"
    broken.write_text(text.replace("@./", "@" + os.fspath(written["usd"]["usda"].parent) + "/"))
    errors = UsdValidation.ValidationContext(UsdValidation.ValidationRegistry().GetOrLoadAllValidators()).Validate(
        Usd.Stage.Open(str(broken)))
    assert "InvalidSourceColorSpace" in {e.GetName() for e in errors}
