"""photo_camera: --fov, EXIF, the fall-off estimate, a phone's main camera (svbrdf.runtime.workflow.camera)."""

import numpy as np
import pytest

from svbrdf.runtime.io.images import ImageWarning, write_image
from svbrdf.runtime.workflow.camera import photo_camera


def test_photo_camera_option_then_estimate_then_default(tmp_path, flash_plane):
    import math
    import warnings

    plane = flash_plane(tmp_path / "plane.png", 70.0)
    assert photo_camera(plane, 30.0) == {"fov_deg": 30.0, "fov_source": "option", "how": "--fov"}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a photo with its flash in frame: no warning
        cam = photo_camera(plane, None)
    assert cam["fov_source"] == "estimated" and abs(cam["fov_deg"] - 70.0) < 0.1 * 70.0, cam
    assert "fall-off" in cam["how"] and "highlight" not in cam
    # the same photo read already (any size): the same answer
    from svbrdf.runtime.io.images import read_image

    assert photo_camera(plane, None, image=read_image(plane))["fov_deg"] == pytest.approx(cam["fov_deg"], rel=0.02)
    # a photo without fall-off: the default, with the reason, and no flash seen
    flat = tmp_path / "flat.png"
    write_image(flat, np.random.default_rng(0).uniform(0.1, 0.6, (48, 64, 3)).astype(np.float32), bits=8,
                srgb_encode=True)
    cam = photo_camera(flat, None)
    # a 4:3 photo from a phone's main camera (26 mm equivalent): 2 atan(34.62 / 52) across its width
    assert cam["fov_source"] == "default" and cam["fov_deg"] == pytest.approx(67.30, abs=0.01)
    assert "phone's main camera" in cam["how"]
    assert "no estimate from the fall-off" in cam["how"] and cam.get("highlight") == "absent"
    # the flash beside the photo: a warning naming the photo and the camera assumed
    off = flash_plane(tmp_path / "off.png", 45.0, light=[2.5, 0.0, 1.0 / math.tan(math.radians(22.5))])
    with pytest.warns(ImageWarning, match="off.png: the flash highlight is out of frame; the maps assume a camera of"):
        cam = photo_camera(off, None)
    assert cam["highlight"] == "out of frame"


def test_an_absurd_exif_focal_length_is_a_warning_and_then_the_estimate(tmp_path, flash_plane):
    import OpenImageIO as oiio

    src = oiio.ImageBuf(str(flash_plane(tmp_path / "plane.png", 70.0)))
    src.specmod().attribute("Exif:FocalLengthIn35mmFilm", 0)
    src.specmod().attribute("compression", "jpeg:98")
    assert src.write(str(tmp_path / "zero.jpg"))
    with pytest.warns(ImageWarning, match="FocalLengthIn35mmFilm 0 is not a plausible camera"):
        cam = photo_camera(tmp_path / "zero.jpg", None)
    assert cam["fov_source"] == "estimated" and abs(cam["fov_deg"] - 70.0) < 0.1 * 70.0, cam


def test_process_photo_renders_with_the_estimated_camera_reading_the_photo_once(session, tmp_path, flash_plane,
                                                                               monkeypatch):
    pytest.importorskip("onnxruntime")
    import math

    from svbrdf.runtime.workflow import camera as camera_module
    from svbrdf.runtime.workflow.options import PhotoOptions
    from svbrdf.runtime.workflow.photo import process_photo

    plane = flash_plane(tmp_path / "plane.png", 70.0)
    expected = photo_camera(plane, None)
    # the preview's own read of the photo serves the camera: no second read
    monkeypatch.setattr(camera_module, "read_image", lambda *a, **k: pytest.fail("the photo was read twice"))
    maps, relit, _ = process_photo(plane, PhotoOptions(threads=1), session)
    assert maps.meta["camera"]["fov_source"] == "estimated"
    assert maps.meta["camera"]["fov_deg"] == pytest.approx(expected["fov_deg"], rel=0.02)
    assert maps.render_config.fov_deg == maps.meta["camera"]["fov_deg"]
    # the flash beside the photo: the warning names the photo and the camera assumed, as photo_camera's does
    off = flash_plane(tmp_path / "off.png", 45.0, light=[2.5, 0.0, 1.0 / math.tan(math.radians(22.5))])
    with pytest.warns(ImageWarning, match="off.png: the flash highlight is out of frame"):
        maps, _, _ = process_photo(off, PhotoOptions(threads=1), session)
    assert maps.meta["camera"]["highlight"] == "out of frame"


@pytest.mark.parametrize("size, fov", [((64, 64), 53.06), ((64, 48), 67.30), ((48, 64), 53.06), ((64, 36), 67.30),
                                       ((36, 64), 41.05), ((1, 400), 5.0)])
def test_without_exif_or_fall_off_the_camera_is_a_phones_across_the_photos_shape(size, fov):
    """The largest centred crop of the photo's shape from a 4:3 phone frame turned like the photo, at 26 mm
    equivalent: a square photo spans 3/4 of the frame's width, a 9:16 portrait 9/16 of the portrait frame's height;
    a strip the narrowest plausible camera."""
    from svbrdf.runtime.workflow.camera import image_camera

    width, height = size
    flat = np.random.default_rng(1).uniform(0.1, 0.6, (height, width, 3)).astype(np.float32)
    cam = image_camera(flat)  # a strip is too small for the fall-off's grid: the default too
    assert cam["fov_source"] == "default" and cam["fov_deg"] == pytest.approx(fov, abs=0.01), cam
    assert f"{width}x{height} photo" in cam["how"]
