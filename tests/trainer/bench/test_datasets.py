"""Ground-truth readers, format detection and the case finder (svbrdf.trainer.bench.datasets)."""

import math
from pathlib import Path

import numpy as np
import pytest

from svbrdf.runtime.core.colour import srgb_to_linear
from svbrdf.trainer.bench.datasets import (
    Case, detect_format, find_cases, normal_curl_ratio, read_des18, read_des19, read_gt, read_xuejiao,
)
from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.io.images import write_image

S = 16  # panel side of the synthetic files


def _panels(rng):
    """Stored (encoded, [0,1]) panels with distinct content, and the normal they encode."""
    y, x = np.mgrid[0:S, 0:S] / S
    normal = np.stack([0.4 * np.sin(6 * x), 0.3 * np.cos(5 * y), np.ones_like(x)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return {
        "input": rng.uniform(0, 1, (S, S, 3)),
        "normal": (normal + 1) / 2,
        "diffuse": rng.uniform(0, 1, (S, S, 3)),
        # RGB but not grey: the reader must average the channels.
        "roughness": np.stack([0.2 + 0.5 * x, 0.3 + 0.5 * x, 0.4 + 0.5 * x], -1),
        "specular": np.stack([0.02 + 0.5 * y, 0.04 + 0.5 * y, 0.06 + 0.5 * y], -1),
    }, normal


ORDERS = {
    "des18": ("input", "normal", "diffuse", "roughness", "specular"),
    "des19": ("normal", "diffuse", "roughness", "specular"),
    "xuejiao": ("diffuse", "specular", "roughness", "normal"),
}


def _write(path: Path, panels, order) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    # 16-bit so that quantisation stays far below the tolerances below.
    return write_image(path, np.concatenate([panels[n] for n in order], axis=1), bits=16)


def _quantised(a):
    return np.round(np.asarray(a) * 65535) / 65535  # compare with atol=2e-5: one 16-bit code is 1.5e-5


@pytest.fixture
def panels():
    return _panels(np.random.default_rng(0))


@pytest.mark.parametrize("fmt", list(ORDERS))
def test_readers_decode_every_panel(tmp_path, panels, fmt):
    stored, normal = panels
    path = _write(tmp_path / f"{fmt}.png", stored, ORDERS[fmt])
    reader = {"des18": read_des18, "des19": read_des19, "xuejiao": read_xuejiao}[fmt]
    out = reader(path)
    maps, photo = out if fmt == "des18" else (out, None)
    assert maps.shape == (S, S)
    np.testing.assert_allclose(maps.normal, normal, atol=1e-3)
    # Default encoding "srgb-diffuse": diffuse decoded, specular and roughness as stored.
    np.testing.assert_allclose(maps.diffuse, srgb_to_linear(_quantised(stored["diffuse"])), atol=1e-4)
    np.testing.assert_allclose(maps.roughness[..., 0], _quantised(stored["roughness"]).mean(-1), atol=2e-5)
    np.testing.assert_allclose(maps.specular[..., 0], _quantised(stored["specular"]).mean(-1), atol=2e-5)
    assert maps.meta["format"] == fmt and maps.meta["source"] == str(path)
    if fmt == "des18":
        np.testing.assert_allclose(photo, srgb_to_linear(_quantised(stored["input"])), atol=1e-4)
    # read_gt detects the layout and gives the same maps.
    gt, gt_photo = read_gt(path)
    np.testing.assert_array_equal(gt.pack(), maps.pack())
    assert (gt_photo is None) == (fmt != "des18")


@pytest.mark.parametrize("encoding", ["linear", "srgb"])
def test_normal_y_down_and_maps_encodings(tmp_path, panels, encoding):
    stored, normal = panels
    path = _write(tmp_path / "set.png", stored, ORDERS["des19"])
    maps = read_des19(path, normal_y="down", maps_encoding=encoding)
    np.testing.assert_allclose(maps.normal, normal * [1, -1, 1], atol=1e-3)
    decode = srgb_to_linear if encoding == "srgb" else (lambda a: a)
    np.testing.assert_allclose(maps.diffuse, decode(_quantised(stored["diffuse"])), atol=1e-4)
    # Specular: decoded per channel (if at all), then averaged. Roughness is data: never decoded.
    np.testing.assert_allclose(maps.specular[..., 0], decode(_quantised(stored["specular"])).mean(-1), atol=1e-4)
    np.testing.assert_allclose(maps.roughness[..., 0], _quantised(stored["roughness"]).mean(-1), atol=2e-5)
    assert maps.meta["maps_encoding"] == encoding and maps.meta["normal_y"] == "down"


def test_bad_options(tmp_path, panels):
    path = _write(tmp_path / "set.png", panels[0], ORDERS["des19"])
    with pytest.raises(ValueError, match="normal_y"):
        read_des19(path, normal_y="left")
    with pytest.raises(ValueError, match="maps_encoding"):
        read_des19(path, maps_encoding="gamma")
    with pytest.raises(ValueError, match="format"):
        detect_format(path, "des20")


@pytest.mark.parametrize("reader, fmt", [(read_des18, "des18"), (read_des19, "des19"), (read_xuejiao, "xuejiao")])
def test_size_that_does_not_fit_is_a_one_line_image_error(tmp_path, reader, fmt):
    path = tmp_path / "odd size.png"
    write_image(path, np.full((S, 3 * S, 3), 0.5), bits=8)
    with pytest.raises(ImageError) as err:
        reader(path)
    msg = str(err.value)
    assert "\n" not in msg and str(path) in msg and fmt in msg and f"{3 * S}x{S}" in msg


def test_missing_file_is_an_image_error(tmp_path):
    with pytest.raises(ImageError, match="no such file"):
        read_des18(tmp_path / "nope.png")


def test_detect_format_rules(tmp_path, panels):
    stored, _ = panels
    des18 = _write(tmp_path / "a" / "d18.png", stored, ORDERS["des18"])
    des19 = _write(tmp_path / "a" / "d19.png", stored, ORDERS["des19"])
    xue = _write(tmp_path / "a" / "xj.png", stored, ORDERS["xuejiao"])  # recognised by content, not by name
    assert detect_format(des18) == "des18"
    assert detect_format(des19) == "des19"
    assert detect_format(xue) == "xuejiao"

    # No panel at either end looks like a normal map: the naming convention decides.
    flat = {**stored, "normal": stored["diffuse"]}
    assert detect_format(_write(tmp_path / "a" / "plain.png", flat, ORDERS["des19"])) == "des19"
    assert detect_format(_write(tmp_path / "a" / "plain_gt.png", flat, ORDERS["des19"])) == "xuejiao"
    assert detect_format(_write(tmp_path / "my-xuejiao-sets" / "m.png", flat, ORDERS["des19"])) == "xuejiao"

    square = write_image(tmp_path / "photo.png", stored["input"], bits=8)
    wide = write_image(tmp_path / "wide.png", np.zeros((12, 16, 3)), bits=8)
    assert detect_format(square) == "photo" and detect_format(wide) == "photo"

    # Explicit override wins over the content rule, but the size must fit it.
    assert detect_format(des19, "xuejiao") == "xuejiao"
    assert detect_format(des18, "photo") == "photo"
    with pytest.raises(ImageError, match="does not fit the des18 layout"):
        detect_format(des19, "des18")
    with pytest.raises(ImageError, match="not a ground-truth panel set"):
        read_gt(square)


def test_find_cases_walks_any_folder(tmp_path, panels):
    stored, _ = panels
    root = tmp_path / "data"
    _write(root / "sets" / "one;two (3).png", stored, ORDERS["des18"])
    _write(root / "sets" / "deeper" / "m.png", stored, ORDERS["des19"])
    (root / "photos").mkdir()
    write_image(root / "photos" / "shot 1.png", stored["input"], bits=8)
    (root / "photos" / "LICENSE.txt").write_text("not an image")
    (root / "photos" / "meta.json").write_text("{}")
    write_image(root / "photos" / ".hidden.png", stored["input"], bits=8)
    (root / ".cache").mkdir()
    write_image(root / ".cache" / "x.png", stored["input"], bits=8)

    cases = find_cases(root)
    assert cases == [
        Case("photos/shot 1", root / "photos" / "shot 1.png", "photo", "photo"),
        Case("sets/deeper/m", root / "sets" / "deeper" / "m.png", "gt", "des19"),
        Case("sets/one;two (3)", root / "sets" / "one;two (3).png", "gt", "des18"),
    ]
    # A single file is a root too; a forced format applies to every file found.
    assert find_cases(root / "sets" / "deeper" / "m.png")[0].format == "des19"
    assert {c.format for c in find_cases(root / "sets" / "deeper", format="xuejiao")} == {"xuejiao"}
    with pytest.raises(ImageError, match="does not fit"):
        find_cases(root, format="des19")
    with pytest.raises(ImageError, match="no such file or folder"):
        find_cases(tmp_path / "absent")


def test_normal_curl_ratio_separates_the_y_conventions():
    # Normals of a height field h(x, y), y up: n ~ (-dh/dx, -dh/dy, 1).
    n = 64
    y, x = np.meshgrid(1 - (2 * np.arange(n) + 1) / n, (2 * np.arange(n) + 1) / n - 1, indexing="ij")
    hx = 0.3 * np.cos(3 * x) * np.sin(4 * y) + 0.2 * np.cos(x + 2 * y)
    hy = 0.4 * np.sin(3 * x) * np.cos(4 * y) + 0.4 * np.cos(x + 2 * y)
    normal = np.stack([-hx, -hy, np.ones_like(x)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    assert normal_curl_ratio(normal) < 0.1
    assert normal_curl_ratio(normal * [1, -1, 1]) > 1.2
    assert math.isnan(normal_curl_ratio(np.broadcast_to([0.0, 0.0, 1.0], (8, 8, 3))))


# ---- the third-party files (skipped when ../shared/data is absent) ----

@pytest.mark.integration
def test_shared_data_formats_and_conventions(shared_data):
    cases = find_cases(shared_data)
    by_folder = {}
    for c in cases:
        by_folder.setdefault(c.path.parent.name, set()).add((c.kind, c.format))
    assert by_folder["gt-material"] >= {("gt", "des18"), ("gt", "des19")}
    assert by_folder["map"] == {("gt", "xuejiao")}
    for folder in ("deschaintre18-real", "dataset", "real", "bath_tile"):
        assert by_folder[folder] == {("photo", "photo")}, folder
    for c in cases:
        if "Des18" in c.path.parts:
            assert c.format == "des18", c
        if "Des19" in c.path.parts:
            assert c.format == "des19", c

    gt = [c for c in cases if c.kind == "gt"]
    for c in gt[:: max(1, len(gt) // 8)] + [c for c in gt if c.format == "xuejiao"]:
        maps, photo = read_gt(c.path, c.format)
        assert all(np.all(np.isfinite(a)) for _, a in maps.items())
        assert maps.roughness.min() >= 0 and maps.roughness.max() <= 1
        np.testing.assert_allclose(np.linalg.norm(maps.normal, axis=-1), 1.0, atol=1e-5)
        if c.format == "des18":
            assert photo.shape == maps.diffuse.shape
        # The default normal_y ("up") is the one under which the normals integrate to a height field.
        ratio = normal_curl_ratio(maps.normal)
        if not math.isnan(ratio):
            assert ratio < normal_curl_ratio(maps.normal * [1, -1, 1]), c.name


def test_shared_des19_roughness_zero_is_kept(shared_data):
    path = shared_data / "weiyi-auxrender" / "test_data" / "Des19" / "gt-material" / "13_PolishedMarbleFloor_01.png"
    if not path.is_file():
        pytest.skip(f"{path} not found")
    maps = read_des19(path)
    assert maps.roughness.min() == 0.0 and maps.shape == (512, 512)
