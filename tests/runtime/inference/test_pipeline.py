"""The per-photo pipeline: estimate(..., post=PostProcess), PhotoOptions and process_photo (the one path of both CLIs)."""

import argparse
import os
import platform
import sys

import numpy as np
import pytest

from svbrdf.runtime.io.images import ImageWarning, write_image

pytest.importorskip("onnxruntime")
from svbrdf.runtime.inference.pipeline import PhotoOptions, estimate, process_photo  # noqa: E402
from svbrdf.runtime.post import PostProcess  # noqa: E402


def _photo(h=40, w=56, seed=3):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    base = 0.3 + 0.1 * np.sin(xx / 3.0)[..., None] * np.array([1.0, 0.8, 0.6], np.float32)
    flash = 0.6 * np.exp(-((yy - h / 2) ** 2 + (xx - w / 2) ** 2) / (2 * 8.0 ** 2))[..., None]
    return (base + flash + rng.normal(0, 0.01, (h, w, 3))).clip(0, 1).astype(np.float32)


def test_the_default_post_is_what_estimate_did_without_it(session):
    photo = _photo()
    a, b = estimate(photo, session), estimate(photo, session, post=PostProcess())
    for name in a.names:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_without_corrections_estimate_returns_the_networks_maps(session):
    photo = _photo()
    bare = estimate(photo, session, post=PostProcess.off())
    assert bare.meta["even_lighting"] is None
    assert bare.meta["burn_in"] == bare.meta["burn_in_model"]
    assert "flash_trend" not in bare.meta and "uniform_specular" not in bare.meta
    raw = session.run(photo)
    np.testing.assert_allclose(bare.roughness[..., 0], raw[..., 4].clip(0, 1), atol=1e-6)
    shipped = estimate(photo, session)
    assert np.ptp(shipped.specular) == 0 and np.ptp(bare.specular) > 0  # one specular level only when asked
    one_off = estimate(photo, session, post=PostProcess(uniform_specular=False))
    assert np.ptp(one_off.specular) > 0 and "flash_trend" in one_off.meta


def test_photo_options_from_parsed_arguments_keep_only_their_fields():
    args = argparse.Namespace(maps=("normal",), tile=512, verbose=True, photos=["x.png"], out=None, force=True)
    options = PhotoOptions.from_mapping(args)
    assert options.maps == ("normal",) and options.tile == 512 and options.force
    assert options.post == PostProcess() and options.max_size == 2048
    assert PhotoOptions.from_mapping({"maps": ["basecolor", "normal"]}).maps == ("diffuse", "normal")
    with pytest.raises(Exception, match="unknown map"):
        PhotoOptions(maps=("shininess",))


def test_process_photo_with_options(session, tmp_path):
    path = tmp_path / "wood.png"
    write_image(path, _photo(), bits=16)
    maps, relit, detail = process_photo(path, PhotoOptions(), session)
    assert maps.complete and relit.shape == (40, 3 * 56, 3) and detail.startswith("model")  # h x 3w, sRGB
    only, none, _ = process_photo(path, PhotoOptions(maps=("normal",)), session)
    assert only.names == ("normal",) and none is None
    bare, _, _ = process_photo(path, PhotoOptions(post=PostProcess.off()), session)
    assert bare.meta["even_lighting"] is None
    with pytest.raises(ValueError, match="needs the refine function"):
        process_photo(path, PhotoOptions(refine=True), session)


@pytest.mark.parametrize("target", ["generic", "gltf"])
def test_relief_and_panel_left_to_the_writers_give_the_same_files(session, tmp_path, target):
    from svbrdf.runtime.inference.pipeline import write_maps

    path = tmp_path / "wood.png"
    write_image(path, _photo(), bits=16)
    options = PhotoOptions(target=target)
    now = process_photo(path, options, session)
    maps, relit, _ = process_photo(path, options, session, later=True)
    assert now[0].relief is not None and maps.relief is None and callable(relit)
    np.testing.assert_array_equal(relit(), now[1])
    a = write_maps(now[0], now[1], tmp_path / "a", "wood", options, {})
    b = write_maps(maps, relit, tmp_path / "b", "wood", options, {})
    assert list(a) == list(b) and {"sidecar", "relit"} <= set(a) and ("height" in a or "orm" in a)
    for role in a:
        if role != "sidecar":
            assert a[role].read_bytes() == b[role].read_bytes(), role
    assert "relief" in maps.meta["timings"]  # timed while the maps were written


def test_processed_pixels_reads_the_header(tmp_path):
    from svbrdf.runtime.inference.pipeline import processed_pixels

    path = tmp_path / "p.png"
    write_image(path, np.full((30, 80, 3), 0.5, np.float32), bits=8)
    assert processed_pixels(path, 2048) == 30 * 80
    assert processed_pixels(path, 40) == 15 * 40  # downsized to the long side


_REUSE_PROBE = """
import os, numpy as np
from svbrdf.runtime.inference.pipeline import REUSE_PIXELS, reuse_memory

def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

def rss_after_free():
    a = np.ones(40 * 2**20 // 4, np.float32)  # 40 MB, touched
    before = rss()
    del a
    return before - rss()

assert reuse_memory(1024 * 1024) is True
kept = rss_after_free()
assert reuse_memory(REUSE_PIXELS + 1) is False
print(kept, rss_after_free())
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.exists("/proc/self/statm")
                    or platform.libc_ver()[0] != "glibc", reason="glibc's allocator on Linux")
def test_reuse_memory_keeps_freed_arrays_in_the_process_up_to_its_size():
    """Up to REUSE_PIXELS a freed large array stays in the process (the next one reuses its pages); above it,
    glibc's defaults give it back to the system. In a fresh process: the allocator's state is the process's, and
    what earlier tests left free in its heap would serve the array without a mapping of its own."""
    import subprocess

    r = subprocess.run([sys.executable, "-c", _REUSE_PROBE], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    kept, returned = map(int, r.stdout.split())
    assert kept < 4 * 2**20 and returned > 36 * 2**20  # bytes given back by the free


# --- the camera: --fov, EXIF, the fall-off estimate, the default (photo_camera) ---------------------------------

def _flash_plane(path, fov, light=None, n=256, seed=0):
    """A textured diffuse plane rendered with fall-off at ``fov`` (flash above the centre or at ``light``), as an
    8-bit sRGB PNG (or a JPEG by its suffix); returns ``path``."""
    from svbrdf.runtime.core.maps import Maps
    from svbrdf.runtime.core.render import ZHAO, physical_config, render

    rng = np.random.default_rng(seed)
    noise = rng.normal(0.0, 1.0, (n // 8, n // 8, 1)).repeat(8, 0).repeat(8, 1)
    maps = Maps(diffuse=np.clip(np.array([0.45, 0.3, 0.2]) * np.exp(0.3 * noise), 0, 1).astype(np.float32),
                specular=np.zeros((n, n, 1), np.float32), roughness=np.full((n, n, 1), 0.5, np.float32),
                normal=np.dstack([np.zeros((n, n, 2)), np.ones((n, n, 1))]).astype(np.float32))
    img = render(maps, light, physical_config(ZHAO.replace(fov_deg=fov)))
    write_image(path, np.clip(img / np.percentile(img, 99.5) * 0.9, 0, 1).astype(np.float32), bits=8,
                srgb_encode=True)
    return path


def test_photo_camera_option_then_estimate_then_default(tmp_path):
    import math
    import warnings

    from svbrdf.runtime.inference.pipeline import photo_camera

    plane = _flash_plane(tmp_path / "plane.png", 70.0)
    assert photo_camera(plane, 30.0, 66.0) == {"fov_deg": 30.0, "fov_source": "option", "how": "--fov"}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a photo with its flash in frame: no warning
        cam = photo_camera(plane, None, 66.0)
    assert cam["fov_source"] == "estimated" and abs(cam["fov_deg"] - 70.0) < 0.1 * 70.0, cam
    assert "fall-off" in cam["how"] and "highlight" not in cam
    # the same photo read already (any size): the same answer
    from svbrdf.runtime.io.images import read_image

    assert photo_camera(plane, None, 66.0, image=read_image(plane))["fov_deg"] == pytest.approx(cam["fov_deg"], rel=0.02)
    # a photo without fall-off: the default, with the reason, and no flash seen
    flat = tmp_path / "flat.png"
    write_image(flat, np.random.default_rng(0).uniform(0.1, 0.6, (48, 64, 3)).astype(np.float32), bits=8,
                srgb_encode=True)
    cam = photo_camera(flat, None, 66.0)
    assert cam["fov_source"] == "default" and cam["fov_deg"] == 66.0
    assert "no estimate from the fall-off" in cam["how"] and cam.get("highlight") == "absent"
    # the flash beside the photo: a warning naming the photo and the camera assumed
    off = _flash_plane(tmp_path / "off.png", 45.0, light=[2.5, 0.0, 1.0 / math.tan(math.radians(22.5))])
    with pytest.warns(ImageWarning, match="off.png: the flash highlight is out of frame; the maps assume a camera of"):
        cam = photo_camera(off, None, 66.0)
    assert cam["highlight"] == "out of frame"


def test_an_absurd_exif_focal_length_is_a_warning_and_then_the_estimate(tmp_path):
    import OpenImageIO as oiio

    from svbrdf.runtime.inference.pipeline import photo_camera

    src = oiio.ImageBuf(str(_flash_plane(tmp_path / "plane.png", 70.0)))
    src.specmod().attribute("Exif:FocalLengthIn35mmFilm", 0)
    src.specmod().attribute("compression", "jpeg:98")
    assert src.write(str(tmp_path / "zero.jpg"))
    with pytest.warns(ImageWarning, match="FocalLengthIn35mmFilm 0 is not a plausible camera"):
        cam = photo_camera(tmp_path / "zero.jpg", None, 66.0)
    assert cam["fov_source"] == "estimated" and abs(cam["fov_deg"] - 70.0) < 0.1 * 70.0, cam


def test_process_photo_renders_with_the_estimated_camera(session, tmp_path):
    plane = _flash_plane(tmp_path / "plane.png", 70.0)
    maps, relit, _ = process_photo(plane, PhotoOptions(threads=1), session)
    assert maps.meta["camera"]["fov_source"] == "estimated"
    assert maps.render_config.fov_deg == maps.meta["camera"]["fov_deg"]


def _fake_capture():
    from types import SimpleNamespace

    from svbrdf.trainer.bench.datasets import capture_view_file, read_capture_calibration

    return SimpleNamespace(read_calibration=read_capture_calibration, view_file=capture_view_file)


def _calibrated(folder, n=3, size=(32, 32)):
    import json

    folder.mkdir()
    for i in range(n):
        write_image(folder / f"{i:02d}.png", np.full((*size, 3), 0.4, np.float32), bits=8, srgb_encode=True)
    (folder / "parameters.json").write_text(json.dumps({
        "image_size": 10.0, "idx": list(range(n)), "camera_pos": [[0.0, 0.0, 11.0]] * n}))
    return folder


def test_a_capture_view_the_calibration_does_not_list_is_refused(tmp_path):
    from svbrdf.runtime.errors import SvbrdfError
    from svbrdf.runtime.inference.pipeline import process_capture

    cap = _calibrated(tmp_path / "cap")
    write_image(cap / "07.png", np.full((32, 32, 3), 0.4, np.float32), bits=8, srgb_encode=True)
    with pytest.raises(SvbrdfError, match=r"cap: 07.png is not in parameters.json \(it lists views 0, 1, 2\)") as err:
        process_capture(cap, PhotoOptions(), None, _fake_capture())
    assert "\n" not in str(err.value)


def test_capture_views_that_are_not_square_are_refused(tmp_path):
    from svbrdf.runtime.errors import SvbrdfError
    from svbrdf.runtime.inference.pipeline import process_capture

    cap = _calibrated(tmp_path / "cap", size=(32, 48))
    with pytest.raises(SvbrdfError, match="the views are 48x32 px, not square: parameters.json gives") as err:
        process_capture(cap, PhotoOptions(), None, _fake_capture())
    assert "\n" not in str(err.value)


def test_a_calibration_listing_a_view_twice_is_refused(tmp_path):
    import json

    from svbrdf.runtime.errors import SvbrdfError
    from svbrdf.runtime.inference.pipeline import process_capture

    cap = _calibrated(tmp_path / "cap")
    (cap / "parameters.json").write_text(json.dumps({"image_size": 10.0, "idx": [0, 1, 1],
                                                      "camera_pos": [[0.0, 0.0, 11.0]] * 3}))
    with pytest.raises(SvbrdfError, match="parameters.json: idx lists view 1 more than once") as err:
        process_capture(cap, PhotoOptions(), None, _fake_capture())
    assert "\n" not in str(err.value)


def test_estimate_models_the_flash_with_the_photos_camera(session):
    """``fov_deg`` is the camera of the corrections that model the flash (the highlight's shoulder, filled) and of
    the maps' render_config; without it, the session's."""
    from svbrdf.runtime.post import highlight_fill as hf

    n = 96
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float32)
    lobe = np.exp(-((yy - n / 2) ** 2 + (xx - n / 2) ** 2) / (2 * 10.0 ** 2))[..., None]
    photo = np.clip(0.25 + 0.6 * lobe + 0.01 * np.sin(xx / 2)[..., None], 0, 1).astype(np.float32) * [1, 0.9, 0.8]
    photo = photo.astype(np.float32)
    default, narrow = estimate(photo, session), estimate(photo, session, fov_deg=20.0)
    assert default.render_config.fov_deg == session.render_config.fov_deg and narrow.render_config.fov_deg == 20.0
    assert default.meta["highlight_fill"]["pixels"] == int(hf.highlight_mask(photo).sum())
    assert narrow.meta["highlight_fill"]["pixels"] == int(hf.highlight_mask(photo, fov_deg=20.0).sum())
    assert hf.highlight_mask(photo, fov_deg=20.0).sum() != hf.highlight_mask(photo).sum()
