"""Texture-set writer (files, encodings, sidecar, all-or-nothing) and the relit preview panel."""

import json

import numpy as np
import pytest

from svbrdf.runtime.core.colour import linear_to_srgb, srgb_to_linear
from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.io.images import image_info, read_image
from svbrdf.runtime.core.maps import Maps, normalize_normals
from svbrdf.runtime.core.relief import with_relief
from svbrdf.runtime.core.render import DESCHAINTRE, ZHAO, novel_lights, render
from svbrdf.runtime.outputs.texture_set import relit_panel, write_texture_set

H, W = 12, 16


@pytest.fixture
def maps():
    rng = np.random.default_rng(0)
    n = rng.normal(size=(H, W, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 1.0
    return Maps(
        diffuse=rng.uniform(0.05, 0.9, (H, W, 3)).astype(np.float32),
        specular=rng.uniform(0.02, 0.6, (H, W, 1)).astype(np.float32),
        roughness=rng.uniform(0.1, 0.9, (H, W, 1)).astype(np.float32),
        normal=normalize_normals(n),
        meta={"source": "photo.jpg", "timings": {"infer_s": np.float32(1.5)}},
    )


@pytest.mark.parametrize("fmt,tol", [("png", 2e-5), ("exr", 1e-6)])
def test_files_and_values(tmp_path, maps, fmt, tol):
    paths = write_texture_set(maps, tmp_path / "out" / "deep", "mat", fmt=fmt)  # creates parents
    assert set(paths) == {"basecolor", "normal", "roughness", "specular", "sidecar"}
    out = tmp_path / "out" / "deep"
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["mat_basecolor.png", f"mat_normal.{fmt}", f"mat_roughness.{fmt}", f"mat_specular.{fmt}", "mat.json"])
    assert image_info(paths["basecolor"])["dtype"] == "uint8"
    assert image_info(paths["roughness"])["channels"] == 1
    # Base colour: sRGB-encoded 8-bit; a normal read decodes it back to the linear albedo.
    np.testing.assert_allclose(read_image(paths["basecolor"]), maps.diffuse, atol=5e-3)
    # Data maps: stored as is (raw read).
    np.testing.assert_allclose(read_image(paths["roughness"], raw=True)[..., 0], maps.roughness[..., 0], atol=tol)
    np.testing.assert_allclose(read_image(paths["specular"], raw=True)[..., 0], maps.specular[..., 0], atol=tol)
    np.testing.assert_allclose(read_image(paths["normal"], raw=True), (maps.normal + 1) / 2, atol=tol)


def test_dx_normal_flips_green(tmp_path, maps):
    gl = write_texture_set(maps, tmp_path / "gl", "m")
    dx = write_texture_set(maps, tmp_path / "dx", "m", normal="dx")
    a, b = read_image(gl["normal"], raw=True), read_image(dx["normal"], raw=True)
    np.testing.assert_allclose(b[..., 1], 1.0 - a[..., 1], atol=2e-5)
    np.testing.assert_array_equal(b[..., [0, 2]], a[..., [0, 2]])
    assert json.loads(dx["sidecar"].read_text())["normal_convention"]["name"] == "dx"


def test_sidecar(tmp_path, maps):
    maps.render_config = DESCHAINTRE
    paths = write_texture_set(maps, tmp_path, "m", extra_meta={"model_sha256": "ab" * 32, "source": "x.png"})
    side = json.loads(paths["sidecar"].read_text())
    assert side["size"] == {"width": W, "height": H}
    brdf = side["brdf"]
    assert brdf["distribution"] == "GGX" and brdf["alpha"] == "roughness ** 2"
    assert "Smith-Schlick" in brdf["geometry"] and "Schlick" in brdf["fresnel"]
    assert brdf["render_config"] == DESCHAINTRE.to_dict()
    assert brdf["diffuse"].startswith("(1 - specular)")  # follows the config (diffuse conservation)
    assert side["normal_convention"]["name"] == "opengl"
    files = side["files"]
    assert files["basecolor"] == {"file": "m_basecolor.png", "map": "diffuse", "colour_space": "sRGB", "bits": 8}
    assert files["normal"]["encoding"] == "(n + 1) / 2" and files["normal"]["colour_space"] == "data"
    assert files["specular"]["colour_space"] == "linear" and files["roughness"]["file"] == "m_roughness.png"
    # maps.meta and extra_meta (which wins on clashes); numpy scalars serialised.
    assert side["meta"] == {"source": "x.png", "timings": {"infer_s": 1.5}, "model_sha256": "ab" * 32}


def test_default_render_config_in_sidecar(tmp_path, maps):
    side = json.loads(write_texture_set(maps, tmp_path, "m")["sidecar"].read_text())
    assert side["brdf"]["render_config"] == ZHAO.to_dict()
    assert side["brdf"]["diffuse"] == "diffuse / pi"


def test_refusal_writes_nothing(tmp_path, maps):
    (tmp_path / "m_specular.png").write_bytes(b"user file")
    with pytest.raises(ImageError, match=r"m_specular\.png: exists \(pass force=True"):
        write_texture_set(maps, tmp_path, "m")
    assert [p.name for p in tmp_path.iterdir()] == ["m_specular.png"]
    assert (tmp_path / "m_specular.png").read_bytes() == b"user file"
    # The relit target is checked too.
    (tmp_path / "m_specular.png").unlink()
    (tmp_path / "m_relit.png").write_bytes(b"x")
    write_texture_set(maps, tmp_path, "m")  # no relit requested: fine
    for p in list(tmp_path.iterdir()):
        if p.name != "m_relit.png":
            p.unlink()
    with pytest.raises(ImageError, match="m_relit.png: exists"):
        write_texture_set(maps, tmp_path, "m", relit=np.zeros((H, W, 3), np.float32))
    assert [p.name for p in tmp_path.iterdir()] == ["m_relit.png"]


def test_force_overwrites(tmp_path, maps):
    write_texture_set(maps, tmp_path, "m")
    maps2 = Maps(maps.diffuse * 0.5, maps.specular, maps.roughness * 0.0, maps.normal)
    with pytest.raises(ImageError, match="exists \\(and 4 more\\)"):
        write_texture_set(maps2, tmp_path, "m")
    paths = write_texture_set(maps2, tmp_path, "m", force=True)
    assert read_image(paths["roughness"], raw=True).max() == 0.0
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # staging folder removed


def test_failure_midway_leaves_nothing(tmp_path, maps):
    bad = Maps(maps.diffuse, maps.specular, maps.roughness, maps.normal, meta={"x": object()})
    with pytest.raises(ValueError, match="not JSON-serialisable"):
        write_texture_set(bad, tmp_path / "o", "m")
    nan = Maps(maps.diffuse, maps.specular, np.full((H, W, 1), np.nan, np.float32), maps.normal)
    with pytest.raises(ImageError, match="'roughness' has NaN/Inf"):
        write_texture_set(nan, tmp_path, "m")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("workers", [1, 2])
def test_failed_write_cleans_staging(tmp_path, maps, monkeypatch, workers):
    from svbrdf.runtime.io import images as imageio
    from svbrdf.runtime.outputs import texture_set

    calls = []

    def flaky(path, arr, **kw):  # the roughness file fails, as on a full disk
        calls.append(path.name)
        if path.name == "m_roughness.png":
            raise ImageError(f"{path}: write failed (disk full)")
        return imageio.write_image(path, arr, **kw)

    monkeypatch.setattr(texture_set, "write_image", flaky)
    monkeypatch.setattr(texture_set, "WRITE_WORKERS", workers)
    with pytest.raises(ImageError, match="write failed") as exc:
        write_texture_set(maps, tmp_path, "m")
    # One thread stops at the failure; two may have started the next file meanwhile.
    assert calls == ["m_basecolor.png", "m_normal.png", "m_roughness.png"] if workers == 1 else len(calls) >= 3
    assert str(exc.value).startswith(str(tmp_path / "m_roughness.png"))  # names the target, not the stage
    assert list(tmp_path.iterdir()) == []


def test_argument_errors(tmp_path, maps):
    with pytest.raises(ValueError, match="normal"):
        write_texture_set(maps, tmp_path, "m", normal="directx")
    with pytest.raises(ValueError, match="fmt"):
        write_texture_set(maps, tmp_path, "m", fmt="tif")
    with pytest.raises(ImageError, match="invalid texture-set name"):
        write_texture_set(maps, tmp_path, "a/b")
    with pytest.raises(ValueError, match="relit"):
        write_texture_set(maps, tmp_path, "m", relit=np.zeros((H, W), np.float32))
    (tmp_path / "file").write_text("x")
    with pytest.raises(ImageError, match="not a folder"):
        write_texture_set(maps, tmp_path / "file", "m")
    assert [p.name for p in tmp_path.iterdir()] == ["file"]


def test_relit_panel(maps):
    panel = relit_panel(maps, exposure=1.0)
    assert panel.shape == (H, 3 * W, 3) and panel.dtype == np.float32
    assert panel.min() >= 0.0 and panel.max() <= 1.0
    flash = render(maps, None, ZHAO)
    np.testing.assert_allclose(srgb_to_linear(panel[:, :W].astype(np.float64)),
                               np.clip(flash, 0, 1), atol=1e-4)
    # Panels 2 and 3: upper-left and lower-right lights.
    ul, lr = novel_lights(ZHAO)[0], novel_lights(ZHAO)[-1]
    assert ul[0] < 0 < ul[1] and lr[0] > 0 > lr[1]
    np.testing.assert_allclose(panel[:, W:2 * W], linear_to_srgb(np.clip(render(maps, ul, ZHAO), 0, 1)), atol=1e-5)
    np.testing.assert_allclose(panel[:, 2 * W:], linear_to_srgb(np.clip(render(maps, lr, ZHAO), 0, 1)), atol=1e-5)


def test_relit_panel_auto_exposure_and_writing(tmp_path, maps):
    dark = Maps(maps.diffuse * 0.05, maps.specular * 0.05, maps.roughness, maps.normal)
    panel = relit_panel(dark, lights=[None, (0.3, 0.0, 1.5)])
    assert panel.shape == (H, 2 * W, 3)
    flash = render(dark, None, ZHAO)
    scale = 1.0 / np.percentile(flash, 99)
    np.testing.assert_allclose(panel[:, :W], linear_to_srgb(np.clip(flash * scale, 0, 1)), atol=1e-5)
    assert np.mean(panel[:, :W] >= 1.0 - 1e-6) <= 0.02  # about 1 % saturates
    paths = write_texture_set(dark, tmp_path, "m", relit=panel)
    assert paths["relit"].name == "m_relit.png"
    np.testing.assert_allclose(read_image(paths["relit"], raw=True), panel, atol=0.5 / 255 + 1e-6)


def test_a_subset_writes_only_its_maps(tmp_path, maps):
    part = maps.subset(["normal", "basecolor"])
    paths = write_texture_set(part, tmp_path, "m", fmt="exr")
    assert set(paths) == {"basecolor", "normal", "sidecar"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json", "m_basecolor.png", "m_normal.exr"]
    np.testing.assert_allclose(read_image(paths["normal"], raw=True), (maps.normal + 1) / 2, atol=1e-6)
    side = json.loads(paths["sidecar"].read_text())
    assert side["maps"] == ["diffuse", "normal"] and set(side["files"]) == {"basecolor", "normal"}
    full = json.loads(write_texture_set(maps, tmp_path / "all", "m")["sidecar"].read_text())
    assert full["maps"] == ["diffuse", "specular", "roughness", "normal"]


def test_relit_panel_is_rendered_at_its_display_size(maps):
    # Long side W = 16 -> 8: every view is 6 x 8, rendered from the maps downsized for it.
    panel = relit_panel(maps, exposure=1.0, size=8)
    assert panel.shape == (H // 2, 3 * (W // 2), 3) and panel.dtype == np.float32
    assert panel.min() >= 0.0 and panel.max() <= 1.0
    assert relit_panel(maps, exposure=1.0, size=None).shape == (H, 3 * W, 3)
    np.testing.assert_array_equal(relit_panel(maps, exposure=1.0, size=W), relit_panel(maps, exposure=1.0, size=None))
    # A flat material downsized stays the same material: its small flash view agrees with the full-size one
    # averaged over 2 x 2 pixels (the render is smooth across the image).
    flat = Maps(np.full((H, W, 3), 0.4, np.float32), np.full((H, W, 1), 0.1, np.float32),
                np.full((H, W, 1), 0.5, np.float32), np.tile(np.float32([0, 0, 1]), (H, W, 1)))
    small, full = relit_panel(flat, exposure=1.0, size=8), relit_panel(flat, exposure=1.0, size=None)
    np.testing.assert_allclose(small[:, :8], full[:, :W].reshape(H // 2, 2, W // 2, 2, 3).mean(axis=(1, 3)),
                               atol=0.01)
    with pytest.raises(ValueError, match="size"):
        relit_panel(maps, size=0)


def test_the_default_panel_is_512_px_per_view():
    from svbrdf.runtime.outputs.texture_set import PANEL_SIZE

    n = np.zeros((600, 1024, 3), np.float32)
    n[..., 2] = 1.0
    big = Maps(np.full((600, 1024, 3), 0.5, np.float32), np.full((600, 1024, 1), 0.04, np.float32),
               np.full((600, 1024, 1), 0.5, np.float32), n)
    assert PANEL_SIZE == 512 and relit_panel(big).shape == (300, 3 * 512, 3)


@pytest.mark.parametrize("fmt", ["png", "exr"])
def test_concurrent_writing_gives_the_same_files(tmp_path, maps, monkeypatch, fmt):
    from svbrdf.runtime.outputs import texture_set

    panel = relit_panel(maps)
    written = {}
    for workers in (1, 3):
        monkeypatch.setattr(texture_set, "WRITE_WORKERS", workers)
        paths = write_texture_set(maps, tmp_path / str(workers), "m", fmt=fmt, relit=panel)
        written[workers] = {p.name: _content(p) for p in paths.values()}
    assert written[1] == written[3] and len(written[1]) == 6


def _content(path):
    """A written file's bytes, without the write time OpenImageIO stamps into every EXR (``DateTime``, to the
    second: two writes a second apart differ there and nowhere else)."""
    data = path.read_bytes()
    if path.suffix == ".exr":
        key = b"capDate\x00string\x00\x13\x00\x00\x00"  # the attribute's name, type and 19-byte size
        at = data.index(key) + len(key)
        data = data[:at] + b"?" * 19 + data[at + 19 :]
    return data


def test_concurrent_writing_reports_the_first_failure_and_leaves_nothing(tmp_path, maps, monkeypatch):
    from svbrdf.runtime.outputs import texture_set

    real = texture_set.write_image

    def failing(path, *args, **kwargs):
        if path.name in ("m_normal.png", "m_specular.png"):
            raise ImageError(f"{path}: disk full")
        return real(path, *args, **kwargs)

    monkeypatch.setattr(texture_set, "write_image", failing)
    with pytest.raises(ImageError, match=r"m_normal.png: disk full") as err:
        write_texture_set(maps, tmp_path / "out", "m")
    assert str(tmp_path / "out" / "m_normal.png") in str(err.value)
    assert not (tmp_path / "out").exists()


def test_relit_panel_needs_every_map(maps):
    with pytest.raises(ValueError, match="relit panel needs the diffuse, specular map"):
        relit_panel(maps.subset(["roughness", "normal"]))


def test_commit_writes_any_plan_all_or_nothing(tmp_path):
    from svbrdf.runtime.outputs.texture_set import TextureFile, commit

    image = TextureFile("a.png", {}, np.full((2, 3, 3), 0.5, np.float32), bits=8, srgb=True)
    doc = TextureFile("a.txt", {}, text="hello")
    unwritable = TextureFile("b.png", {}, np.full((2, 3, 1), np.nan, np.float32), bits=16)
    out = tmp_path / "out"
    with pytest.raises(ImageError, match="NaN") as exc:  # the last file of the plan fails
        commit(out, {"a": image, "doc": doc, "b": unwritable})
    assert str(exc.value).startswith(str(out / "b.png"))
    assert list(tmp_path.iterdir()) == []  # no file, no staging folder, no output folder

    paths = commit(out, {"a": image, "doc": doc})
    assert paths == {"a": out / "a.png", "doc": out / "a.txt"} and paths["doc"].read_text() == "hello"
    assert image_info(paths["a"])["dtype"] == "uint8"
    np.testing.assert_allclose(read_image(paths["a"]), 0.5, atol=3e-3)  # sRGB-encoded on write
    with pytest.raises(ImageError, match=r"a\.txt: exists \(pass force=True"):  # refused before anything is written
        commit(out, {"new": TextureFile("new.txt", {}, text="x"), "doc": doc})
    assert sorted(p.name for p in out.iterdir()) == ["a.png", "a.txt"]



def _png_gamma(path):
    """The gAMA chunk's value (gamma x 100000) of a PNG, or None."""
    import struct

    data, i = path.read_bytes(), 8
    while i < len(data):
        n, kind = struct.unpack(">I4s", data[i:i + 8])
        if kind == b"gAMA":
            return struct.unpack(">I", data[i + 8:i + 12])[0]
        i += 12 + n
    return None


def test_files_carry_their_colour_space(tmp_path, maps):
    import OpenImageIO as oiio

    panel = relit_panel(maps)
    paths = write_texture_set(maps, tmp_path, "m", relit=panel)

    def tag(role):
        inp = oiio.ImageInput.open(str(paths[role]))
        try:
            return inp.spec().get_string_attribute("oiio:ColorSpace")
        finally:
            inp.close()

    for role in ("normal", "roughness", "specular"):  # 16-bit data maps: linear in the file itself
        assert tag(role).startswith("lin"), (role, tag(role))
        assert _png_gamma(paths[role]) == 100000, role  # gAMA 1.0
    for role in ("basecolor", "relit"):  # colour: sRGB
        assert tag(role).startswith("srgb"), (role, tag(role))
        assert _png_gamma(paths[role]) == 45455, role
    # The tag does not change the stored values.
    np.testing.assert_allclose(read_image(paths["roughness"], raw=True)[..., 0], maps.roughness[..., 0],
                               atol=0.5 / 65535 + 1e-6)


# ------------------------------------------------------------------------------------------ height and AO
def _bump_normals(h=48, w=64):
    """The normals of a smooth pit (a Gaussian dent) and a ridge, (H, W, 3) OpenGL, and their height in map widths."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    height_px = -6.0 * np.exp(-((xx - 20) ** 2 + (yy - 24) ** 2) / 40.0) + 3.0 * np.exp(-((xx - 48) ** 2) / 20.0)
    dx = np.gradient(height_px, axis=1)
    dy_up = -np.gradient(height_px, axis=0)  # +y is up the image
    n = np.stack([-dx, -dy_up, np.ones_like(dx)], axis=-1)
    return normalize_normals(n.astype(np.float32)), height_px / w


@pytest.mark.parametrize("fmt", ["png", "exr"])
def test_height_and_ao_files_follow_the_normal_map(tmp_path, fmt):
    from svbrdf.runtime.core.relief import denormalise, slope_correlation

    normal, _ = _bump_normals()
    maps = with_relief(Maps(normal=normal, roughness=np.full((48, 64, 1), 0.5, np.float32)))
    paths = write_texture_set(maps, tmp_path, "m", fmt=fmt)
    assert set(paths) == {"normal", "roughness", "height", "ao", "sidecar"}
    assert paths["height"].name == f"m_height.{fmt}" and paths["ao"].name == f"m_ao.{fmt}"
    info = image_info(paths["height"])
    assert info["channels"] == 1 and info["dtype"] == ("uint16" if fmt == "png" else "float")
    sidecar = json.loads(paths["sidecar"].read_text())
    relief = sidecar["relief"]
    assert relief["maps"] == ["height", "ao"] and relief["tileable"] is False and relief["height_scale"] > 0
    assert sidecar["files"]["height"]["height_scale"] == relief["height_scale"]
    assert sidecar["files"]["ao"]["colour_space"] == "data" and relief["ao"]["strength"] == 8.0
    h01 = read_image(paths["height"], raw=True)[..., 0]
    assert abs(float(np.median(h01)) - 0.5) < 0.1 and h01.max() <= 1.0 and h01.min() >= 0.0
    height = denormalise(h01, relief["height_scale"])
    written_normal = read_image(paths["normal"], raw=True) * 2 - 1
    corr = slope_correlation(height, written_normal)
    assert corr["x"] > 0.99 and corr["y"] > 0.99, corr  # white = high, green = up the image
    ao = read_image(paths["ao"], raw=True)[..., 0]
    assert ao.min() >= 0 and ao.max() <= 1.0
    assert ao[24, 20] < ao[5, 5] and ao[5, 5] > 0.99  # the pit is darker than the flat corner
    assert h01[24, 20] < 0.5 < h01[24, 48]  # the pit is low, the ridge high


def test_a_flat_normal_map_gives_a_flat_height_and_no_occlusion(tmp_path):
    flat = np.zeros((16, 20, 3), np.float32)
    flat[..., 2] = 1.0
    maps = with_relief(Maps(normal=flat))
    assert maps.relief.scale == 0.0
    paths = write_texture_set(maps, tmp_path, "flat")
    h01 = read_image(paths["height"], raw=True)
    ao = read_image(paths["ao"], raw=True)
    np.testing.assert_allclose(h01, 32768 / 65535, atol=1e-7)  # mid-grey in 16 bits
    assert np.all(ao == 1.0)


def test_tileable_relief_is_integrated_across_the_wrap(tmp_path):
    from svbrdf.runtime.core.relief import denormalise, slope_correlation

    yy, xx = np.mgrid[0:32, 0:32].astype(np.float64)
    hp = 2.0 * np.sin(2 * np.pi * xx / 32) * np.cos(2 * np.pi * 2 * yy / 32)  # periodic height, pixels
    gx = (np.roll(hp, -1, 1) - np.roll(hp, 1, 1)) / 2
    gy = -(np.roll(hp, -1, 0) - np.roll(hp, 1, 0)) / 2
    normal = normalize_normals(np.stack([-gx, -gy, np.ones_like(gx)], -1).astype(np.float32))
    maps = with_relief(Maps(normal=normal), tileable=True)
    paths = write_texture_set(maps, tmp_path, "t")
    relief = json.loads(paths["sidecar"].read_text())["relief"]
    assert relief["tileable"] is True and "periodic" in relief["height"]["method"]
    height = denormalise(read_image(paths["height"], raw=True)[..., 0], relief["height_scale"])
    corr = slope_correlation(height, normal, tileable=True)
    assert min(corr.values()) > 0.95, corr


def test_relief_bad_input_is_one_line():
    import svbrdf.runtime
    from svbrdf.runtime.core.relief import Relief, relief_maps
    from svbrdf.runtime.errors import SvbrdfError

    assert svbrdf.runtime.relief_maps is relief_maps and svbrdf.runtime.Relief is Relief  # the public API
    normal, _ = _bump_normals(16, 16)
    with pytest.raises(SvbrdfError, match="needs the normal map|need the normal map"):
        with_relief(Maps(roughness=np.zeros((16, 16, 1))))
    bad = normal.copy()
    bad[3, 4] = np.nan
    with pytest.raises(SvbrdfError, match="NaN") as exc:
        with_relief(Maps(normal=bad))
    assert "\n" not in str(exc.value)
    with pytest.raises(SvbrdfError, match=r"NaN or infinite \(first at row 3, column 4\)"):
        relief_maps(bad)
    zero = normal.copy()
    zero[2, 2] = 0.0
    with pytest.raises(SvbrdfError, match=r"1 zero-length normal\(s\) \(first at row 2, column 2\); pass zero='flat'"):
        relief_maps(zero)
    assert relief_maps(zero, zero="flat").height.shape == (16, 16)  # the documented repair
    # the texture set's own normals are made unit length first (as the writer does): a zero normal is flat there
    assert with_relief(Maps(normal=zero)).relief.height.shape == (16, 16)
    # a normal map of another size than the other maps, or relief maps of another size
    with pytest.raises(SvbrdfError, match="'normal' is 16x16 px but the texture set's roughness map is 20x16 px"):
        Maps(roughness=np.zeros((16, 20, 1)), normal=normal)
    with pytest.raises(SvbrdfError, match="the relief maps are 16x16 px but the texture set is 20x16 px"):
        Maps(roughness=np.zeros((16, 20, 1)), relief=relief_maps(normal))
    with pytest.raises(SvbrdfError, match="valid names: height, ao"):
        relief_maps(normal, maps=("depth",))
    nan_relief = Relief(np.full((16, 16), np.nan, np.float32), 1.0, None)
    with pytest.raises(ImageError, match="relief map 'height' has NaN/Inf"):
        write_texture_set(Maps(normal=normal, relief=nan_relief), "/nonexistent-never-made", "m")


def test_relief_is_not_written_without_it_and_never_darkens_the_base_colour(tmp_path, maps):
    plain = write_texture_set(maps, tmp_path / "a", "m")
    assert "height" not in plain and "relief" not in json.loads(plain["sidecar"].read_text())
    relief_set = write_texture_set(with_relief(maps), tmp_path / "b", "m")
    np.testing.assert_array_equal(read_image(plain["basecolor"], raw=True), read_image(relief_set["basecolor"],
                                                                                        raw=True))
    only_height = write_texture_set(with_relief(maps, maps=["height"]), tmp_path / "c", "m")
    assert "height" in only_height and "ao" not in only_height


def test_ao_strength_is_the_depth_gain_of_the_ao_and_is_recorded(tmp_path):
    from svbrdf.runtime.core.relief import AO_STRENGTH, ambient_occlusion, height_from_normals, relief_maps
    from svbrdf.runtime.errors import SvbrdfError

    normal, _ = _bump_normals()
    height, scale = height_from_normals(normal)
    r1 = relief_maps(normal, ao_strength=1.0)
    rd = relief_maps(normal)
    assert rd.ao_strength == AO_STRENGTH == 8.0 and r1.scale == rd.scale == scale  # the height is the normals'
    np.testing.assert_array_equal(r1.height, rd.height)
    np.testing.assert_allclose(r1.ao, ambient_occlusion(height), atol=1e-6)
    np.testing.assert_allclose(rd.ao, ambient_occlusion(height * 8.0), atol=1e-6)
    assert rd.ao.mean() < r1.ao.mean() < 1.0
    info = json.loads(write_texture_set(with_relief(Maps(normal=normal)), tmp_path, "m")["sidecar"].read_text())
    assert info["relief"]["ao"]["strength"] == 8.0 and "0.12 x" in info["relief"]["ao"]["strength_reason"]
    info = json.loads(write_texture_set(with_relief(Maps(normal=normal), ao_strength=1), tmp_path / "b", "m")[
        "sidecar"].read_text())
    assert info["relief"]["ao"]["strength"] == 1.0
    for bad in (0, -1, float("nan"), "x"):
        with pytest.raises(SvbrdfError, match="ao_strength"):
            relief_maps(normal, ao_strength=bad)


@pytest.mark.parametrize("normal", ["opengl", "dx"])
def test_maps_out_of_range_are_written_as_their_clipped_copy(tmp_path, normal):
    """The writer clips and encodes each map strip by strip (no full-size copy): the files are those of
    :meth:`Maps.clipped`, to the bit, for values outside the ranges and normals that are not unit length."""
    rng = np.random.default_rng(11)
    h, w = 40, 24
    raw = Maps(diffuse=rng.uniform(-0.2, 1.3, (h, w, 3)).astype(np.float32),
               specular=rng.uniform(-0.1, 1.1, (h, w, 1)).astype(np.float32),
               roughness=rng.uniform(-0.1, 1.2, (h, w, 1)).astype(np.float32),
               normal=rng.uniform(-1.5, 1.5, (h, w, 3)).astype(np.float32))
    from svbrdf.runtime.core.maps import encode_normal, normal_gl_to_dx
    from svbrdf.runtime.io.images import write_image

    paths = write_texture_set(raw, tmp_path / "raw", "m", normal=normal)
    c = raw.clipped()  # what the writer wrote before: one clipped copy of the set, then each file from it
    n = encode_normal(normal_gl_to_dx(c.normal) if normal == "dx" else c.normal)
    expected = {"basecolor": (c.diffuse, 8, True), "normal": (n, 16, False), "roughness": (c.roughness, 16, False),
                "specular": (c.specular, 16, False)}
    for role, (arr, bits, srgb) in expected.items():
        ref = write_image(tmp_path / f"{role}.png", arr, bits=bits, srgb_encode=srgb)
        np.testing.assert_array_equal(read_image(paths[role], raw=True), read_image(ref, raw=True))


# ------------------------------------------------------------- the relief computed while the maps are written
def _full_maps():
    normal, _ = _bump_normals()
    rng = np.random.default_rng(5)
    return Maps(diffuse=rng.uniform(0.1, 0.8, (48, 64, 3)).astype(np.float32),
                specular=np.full((48, 64, 1), 0.04, np.float32),
                roughness=rng.uniform(0.2, 0.7, (48, 64, 1)).astype(np.float32), normal=normal,
                meta={"source": "photo.jpg"})


@pytest.mark.parametrize("fmt", ["png", "exr"])
def test_relief_beside_the_writes_gives_the_same_files(tmp_path, fmt):
    maps = _full_maps()
    panel = relit_panel(maps)
    before = write_texture_set(with_relief(maps), tmp_path / "a", "m", fmt=fmt, relit=panel)
    calls = []

    def relief(m):
        calls.append(m)
        return with_relief(m)

    beside = write_texture_set(maps, tmp_path / "b", "m", fmt=fmt, relit=lambda: panel, relief=relief)
    assert len(calls) == 1 and calls[0] is maps
    assert list(beside) == list(before) == ["basecolor", "normal", "roughness", "specular", "height", "ao",
                                            "sidecar", "relit"]
    for role in before:
        assert _content(beside[role]) == _content(before[role]), role
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == sorted(p.name for p in (tmp_path / "a").iterdir())


def test_relief_beside_the_writes_fails_whole(tmp_path, monkeypatch):
    from svbrdf.runtime.errors import SvbrdfError
    from svbrdf.runtime.outputs import texture_set
    from svbrdf.runtime.outputs.targets import write_target

    maps = _full_maps()

    def broken(m):
        raise SvbrdfError("photo.jpg: normal map: 3 pixel(s) are NaN or infinite")

    with pytest.raises(SvbrdfError, match="NaN or infinite"):
        write_texture_set(maps, tmp_path / "out", "m", relief=broken)
    assert not (tmp_path / "out").exists()
    # a relief file that exists: refused, and none of the maps written beside the relief is left
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "m_ao.png").write_bytes(b"mine")
    with pytest.raises(ImageError, match="m_ao.png"):
        write_texture_set(maps, tmp_path / "out", "m", relief=with_relief)
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["m_ao.png"]
    assert (tmp_path / "out" / "m_ao.png").read_bytes() == b"mine"
    # a failing write of a relief file
    real = texture_set.write_image

    def failing(path, *args, **kwargs):
        if path.name == "m_height.png":
            raise ImageError(f"{path}: disk full")
        return real(path, *args, **kwargs)

    monkeypatch.setattr(texture_set, "write_image", failing)
    with pytest.raises(ImageError, match=r"m_height.png: disk full"):
        write_texture_set(maps, tmp_path / "new", "m", relief=with_relief)
    assert not (tmp_path / "new").exists(), list((tmp_path / "new").rglob("*"))
    monkeypatch.undo()
    # a layout that packs the relief into the maps' files cannot write them first
    from svbrdf.runtime.outputs.texture_set import write_layout
    from svbrdf.runtime.outputs import targets

    with pytest.raises(ValueError, match="changes its other files with the relief"):
        write_layout(maps, tmp_path / "gltf", "m", lambda m, c: targets._PLANS["gltf"](m, c, targets.PRESETS["gltf"], "m"),
                     relief=with_relief)
    assert not (tmp_path / "gltf").exists()
    assert write_target(with_relief(maps), tmp_path / "gltf", "m", "gltf")  # with maps that carry it
