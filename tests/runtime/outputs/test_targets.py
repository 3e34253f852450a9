"""Target presets (files, encodings, packing, safety), the parameter conversions, and a Mitsuba render check."""

import json

import numpy as np
import pytest

from ..conftest import read_stored
from svbrdf.runtime.outputs import conversions as cv
from svbrdf.runtime.core.colour import srgb_to_linear
from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.io.images import image_info, read_image
from svbrdf.runtime.core.maps import Maps, normalize_normals
from svbrdf.runtime.core.relief import with_relief
from svbrdf.runtime.core.render import DESCHAINTRE, ZHAO, RenderConfig, render
from svbrdf.runtime.outputs.targets import PRESETS, TARGETS, target_files, write_target
from svbrdf.runtime.outputs.texture_set import write_texture_set

H, W = 12, 16
Q8, Q16 = 0.5 / 255 + 1e-6, 0.5 / 65535 + 1e-6  # half a quantisation step


@pytest.fixture
def maps():
    rng = np.random.default_rng(0)
    n = rng.normal(size=(H, W, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 1.0
    spec = rng.uniform(0.02, 0.6, (H, W, 1)).astype(np.float32)
    spec[0, 0] = 0.01  # a pixel below the dielectric F0 (metallic 0 in the Khronos conversion)
    return Maps(
        diffuse=rng.uniform(0.05, 0.45, (H, W, 3)).astype(np.float32),
        specular=spec,
        roughness=rng.uniform(0.1, 0.9, (H, W, 1)).astype(np.float32),
        normal=normalize_normals(n),
        meta={"source": "photo.jpg"},
    )


# ---------------------------------------------------------------------------------------------- conversions


@pytest.mark.parametrize("config", [ZHAO, DESCHAINTRE])
def test_weighted_base_round_trip_and_meaning(maps, config):
    base = cv.to_weighted_base(maps.diffuse, maps.specular, config)
    w_d = 1.0 - maps.specular if config.diffuse_conservation else np.ones_like(maps.specular)
    fits = np.broadcast_to(maps.diffuse * w_d / (1.0 - maps.specular) <= 1.0, base.shape)
    # The target's diffuse lobe at normal incidence, (1 - F0) base, equals ours, w_d rho_d, wherever the base
    # colour fits in [0, 1]; elsewhere it saturates at 1 (Zhao maps can reflect more than a physical material).
    np.testing.assert_allclose(((1.0 - maps.specular) * base)[fits], (w_d * maps.diffuse)[fits], rtol=1e-5)
    np.testing.assert_array_equal(base[~fits], 1.0)
    back = cv.from_weighted_base(base, maps.specular, config)
    np.testing.assert_allclose(back[fits], maps.diffuse[fits], rtol=1e-5)
    if config.diffuse_conservation:
        assert fits.all()
        np.testing.assert_allclose(base, maps.diffuse, rtol=1e-6)
    else:
        assert not fits.all()  # the fixture exercises the clipping


def test_weighted_base_clips_only_what_cannot_be_stored():
    base = cv.to_weighted_base(np.full((1, 1, 3), 0.9, np.float32), np.full((1, 1, 1), 0.5, np.float32), ZHAO)
    assert base.max() == 1.0  # 0.9 / 0.5 = 1.8 is out of range


def test_ior_f0():
    f0 = np.array([0.0, 0.02, 0.04, 0.2, 0.9])
    np.testing.assert_allclose(cv.ior_to_f0(cv.f0_to_ior(f0)), f0, atol=1e-12)
    assert cv.f0_to_ior(0.04) == pytest.approx(1.5)
    assert cv.ior_to_f0(1.5) == pytest.approx(0.04)
    assert cv.ior_to_f0(0.0) == 1.0  # KHR_materials_ior's special value


def test_khr_specular_round_trip(maps):
    factor, tex = cv.to_khr_specular(maps.specular)
    assert factor == pytest.approx(float(maps.specular.max()) / 0.04) and factor > 1  # may exceed 1 (spec)
    assert tex.max() == pytest.approx(1.0) and tex.min() >= 0.0
    np.testing.assert_allclose(cv.from_khr_specular(factor, tex), maps.specular, rtol=1e-5)
    zero_factor, zero_tex = cv.to_khr_specular(np.zeros((2, 2, 1)))
    assert zero_factor == 0.0 and not zero_tex.any()


def test_khronos_metal_rough_round_trip_grey():
    # Grey inputs: the quadratic is solved exactly, so the conversion round-trips (where nothing is clipped).
    d = np.linspace(0.05, 0.5, 6)[:, None, None] * np.ones((1, 6, 3))
    s = np.linspace(0.0, 0.5, 6)[None, :, None] * np.ones((6, 1, 1))
    base, metal = cv.specgloss_to_metalrough(d, s)
    assert metal[:, 0].max() == 0.0 and metal[:, -1].min() > 0.3  # s < 0.04 is a dielectric; s = 0.5 is metal-ish
    d2, s2 = cv.metalrough_to_specgloss(base, metal)
    np.testing.assert_allclose(s2[:, 1:], np.repeat(s, 3, -1)[:, 1:], atol=1e-5)
    np.testing.assert_allclose(d2[:, 1:], d[:, 1:], atol=1e-4)
    np.testing.assert_allclose(s2[:, 0], 0.04, atol=1e-7)  # metal-rough cannot go below F0 = 0.04


def test_khronos_metal_rough_coloured_and_inverse():
    # Coloured diffuse over a dielectric-range grey F0 in [0.04, 0.08]: a metallic up to ~0.4 carries the
    # extra F0, and the metallic-squared blend of the base colour costs a little colour (measured over 40k
    # random pixels: F0 error <= 0.008, diffuse error <= 0.047, 99th percentile 0.016).
    rng = np.random.default_rng(1)
    sg_diffuse = rng.uniform(0.05, 0.6, (50, 50, 3))
    spec = rng.uniform(0.04, 0.08, (50, 50, 1))
    base, metal = cv.specgloss_to_metalrough(sg_diffuse, spec)
    assert base.min() >= 0 and base.max() <= 1 and metal.min() >= 0 and 0.2 < metal.max() <= 1
    d2, s2 = cv.metalrough_to_specgloss(base, metal)
    np.testing.assert_allclose(cv.perceived_brightness(s2), spec[..., 0], atol=0.01)
    np.testing.assert_allclose(d2, sg_diffuse, atol=0.05)
    # metal-rough -> spec-gloss -> metal-rough is the identity on a pure dielectric and a pure metal.
    for b, m in ((0.3, 0.0), (0.8, 1.0)):
        sd, ss = cv.metalrough_to_specgloss(np.full((1, 1, 3), b), np.full((1, 1, 1), m))
        b2, m2 = cv.specgloss_to_metalrough(sd, ss)
        np.testing.assert_allclose(m2, m, atol=1e-4)
        np.testing.assert_allclose(b2, b, atol=1e-4)


def test_smoothness():
    r = np.linspace(0, 1, 5)
    np.testing.assert_allclose(cv.roughness_to_smoothness(r), 1 - r)
    np.testing.assert_allclose(cv.smoothness_to_roughness(cv.roughness_to_smoothness(r)), r, atol=1e-7)


# -------------------------------------------------------------------------------------------------- presets


def test_generic_is_write_texture_set(tmp_path, maps):
    relit = np.full((H, W, 3), 0.5, np.float32)
    a = write_target(maps, tmp_path / "a", "m", extra_meta={"k": 1}, relit=relit)
    b = write_texture_set(maps, tmp_path / "b", "m", extra_meta={"k": 1}, relit=relit)
    assert {r: p.name for r, p in a.items()} == {r: p.name for r, p in b.items()}
    for role in a:
        assert a[role].read_bytes() == b[role].read_bytes(), role
    assert set(target_files("m", "generic", relit=True).values()) == {p.name for p in a.values()}


@pytest.mark.parametrize("relief", [False, True])
@pytest.mark.parametrize("target", [t for t in TARGETS if t != "generic"])
def test_every_target_writes_its_files_and_sidecar(tmp_path, maps, target, relief):
    if relief:
        maps = with_relief(maps)
    paths = write_target(maps, tmp_path, "mat", target, extra_meta={"model": "x"})
    names = target_files("mat", target, relief=("height", "ao") if relief else ())
    assert {r: p.name for r, p in paths.items()} == names
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names.values())  # nothing else, no staging left
    side = json.loads(paths["sidecar"].read_text())
    assert side["target"]["name"] == target and side["target"]["conversion"]
    assert side["meta"] == {"source": "photo.jpg", "model": "x"}
    assert side["normal_convention"]["name"] == PRESETS[target].normal
    assert set(side["files"]) == set(names) - {"sidecar"}
    for role, desc in side["files"].items():
        assert desc["file"] == names[role]
        if "bits" in desc:  # images: the sidecar tells the truth about the file
            info = image_info(paths[role])
            assert info["dtype"] == {8: "uint8", 16: "uint16"}[desc["bits"]], role
            assert info["channels"] == desc["channels"], role


def test_specular_workflow_files(tmp_path, maps):
    for target in ("usd", "mtlx"):
        p = write_target(maps, tmp_path / target, "m", target)
        base = cv.to_weighted_base(maps.diffuse, maps.specular, ZHAO)
        np.testing.assert_allclose(read_image(p["basecolor"]), base, atol=5e-3)  # sRGB 8-bit
        np.testing.assert_allclose(read_image(p["specular"], raw=True)[..., :1], maps.specular, atol=Q16)
        np.testing.assert_allclose(read_image(p["roughness"], raw=True)[..., :1], maps.roughness, atol=Q16)
        np.testing.assert_allclose(read_image(p["normal"], raw=True), (maps.normal + 1) / 2, atol=Q16)
    assert (tmp_path / "usd" / "m.usda").is_file() and (tmp_path / "mtlx" / "m.mtlx").is_file()


def test_render_config_changes_the_base_colour(tmp_path, maps):
    maps.render_config = DESCHAINTRE
    p = write_target(maps, tmp_path, "m", "usd")
    np.testing.assert_allclose(read_image(p["basecolor"]), maps.diffuse, atol=5e-3)  # w_d = 1 - rho_s


def test_gltf_files(tmp_path, maps):
    p = write_target(maps, tmp_path, "m", "gltf")
    for role in ("basecolor", "normal", "orm", "specularcolor", "fallback_basecolor"):
        assert image_info(p[role])["dtype"] == "uint8", role  # web glTF: 8-bit everywhere
    base = cv.to_weighted_base(maps.diffuse, maps.specular, ZHAO)
    fb_base, metal = cv.specgloss_to_metalrough(base, maps.specular)
    np.testing.assert_allclose(read_image(p["basecolor"]), base, atol=5e-3)
    np.testing.assert_allclose(read_image(p["fallback_basecolor"]), fb_base, atol=5e-3)
    orm = read_stored(p["orm"])
    np.testing.assert_array_equal(orm[..., 0], 1.0)
    np.testing.assert_allclose(orm[..., 1:2], maps.roughness, atol=Q8)
    np.testing.assert_allclose(orm[..., 2:3], metal, atol=Q8)
    assert metal[0, 0, 0] == 0.0 and metal.max() > 0.1
    np.testing.assert_allclose(read_stored(p["normal"]), (maps.normal + 1) / 2, atol=Q8)
    doc = json.loads(p["gltf"].read_text())
    ext = doc["materials"][0]["extensions"]["KHR_materials_specular"]
    tex = read_image(p["specularcolor"])[..., :1]  # sRGB-decoded, as a glTF viewer does
    np.testing.assert_allclose(cv.from_khr_specular(ext["specularColorFactor"][0], tex), maps.specular,
                               rtol=0.03, atol=1e-3)
    assert doc["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] == 0.0  # exact material: no metal
    fallback = json.loads(p["gltf_fallback"].read_text())
    assert "extensionsUsed" not in fallback
    assert fallback["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] == 1.0


@pytest.mark.parametrize("target", ["unreal"])
def test_metal_rough_targets(tmp_path, maps, target):
    p = write_target(maps, tmp_path, "m", target)
    base, metal = cv.specgloss_to_metalrough(cv.to_weighted_base(maps.diffuse, maps.specular, ZHAO), maps.specular)
    np.testing.assert_allclose(read_image(p["basecolor"]), base, atol=5e-3)
    stored_n = read_stored(p["normal"]) * 2 - 1
    if target == "unreal":  # DirectX: green flipped, nothing else
        np.testing.assert_allclose(stored_n[..., 1], -maps.normal[..., 1], atol=3 * Q16)
        orm = read_stored(p["orm"])
        np.testing.assert_array_equal(orm[..., 0], 1.0)
        np.testing.assert_allclose(orm[..., 1:2], maps.roughness, atol=Q16)
        np.testing.assert_allclose(orm[..., 2:3], metal, atol=Q16)
    else:
        np.testing.assert_allclose(stored_n[..., 1], maps.normal[..., 1], atol=3 * Q16)
        np.testing.assert_allclose(read_stored(p["metallic"])[..., :1], metal, atol=Q16)
        np.testing.assert_allclose(read_stored(p["roughness"])[..., :1], maps.roughness, atol=Q16)
    np.testing.assert_allclose(stored_n[..., [0, 2]], maps.normal[..., [0, 2]], atol=3 * Q16)


def test_unity_smoothness_in_alpha(tmp_path, maps):
    p = write_target(maps, tmp_path, "m", "unity")
    ss = read_stored(p["specular_smoothness"])
    assert ss.shape == (H, W, 4) and image_info(p["specular_smoothness"])["dtype"] == "uint16"
    np.testing.assert_allclose(ss[..., 3:], 1.0 - maps.roughness, atol=Q16)  # alpha: linear, not premultiplied
    for c in range(3):  # RGB: sRGB-encoded F0, untouched by the alpha
        np.testing.assert_allclose(srgb_to_linear(ss[..., c:c + 1]), maps.specular, atol=1e-4)
    np.testing.assert_allclose(read_image(p["basecolor"]),
                               cv.to_weighted_base(maps.diffuse, maps.specular, ZHAO), atol=5e-3)


# --------------------------------------------------------------------------------------------------- safety


def test_refuses_existing_file_and_writes_nothing(tmp_path, maps):
    (tmp_path / "m.usda").write_text("user file")
    with pytest.raises(ImageError, match=r"m\.usda: exists \(pass force=True"):
        write_target(maps, tmp_path, "m", "usd")
    assert [p.name for p in tmp_path.iterdir()] == ["m.usda"]
    assert (tmp_path / "m.usda").read_text() == "user file"
    paths = write_target(maps, tmp_path, "m", "usd", force=True)
    assert "UsdPreviewSurface" in paths["usda"].read_text()
    with pytest.raises(ImageError, match=r"exists \(and 5 more\)"):
        write_target(maps, tmp_path, "m", "usd")


def test_bad_input_leaves_nothing(tmp_path, maps):
    nan = Maps(maps.diffuse, maps.specular, np.full((H, W, 1), np.nan, np.float32), maps.normal)
    with pytest.raises(ImageError, match="'roughness' has NaN/Inf"):
        write_target(nan, tmp_path / "o", "gltf")
    bad_meta = Maps(maps.diffuse, maps.specular, maps.roughness, maps.normal, meta={"x": object()})
    with pytest.raises(ValueError, match="not JSON-serialisable"):
        write_target(bad_meta, tmp_path / "o", "unreal")
    with pytest.raises(ImageError, match="invalid texture-set name"):
        write_target(maps, tmp_path, "a/b", "mtlx")
    with pytest.raises(ValueError, match="unknown target 'maya'"):
        write_target(maps, tmp_path, "m", "maya")
    assert list(tmp_path.iterdir()) == []  # the output folder it would have created is gone too


@pytest.mark.parametrize("existing", [False, True])
def test_failed_write_midway_leaves_nothing(tmp_path, maps, monkeypatch, existing):
    from svbrdf.runtime.io import images as imageio
    from svbrdf.runtime.outputs import texture_set

    written = []

    def full_disk(path, arr, **kw):  # the packed texture fails, after the base colour and the normal map
        if path.name == "m_OcclusionRoughnessMetallic.png":
            raise ImageError(f"{path}: write failed (disk full)")
        written.append(path.name)
        return imageio.write_image(path, arr, **kw)

    out = tmp_path / "out"
    if existing:  # an earlier set is replaced (force) only when the whole new one was written
        write_target(maps, out, "m", "unreal")
        before = {p.name: p.read_bytes() for p in out.iterdir()}
    monkeypatch.setattr(texture_set, "write_image", full_disk)
    with pytest.raises(ImageError, match="write failed") as exc:
        write_target(maps.clipped(), out, "m", "unreal", force=True, extra_meta={"new": 1})
    assert written == ["m_BaseColor.png", "m_Normal.png"]
    assert str(exc.value).startswith(str(out / "m_OcclusionRoughnessMetallic.png"))  # the target, not the stage
    if existing:
        assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # no staging folder, nothing replaced
    else:
        assert list(tmp_path.iterdir()) == []  # the output folder it created is gone too


@pytest.mark.parametrize("relief", [(), ("height",), ("height", "ao")])
def test_files_are_listed_in_the_order_of_target_files(tmp_path, maps, relief):
    if relief:
        maps = with_relief(maps, maps=relief)
    for target in TARGETS:
        paths = write_target(maps, tmp_path / target, "m", target, relit=np.zeros((H, W * 3, 3), np.float32))
        names = target_files("m", target, relit=True, relief=relief)
        assert list(paths) == list(names) and [p.name for p in paths.values()] == list(names.values())
        files = json.loads(paths["sidecar"].read_text())["files"]
        assert list(files) == [r for r in names if r != "sidecar"]


# ----------------------------------------------------------------------------------- independent renderer


def test_mitsuba_renders_the_usd_files_like_our_renderer(tmp_path):
    """Mitsuba 3 reads the usd target's texture files (its own PNG reader and sRGB decoding) and renders the
    UsdPreviewSurface model with F = F0 (diffuse ``diffuseColor (1 - F0)``, GGX ``alpha = roughness^2`` with
    Smith G and ``F = specularColor``, tangent-space normal map) under the same point light and camera as our
    renderer with ``RenderConfig(falloff=True, geometry="smith", fresnel="none")``.

    Measured at 64 px, 16 spp: median relative difference 0.3 %, 99th percentile 1.1 % (8-bit base colour,
    pixel-footprint averaging). A flipped normal green, an unsquared roughness or upside-down texture
    coordinates each give >= 5 % median / ~100 % 99th percentile, so the tolerance below catches them.
    """
    mi = pytest.importorskip("mitsuba")
    try:
        mi.set_variant("scalar_rgb")
    except (ImportError, AttributeError) as exc:
        pytest.skip(f"mitsuba scalar_rgb variant unavailable: {exc}")
    size = 64
    y, x = np.mgrid[0:size, 0:size].astype(np.float32) / np.float32(size)
    n = np.stack([0.25 * np.sin(2 * np.pi * x), 0.2 * np.cos(2 * np.pi * y), np.ones_like(x)], -1)
    config = RenderConfig(falloff=True, geometry="smith", fresnel="none")
    maps = Maps(np.stack([0.2 + 0.5 * x, 0.3 + 0.3 * y, 0.15 + 0.2 * (1 - x) * y], -1),
                (0.04 + 0.3 * x * y)[..., None], (0.35 + 0.35 * y)[..., None], normalize_normals(n),
                render_config=config)
    paths = write_target(maps, tmp_path, "m", "usd")
    files = json.loads(paths["sidecar"].read_text())["files"]

    def load(role):
        bmp = mi.Bitmap(str(paths[role]))
        bmp.set_srgb_gamma(files[role]["colour_space"] == "sRGB")  # as the USD document says (test_materials)
        return np.array(bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False))

    base, f0, rough, normal = (load(r) for r in ("basecolor", "specular", "roughness", "normal"))
    d = config.camera_distance
    # Mitsuba puts bitmap row 0 at v = 0, the bottom of the rectangle: flip v so row 0 is the top.
    flip_v = mi.ScalarTransform3f().translate([0, 1]) @ mi.ScalarTransform3f().scale([1, -1])

    def tex(a):
        return {"type": "bitmap", "data": mi.TensorXf(np.ascontiguousarray(a, np.float32)), "raw": True,
                "filter_type": "nearest", "wrap_mode": "clamp", "to_uv": flip_v}

    def shoot(bsdf):
        scene = mi.load_dict({
            "type": "scene",
            "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
            "sensor": {"type": "perspective", "fov": config.fov_deg, "fov_axis": "x",
                       "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, d], target=[0, 0, 0], up=[0, 1, 0]),
                       "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"},
                                "pixel_format": "rgb"},
                       "sampler": {"type": "independent", "sample_count": 16}},
            # our falloff is d^2 / |p_l - p|^2, Mitsuba's 1 / |p_l - p|^2
            "light": {"type": "point", "position": [0, 0, d],
                      "intensity": {"type": "rgb", "value": [config.intensity * d * d] * 3}},
            "plane": {"type": "rectangle", "bsdf": {"type": "normalmap", "normalmap": tex(normal), "bsdf": bsdf}},
        })
        return np.array(mi.render(scene))

    theirs = shoot({"type": "diffuse", "reflectance": tex(base * (1.0 - f0))}) + shoot(
        {"type": "roughconductor", "distribution": "ggx", "material": "none", "alpha": tex(rough * rough),
         "specular_reflectance": tex(f0)})
    ours = render(maps, None, config)
    rel = np.abs(theirs - ours) / np.maximum(ours, 1e-3)
    assert np.median(rel) < 0.01 and np.percentile(rel, 99) < 0.03, (np.median(rel), np.percentile(rel, 99))


def test_targets_other_than_generic_need_every_map(tmp_path, maps):
    part = maps.subset(["diffuse", "normal"])
    with pytest.raises(ValueError, match="target 'gltf' needs the specular, roughness map"):
        write_target(part, tmp_path / "gl", "m", "gltf")
    assert not (tmp_path / "gl").exists()
    paths = write_target(part, tmp_path / "generic", "m", "generic")  # the project's own layout takes a subset
    assert set(paths) == {"basecolor", "normal", "sidecar"}


# ------------------------------------------------------------------------------------------ height and AO
def _relief_maps(maps):
    """``maps`` with a deep pit in the normal map (so the AO is well below 1 there) and its relief."""
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    hp = -4.0 * np.exp(-((xx - 8) ** 2 + (yy - 6) ** 2) / 6.0)
    n = np.stack([-np.gradient(hp, axis=1), np.gradient(hp, axis=0), np.ones_like(hp)], -1).astype(np.float32)
    return with_relief(Maps(maps.diffuse, maps.specular, maps.roughness, normalize_normals(n), meta=maps.meta))


def test_ao_goes_into_the_orm_red_channel_and_the_gltf_occlusion_texture(tmp_path, maps):
    m = _relief_maps(maps)
    ao = m.relief.ao[..., None]
    assert ao.min() < 0.9
    p = write_target(m, tmp_path / "gltf", "m", "gltf")
    orm = read_stored(p["orm"])
    np.testing.assert_allclose(orm[..., :1], ao, atol=Q8)
    np.testing.assert_allclose(orm[..., 1:2], m.roughness, atol=Q8)  # G and B as without the AO
    for role in ("gltf", "gltf_fallback"):
        material = json.loads(p[role].read_text())["materials"][0]
        assert material["occlusionTexture"] == {"index": 2} == material["pbrMetallicRoughness"][
            "metallicRoughnessTexture"]
    assert "occlusionTexture" in json.loads(p["sidecar"].read_text())["target"]["import_notes"][-1]
    plain = write_target(maps, tmp_path / "plain", "m", "gltf")
    assert "occlusionTexture" not in json.loads(plain["gltf"].read_text())["materials"][0]
    np.testing.assert_array_equal(read_stored(plain["orm"])[..., 1:], read_stored(
        write_target(with_relief(maps), tmp_path / "same", "m", "gltf")["orm"])[..., 1:])
    u = write_target(m, tmp_path / "unreal", "m", "unreal")
    orm = read_stored(u["orm"])
    np.testing.assert_allclose(orm[..., :1], ao, atol=Q16)
    np.testing.assert_allclose(orm[..., 1:2], m.roughness, atol=Q16)
    np.testing.assert_allclose(read_stored(u["height"])[..., 0], m.relief.height, atol=Q16)


def test_unity_mask_map_has_ao_in_green_and_smoothness_in_alpha(tmp_path, maps):
    m = _relief_maps(maps)
    p = write_target(m, tmp_path, "m", "unity")
    mask = read_stored(p["mask"])
    assert mask.shape == (H, W, 4) and image_info(p["mask"])["dtype"] == "uint16"
    np.testing.assert_allclose(mask[..., 1], m.relief.ao, atol=Q16)
    np.testing.assert_allclose(mask[..., 3:], 1.0 - m.roughness, atol=Q16)
    np.testing.assert_array_equal(mask[..., [0, 2]], 0.0)
    np.testing.assert_allclose(read_stored(p["height"])[..., 0], m.relief.height, atol=Q16)


@pytest.mark.parametrize("target,height,ao", [("blender", "m_disp.png", "m_ao.png"),
                                              ("usd", "m_Displacement.png", "m_AmbientOcclusion.png"),
                                              ("mtlx", "m_Displacement.png", "m_AmbientOcclusion.png"),
                                              ("ambientcg", "m_Displacement.png", "m_AmbientOcclusion.png")])
def test_height_and_ao_files_of_the_library_targets(tmp_path, maps, target, height, ao):
    m = _relief_maps(maps)
    p = write_target(m, tmp_path, "m", target)
    assert (p["height"].name, p["ao"].name) == (height, ao)
    np.testing.assert_allclose(read_stored(p["height"])[..., 0], m.relief.height, atol=Q16)
    np.testing.assert_allclose(read_stored(p["ao"])[..., 0], m.relief.ao, atol=Q16)
    side = json.loads(p["sidecar"].read_text())
    assert side["relief"]["height_scale"] == m.relief.scale == side["files"]["height"]["height_scale"]
    # the base colour is the same as without the relief: the AO never darkens it
    plain = write_target(maps.__class__(m.diffuse, m.specular, m.roughness, m.normal), tmp_path / "p", "m", target)
    np.testing.assert_array_equal(read_stored(p["basecolor"]), read_stored(plain["basecolor"]))


def test_ambientcg_ships_both_normal_conventions(tmp_path, maps):
    p = write_target(with_relief(maps), tmp_path, "Ground 080", "ambientcg")
    assert sorted(x.name for x in p.values()) == sorted(
        f"Ground 080{s}" for s in ("_Color.png", "_NormalGL.png", "_NormalDX.png", "_Roughness.png",
                                   "_Specular.png", "_Displacement.png", "_AmbientOcclusion.png", ".mtlx", ".json"))
    gl, dx = read_stored(p["normal"]), read_stored(p["normal_dx"])
    np.testing.assert_allclose(dx[..., 1], 1.0 - gl[..., 1], atol=3 * Q16)
    np.testing.assert_array_equal(dx[..., [0, 2]], gl[..., [0, 2]])
    files = json.loads(p["sidecar"].read_text())["files"]
    assert "opengl" in files["normal"]["content"] and "dx" in files["normal_dx"]["content"]
