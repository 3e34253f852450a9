"""The camera's field of view from EXIF: 35 mm-equivalent and sensor-size records, orientation, crops, absurd
records; and ``svbrdf-preview``'s sidecar ``camera`` with each source."""

import json
import math
import warnings

import numpy as np
import pytest

from svbrdf.runtime.io.exif import exif_camera
from svbrdf.runtime.io.images import ImageWarning

EXAMPLE_FILE_SIZE = (48, 64)  # (h, w) of the files written here; EXIF records a 4032 x 3024 frame


def _jpeg(path, size=EXAMPLE_FILE_SIZE, **attrs):
    import OpenImageIO as oiio

    h, w = size
    spec = oiio.ImageSpec(w, h, 3, oiio.UINT8)
    for name, value in attrs.items():
        name = name.replace("__", ":")
        if isinstance(value, tuple):
            spec.attribute(name, oiio.TypeDesc(value[0]), value[1])
        else:
            spec.attribute(name, value)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), spec)
    rng = np.random.default_rng(0)
    out.write_image(rng.integers(40, 200, (h, w, 3)).astype(np.uint8))
    out.close()
    return path


def _frame(**more):
    return {"Exif__PixelXDimension": 4032, "Exif__PixelYDimension": 3024, **more}


def _fov(width_mm, focal_mm):
    return 2 * math.degrees(math.atan(width_mm / (2 * focal_mm)))


def test_35mm_equivalent_across_the_displayed_width(tmp_path):
    f35 = 26
    cam = exif_camera(_jpeg(tmp_path / "a.jpg", **_frame(Exif__FocalLengthIn35mmFilm=f35)))
    assert cam.fov_deg == pytest.approx(_fov(math.hypot(36, 24) * 4 / 5, 26), abs=1e-3)  # 67.3 deg
    assert "FocalLengthIn35mmFilm 26" in cam.how
    # turned a quarter (Orientation 6): the displayed width is the frame's short side
    cam = exif_camera(_jpeg(tmp_path / "p.jpg", **_frame(Exif__FocalLengthIn35mmFilm=f35, Orientation=6)),
                      size=(64, 48))
    assert cam.fov_deg == pytest.approx(_fov(math.hypot(36, 24) * 3 / 5, 26), abs=1e-3)  # 53.0 deg


def test_focal_length_with_the_sensor_size(tmp_path):
    # a 6.4 mm wide sensor recorded as pixels per mm (unit 4), a 4.2 mm lens
    path = _jpeg(tmp_path / "s.jpg", **_frame(Exif__FocalLength=4.2, Exif__FocalPlaneXResolution=4032 / 6.4,
                                              Exif__FocalPlaneResolutionUnit=4))
    cam = exif_camera(path)
    assert cam is not None and cam.fov_deg == pytest.approx(_fov(6.4, 4.2), abs=0.05)  # 74.6 deg
    # a focal length alone says nothing of the field of view
    assert exif_camera(_jpeg(tmp_path / "f.jpg", **_frame(Exif__FocalLength=4.2))) is None
    assert exif_camera(_jpeg(tmp_path / "none.jpg")) is None


def test_a_downsized_photo_keeps_and_a_crop_narrows_the_field_of_view(tmp_path):
    f35 = {"Exif__FocalLengthIn35mmFilm": 26}
    full = _fov(math.hypot(36, 24) * 4 / 5, 26)
    assert exif_camera(_jpeg(tmp_path / "d.jpg", **_frame(**f35))).fov_deg == pytest.approx(full, abs=1e-3)
    with pytest.warns(ImageWarning, match="crop of 75% of its width"):  # a square of the whole height
        cam = exif_camera(_jpeg(tmp_path / "c.jpg", size=(48, 48), **_frame(**f35)))
    expected = 2 * math.degrees(math.atan(0.75 * math.tan(math.radians(full) / 2)))
    assert cam.fov_deg == pytest.approx(expected, abs=1e-3)


@pytest.mark.parametrize("attrs", [{"Exif__FocalLengthIn35mmFilm": 1},  # 173 deg
                                   {"Exif__FocalLengthIn35mmFilm": 900},  # 2.2 deg
                                   {"Exif__FocalLength": 0.0, "Exif__FocalPlaneXResolution": 600.0,
                                    "Exif__FocalPlaneResolutionUnit": 4}])
def test_an_absurd_record_is_a_warning_and_no_answer(tmp_path, attrs):
    with pytest.warns(ImageWarning, match="not a plausible camera"):
        assert exif_camera(_jpeg(tmp_path / "x.jpg", **_frame(**attrs))) is None


def test_the_sidecar_records_the_camera_and_its_source(tmp_path, capsys):
    from svbrdf.runtime.cli.preview import main

    photo = _jpeg(tmp_path / "phone.jpg", **_frame(Exif__FocalLengthIn35mmFilm=26))
    runs = {"exif": [], "option": ["--fov", "30"]}
    for source, extra in runs.items():
        out = tmp_path / source
        assert main([str(photo), "-o", str(out), "-q", *extra]) == 0
        meta = json.loads((out / "phone.json").read_text())
        assert meta["camera"]["fov_source"] == source
        assert meta["brdf"]["render_config"]["fov_deg"] == meta["camera"]["fov_deg"]
    assert json.loads((tmp_path / "option" / "phone.json").read_text())["camera"]["fov_deg"] == 30.0
    bad = _jpeg(tmp_path / "bad.jpg", **_frame(Exif__FocalLengthIn35mmFilm=1))
    capsys.readouterr()
    assert main([str(bad), "-o", str(tmp_path / "bad")]) == 0
    err = capsys.readouterr().err
    assert "svbrdf-preview: warning:" in err and "not a plausible camera" in err and "Traceback" not in err
    assert json.loads((tmp_path / "bad" / "bad.json").read_text())["camera"]["fov_source"] == "default"
