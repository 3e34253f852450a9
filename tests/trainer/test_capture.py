"""Several calibrated views of one material fitted together (:mod:`svbrdf.trainer.capture`, ``svbrdf-preview
--capture``): on a synthetic capture rendered from known maps, the fit relights a view it did not see better than
its prior; the command's outputs and its one-line errors."""

import json
import math

import numpy as np
import pytest

from svbrdf.runtime.cli.preview import main
from svbrdf.runtime.core.maps import Maps, normalize_normals
from svbrdf.runtime.core.render import ZHAO, render
from svbrdf.runtime.io.images import write_image
from svbrdf.trainer.bench.cases import CaptureViews
from svbrdf.trainer.bench.datasets import read_capture_calibration
from svbrdf.trainer.bench.metrics import relight_view
from svbrdf.trainer.capture import average_maps, capture_fov, fit_capture

ERR = "svbrdf-preview: error: "
S = 48
WIDTH_CM = 10.0
#: Camera (= flash) positions in cm, as bath_tile's: about 11 cm above a 10 cm square, moved around.
CAMERAS = [(0.0, 0.0, 11.0), (3.0, 2.0, 10.5), (-2.5, 1.5, 11.2), (2.0, -3.0, 10.8), (-1.5, -2.0, 10.6)]


def _truth() -> Maps:
    yy, xx = (np.mgrid[0:S, 0:S] + 0.5) / S
    normal = normalize_normals(np.stack([0.35 * np.sin(12 * xx), 0.3 * np.cos(9 * yy), np.ones((S, S))], -1))
    diffuse = np.stack([0.45 + 0.2 * np.sin(7 * yy), 0.3 + 0.1 * xx, 0.2 * np.ones((S, S))], -1)
    return Maps(diffuse=diffuse.astype(np.float32), specular=(0.1 + 0.3 * xx[..., None]).astype(np.float32),
                roughness=(0.25 + 0.3 * yy[..., None]).astype(np.float32), normal=normal.astype(np.float32))


def _capture(folder, cameras=CAMERAS, sizes=None):
    """Views of the truth rendered at ``cameras`` (16-bit sRGB PNGs) and their parameters.json."""
    folder.mkdir(parents=True, exist_ok=True)
    truth, half = _truth(), WIDTH_CM / 2
    photos = {}
    for i, cam in enumerate(cameras):
        scene = np.asarray(cam) / half
        photo = np.clip(render(truth, scene, ZHAO.replace(falloff=True), camera_pos=scene) * 0.5, 0, 1)
        if sizes and i in sizes:
            photo = photo[: sizes[i], : sizes[i]]
        write_image(folder / f"{i:02d}.png", photo.astype(np.float32), bits=16, srgb_encode=True)
        photos[i] = photo.astype(np.float32)
    (folder / "parameters.json").write_text(json.dumps({
        "image_size": WIDTH_CM, "idx": list(range(len(cameras))), "camera_pos": [list(c) for c in cameras],
        "light_pos": [list(c) for c in cameras]}))
    return photos


def _flat(like: Maps) -> Maps:
    normal = np.zeros((S, S, 3), np.float32)
    normal[..., 2] = 1
    return Maps(diffuse=np.full((S, S, 3), like.diffuse.mean((0, 1)), np.float32),
                specular=np.full((S, S, 1), 0.04, np.float32), roughness=np.full((S, S, 1), 0.5, np.float32),
                normal=normal)


def _rmse(maps, capture, view):
    relit, ref, ok = relight_view(maps, capture, view, ZHAO)
    return math.sqrt(float(np.mean((relit[ok] - ref[ok]) ** 2)))


@pytest.mark.integration
def test_the_fit_relights_a_view_it_did_not_see_better_than_its_prior(tmp_path):
    photos = _capture(tmp_path / "cap")
    calib = read_capture_calibration(tmp_path / "cap")
    capture = CaptureViews(calib, -1, photos)
    prior = _flat(_truth())
    fit = fit_capture({i: p for i, p in photos.items() if i != 0}, calib, prior, iters=150, threads=1)
    assert fit.shape == (S, S) and fit.meta["capture"]["views"] == [1, 2, 3, 4]
    before, after = _rmse(prior, capture, 0), _rmse(fit, capture, 0)
    assert after < 0.9 * before, (before, after)
    assert np.allclose(np.linalg.norm(fit.normal, axis=-1), 1, atol=1e-5)
    # the prior holds where the views say nothing: a fit with a heavy pull barely moves
    held = fit_capture({1: photos[1]}, calib, prior, iters=20, prior_weight=1e4, threads=1)
    assert np.abs(held.roughness - prior.roughness).max() < 0.02


def test_average_maps_and_the_field_of_view(tmp_path):
    _capture(tmp_path / "cap")
    truth = _truth()
    mean = average_maps([truth, _flat(truth)])
    assert np.allclose(np.linalg.norm(mean.normal, axis=-1), 1, atol=1e-5)
    assert np.allclose(mean.roughness, (truth.roughness + 0.5) / 2)
    fov = capture_fov(read_capture_calibration(tmp_path / "cap"))
    mean_z = np.mean([c[2] for c in CAMERAS])
    assert fov == pytest.approx(2 * math.degrees(math.atan(WIDTH_CM / 2 / mean_z)))


def test_svbrdf_preview_capture_writes_one_set(tmp_path, capsys):
    _capture(tmp_path / "cap")
    out = tmp_path / "out"
    assert main(["--capture", str(tmp_path / "cap"), "-o", str(out), "--iters", "3", "--threads", "1", "-q"]) == 0
    meta = json.loads((out / "cap.json").read_text())
    assert meta["camera"]["fov_source"] == "calibration" and meta["meta"]["capture"]["views"] == [0, 1, 2, 3, 4]
    assert meta["brdf"]["render_config"]["fov_deg"] == pytest.approx(meta["camera"]["fov_deg"], abs=1e-3)
    assert {"cap_basecolor.png", "cap_normal.png", "cap_relit.png", "cap_height.png"} <= {p.name for p in out.iterdir()}
    assert main(["--capture", str(tmp_path / "cap"), "-o", str(out), "--iters", "3", "-q"]) == 1  # exists
    assert "exists" in capsys.readouterr().err


def _errors(err: str) -> list:
    return [line for line in err.splitlines() if line.startswith(ERR)]


def test_bad_captures_are_one_line(tmp_path, capsys):
    (tmp_path / "none").mkdir()
    write_image(tmp_path / "none" / "00.png", np.full((S, S, 3), 0.5, np.float32), bits=8, srgb_encode=True)
    _capture(tmp_path / "sizes", sizes={2: S - 8})
    _capture(tmp_path / "gone")
    for i in range(len(CAMERAS)):
        (tmp_path / "gone" / f"{i:02d}.png").unlink()
    cases = {"none": "not a calibrated capture", "sizes": "different sizes", "gone": "none of their photos",
             "missing-folder": "needs a folder"}
    for folder, expected in cases.items():
        code = main(["--capture", str(tmp_path / folder), "-o", str(tmp_path / f"o-{folder}"), "--iters", "1", "-q"])
        err = capsys.readouterr().err
        assert code == 1 and "Traceback" not in err, (folder, err)
        assert len(_errors(err)) == 1 and expected in _errors(err)[0], (folder, err)
        assert not (tmp_path / f"o-{folder}").exists()


def test_a_view_listed_but_absent_is_a_warning(tmp_path, capsys):
    _capture(tmp_path / "cap")
    (tmp_path / "cap" / "03.png").unlink()
    assert main(["--capture", str(tmp_path / "cap"), "-o", str(tmp_path / "out"), "--iters", "1"]) == 0
    err = capsys.readouterr().err
    assert "svbrdf-preview: warning:" in err and "there is no photo of it (03)" in err
    assert json.loads((tmp_path / "out" / "cap.json").read_text())["meta"]["capture"]["views"] == [0, 1, 2, 4]


@pytest.mark.parametrize("argv, expected", [
    (["photo.png", "--capture", "cap"], "give photos or --capture DIR (not both)"),
    (["--capture", "cap", "--refine"], "--capture fits the views itself"),
    ([], "no photo given"),
])
def test_usage_errors(argv, expected, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert expected in err and "Traceback" not in err
