"""The artist measures of the benchmark (svbrdf.trainer.bench.metrics.artist_metrics, capture_errors and the
capture reader): detail ratios, slope correlation, grazing lights, and the relighting of a multi-view capture,
on hand-made maps and a capture synthesised with the project renderer in the layout of the public captures."""

import dataclasses
import json

import numpy as np
import pytest

from svbrdf.trainer.camera_model import Camera, expose
from svbrdf.runtime.io.images import write_image
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, grazing_lights, render
from svbrdf.trainer.bench import metrics as bm
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.runtime.errors import ImageError
from svbrdf.trainer.bench.datasets import capture_view, read_capture_calibration

N = 64


def _bumpy_maps(n=N, seed=0, amp=0.6) -> Maps:
    """Maps with relief (a height field of bumps), a varied albedo and roughness."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n] / n
    h = amp * (np.sin(2 * np.pi * 4 * xx) * np.cos(2 * np.pi * 3 * yy) + 0.3 * rng.standard_normal((n, n)))
    gy, gx = np.gradient(h)
    normal = np.stack([-gx * 4, gy * 4, np.ones_like(h)], -1)  # +y up the image: rows grow downwards
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    diffuse = np.clip(0.35 + 0.2 * rng.standard_normal((n, n, 1)) * np.array([1.0, 0.8, 0.6]), 0.02, 1)
    rough = np.clip(0.45 + 0.15 * np.sin(2 * np.pi * 2 * yy)[..., None], 0.05, 1)
    return Maps(diffuse=diffuse.astype(np.float32), specular=np.full((n, n, 1), 0.06, np.float32),
                roughness=rough.astype(np.float32), normal=normal.astype(np.float32))


def _flat_constant(m: Maps) -> Maps:
    """The trivial baseline's kind of answer: mean albedo, constant roughness and specular, flat normals."""
    n = m.shape[0]
    flat = np.zeros((n, n, 3), np.float32)
    flat[..., 2] = 1
    return Maps(diffuse=np.broadcast_to(m.diffuse.mean((0, 1)), m.diffuse.shape).astype(np.float32),
                specular=np.full((n, n, 1), 0.04, np.float32), roughness=np.full((n, n, 1), 0.5, np.float32),
                normal=flat)


def test_detail_ratios_and_slope_correlation():
    gt = _bumpy_maps()
    same = bm.artist_metrics(gt, gt)
    for name in ("diffuse", "roughness", "normal"):
        assert same[f"detail_{name}"] == pytest.approx(1.0)
    assert same["normal_slope_corr"] == pytest.approx(1.0)
    assert same["grazing_rmse"] == pytest.approx(0.0, abs=1e-6)
    assert same["grazing_hp_corr"] == pytest.approx(1.0)
    flat = bm.artist_metrics(_flat_constant(gt), gt)
    # A flat normal map and constant maps score detail 0 (the criterion), whatever their RMSE.
    assert flat["detail_normal"] == 0.0 and flat["detail_roughness"] == 0.0 and flat["detail_diffuse"] == 0.0
    assert flat["normal_slope_corr"] == 0.0
    assert flat["grazing_rmse"] > 0.02
    assert flat["grazing_hp_corr"] < same["grazing_hp_corr"] - 0.2
    # Inverted relief: the detail ratio is right, the correlation says it is upside down.
    inv = Maps(**{**dict(gt.items()), "normal": gt.normal * np.array([-1, -1, 1], np.float32)})
    assert bm.artist_metrics(inv, gt)["normal_slope_corr"] == pytest.approx(-1.0)
    # A truth that is visually constant (specular 0.06 everywhere; a roughness varying by 1 / 1000) has no ratio:
    # it would be unbounded (a marble's near-constant albedo once gave 165); one just above the floor has one.
    faint = dataclasses.replace(gt, roughness=(0.5 + 0.001 * np.sign(gt.roughness - gt.roughness.mean()))
                                .astype(np.float32))
    got = bm.artist_metrics(gt, faint)
    assert "detail_specular" not in got and "detail_roughness" not in got and "detail_diffuse" in got
    visible = dataclasses.replace(faint, roughness=0.5 + 0.02 * (faint.roughness - 0.5) / 0.001)
    assert bm.artist_metrics(gt, visible)["detail_roughness"] == pytest.approx(
        bm.map_std("roughness", gt.roughness) / bm.map_std("roughness", visible.roughness))
    assert bm.map_std("roughness", visible.roughness) == pytest.approx(0.02, rel=0.01)
    # Without a ground truth only the absolute spreads are reported.
    alone = bm.artist_metrics(gt)
    assert set(alone) == {f"std_{n}" for n in ("diffuse", "specular", "roughness", "normal")}
    assert alone["std_specular"] == 0.0 and alone["std_normal"] > 0.1


def test_grazing_lights_are_grazing():
    lights = grazing_lights(ZHAO)
    assert lights.shape == (8, 3)
    d = ZHAO.camera_distance
    angles = np.degrees(np.arccos(lights[:, 2] / np.linalg.norm(lights, axis=1)))
    assert np.allclose(np.sort(angles), [60] * 4 + [75] * 4, atol=1e-4)
    assert np.allclose(np.linalg.norm(lights, axis=1), d, atol=1e-5)
    assert len({(round(x, 3), round(y, 3)) for x, y in lights[:, :2]}) == 8  # 8 azimuths in all


def test_ssim_and_blur():
    rng = np.random.default_rng(0)
    a = rng.uniform(0, 1, (32, 32))
    assert np.allclose(bm.ssim_map(a, a), 1.0)
    assert bm.ssim_map(a, rng.uniform(0, 1, (32, 32))).mean() < 0.2
    const = np.full((20, 30), 0.4)
    assert np.allclose(bm.gaussian_blur(const, 2.0), 0.4)  # reflected borders keep a constant
    assert bm.gaussian_blur(a, 1.5).std() < a.std() / 2


# --- multi-view capture -------------------------------------------------------------------------------------

# Camera (= flash) positions in cm of a 10 cm wide square, in the public captures' frame (origin at the crop
# centre, +x right, +y up the image, z out of the surface), deliberately asymmetric so that a flipped axis shows.
CAMS = [(0.5, 0.2, 11.0), (3.5, 2.5, 10.0), (-2.5, -2.0, 10.5), (-1.0, 3.0, 10.2), (3.0, -3.0, 10.8)]
WIDTH_CM = 10.0


def _write_capture(folder, maps: Maps, key="image_size", name="parameters.json", cams=CAMS):
    """A capture in the public layout: 00.png ... (8-bit sRGB, one exposure) + the calibration JSON."""
    folder.mkdir(parents=True, exist_ok=True)
    cfg = ZHAO.replace(falloff=True)
    for i, cam in enumerate(cams):
        pos = np.array(cam) / (WIDTH_CM / 2)
        img = render(maps, pos, cfg, camera_pos=pos)
        write_image(folder / f"{i:02d}.png", expose(img, Camera(ev=-0.5)), bits=8, srgb_encode=True)
    doc = {"_comment": "in cm uint", key: WIDTH_CM, "idx": list(range(len(cams))),
           "camera_pos": [list(c) for c in cams], "light_pos": [list(c) for c in cams],
           "light_pow": [1500, 1500, 1500]}
    (folder / name).write_text(json.dumps(doc))
    return folder


def test_synthetic_capture_scores_the_true_maps_near_zero(tmp_path):
    gt = _bumpy_maps(n=N)
    folder = _write_capture(tmp_path / "data" / "tile", gt)
    cases = load_cases(tmp_path / "data", N)
    assert [c.name for c in cases] == [f"tile/{i:02d}" for i in range(len(CAMS))]
    for c in cases[:2]:
        assert c.capture is not None and c.capture.index == int(c.name[-2:])
        assert c.capture.others() == [i for i in range(len(CAMS)) if i != c.capture.index]
        true = bm.capture_errors(gt, c.capture)
        base = bm.capture_errors(_flat_constant(gt), c.capture)
        assert true["capture_views"] == len(CAMS) - 1
        assert true["capture_rmse"] < 0.01  # 8-bit storage only
        assert true["capture_ssim"] > 0.98
        assert base["capture_rmse"] > 5 * true["capture_rmse"] and base["capture_rmse"] > 0.02
        assert base["capture_ssim"] < true["capture_ssim"] - 0.1
    # Axes pinned: read with y down the image (or x to the left), the calibration relights the true maps badly.
    c = cases[0]
    for flip in ((1, -1, 1), (-1, 1, 1)):
        f = np.array(flip, float)
        calib = dataclasses.replace(c.capture.calibration, views={
            i: (tuple(np.array(cam) * f), tuple(np.array(light) * f))
            for i, (cam, light) in c.capture.calibration.views.items()})
        wrong = dataclasses.replace(c.capture, calibration=calib)
        assert bm.capture_errors(gt, wrong)["capture_rmse"] > 5 * bm.capture_errors(gt, c.capture)["capture_rmse"]
    # evaluate() reports the capture measures of a view case.
    out = bm.evaluate(gt, photo=c.photo, centre=c.centre, capture=c.capture)
    assert out["capture_rmse"] < 0.01


def test_capture_calibration_versions_and_errors(tmp_path):
    gt = _bumpy_maps(n=32)
    folder = _write_capture(tmp_path / "optim", gt, key="im_size", name="optim.json", cams=CAMS[:3])
    calib = read_capture_calibration(folder)
    assert calib.width_cm == WIDTH_CM and sorted(calib.views) == [0, 1, 2]
    cam, light = calib.scene_units(1)
    assert np.allclose(cam, np.array(CAMS[1]) / 5.0) and np.allclose(light, cam)
    assert capture_view(folder / "01.png")[1] == 1
    assert capture_view(folder / "07.png") is None  # not a listed view
    assert read_capture_calibration(tmp_path) is None  # no calibration: an ordinary folder
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "parameters.json").write_text('{"image_size": 3, "camera_pos": [[1, 2]]}')
    with pytest.raises(ImageError, match="parameters.json"):
        read_capture_calibration(tmp_path / "bad")


@pytest.mark.integration
def test_shared_bath_tile_capture(shared_data):
    folder = shared_data / "guo-svbrdf-diff-renderer" / "bath_tile"
    if not folder.is_dir():
        pytest.skip(f"third-party test data not found at {folder}")
    cases = load_cases(shared_data, 64, "guo-svbrdf-diff-renderer/bath_tile/0[07]")
    assert len(cases) == 2
    for c in cases:
        assert c.capture is not None and len(c.capture.others()) == 8
        flat = _flat_constant(Maps(diffuse=c.photo, specular=c.photo[..., :1], roughness=c.photo[..., :1],
                                   normal=np.dstack([np.zeros_like(c.photo[..., :2]), np.ones_like(c.photo[..., :1])])))
        out = bm.capture_errors(flat, c.capture)
        assert 0.05 < out["capture_rmse"] < 0.4 and out["capture_views"] == 8


def test_a_capture_with_missing_views_is_read_with_the_views_on_disk(tmp_path):
    # Published captures often ship a subset of the views their calibration lists (issue 52, item 5).
    from svbrdf.trainer.bench import datasets

    gt = _bumpy_maps(n=N)
    folder = _write_capture(tmp_path / "data" / "tile", gt)
    (folder / "00.png").unlink()
    (folder / "03.png").unlink()
    datasets._WARNED.clear()
    with pytest.warns(datasets.MissingViewsWarning, match=r"lists views 0, 3 but there is no photo of them "
                                                          r"\(00, 03\); the capture is read with the 3 views"):
        cases = load_cases(tmp_path / "data", N)
    assert [c.name for c in cases] == ["tile/01", "tile/02", "tile/04"]
    for c in cases:
        assert sorted(c.capture.photos) == [1, 2, 4] and c.capture.calibration.missing == (0, 3)
        assert c.capture.others() == [i for i in (1, 2, 4) if i != c.capture.index]
        true = bm.capture_errors(gt, c.capture)
        assert true["capture_views"] == 2 and true["capture_rmse"] < 0.01
    import warnings

    with warnings.catch_warnings():  # once per calibration file: reading it again says nothing
        warnings.simplefilter("error")
        assert read_capture_calibration(folder).missing == (0, 3)
    for p in folder.glob("*.png"):  # no view left: an error naming the file
        p.unlink()
    with pytest.raises(ImageError, match=r"parameters.json: the calibration lists views 0-4 but none of their"):
        read_capture_calibration(folder)


@pytest.mark.integration
def test_a_copy_of_the_shared_capture_without_some_views(shared_data, tmp_path):
    import shutil

    from svbrdf.trainer.bench import datasets

    src = shared_data / "guo-svbrdf-diff-renderer" / "bath_tile"
    if not src.is_dir():
        pytest.skip(f"third-party test data not found at {src}")
    folder = tmp_path / "bath_tile"  # a temporary copy, deleted with tmp_path
    shutil.copytree(src, folder, ignore=shutil.ignore_patterns("00.png", "05.png", "06.png"))
    datasets._WARNED.clear()
    with pytest.warns(datasets.MissingViewsWarning, match=r"lists views 0, 5, 6 but .*read with the 6 views on "
                                                          r"disk \(1-4, 7, 8\)"):
        cases = load_cases(tmp_path, 64, "*bath_tile/0[17]")
    assert [c.name for c in cases] == ["bath_tile/01", "bath_tile/07"]
    assert all(sorted(c.capture.photos) == [1, 2, 3, 4, 7, 8] and len(c.capture.others()) == 5 for c in cases)


def test_foreign_colour_is_reported_for_synthetic_cases_and_photos():
    """Every case gets the base colour's foreign colour (svbrdf.runtime.quality.colour_check): against the photo
    when there is one, else against the ground truth rendered under the input flash; the artist table reports it
    for synthetic cases and for photos."""
    from svbrdf.trainer.bench import report

    gt = _bumpy_maps(seed=3)
    own = bm.evaluate(gt, gt=gt)
    assert set(bm.COLOUR_METRICS) <= set(own) and own["foreign_colour"] < 5.0
    blotch = gt.diffuse.copy()
    blotch[:32, 16:48] = blotch[:32, 16:48].mean(-1, keepdims=True) * np.array([2.4, 0.3, 0.3], np.float32)
    off = bm.evaluate(gt._with({**dict(gt.items()), "diffuse": np.clip(blotch, 0, 1)}), gt=gt)
    assert off["foreign_colour"] > own["foreign_colour"] + 5 and off["foreign_colour_area"] > 0.1
    photo = np.clip(render(gt, None, ZHAO), 0, 1)
    seen = bm.evaluate(gt, photo=photo)
    assert seen["foreign_colour"] == pytest.approx(own["foreign_colour"], abs=1e-6)  # the same reference
    records = [{"case": "s", "kind": "synthetic", "method": "preview", "preset": None, "iterations": None, **own},
               {"case": "p", "kind": "photo", "method": "preview", "preset": None, "iterations": None, **off}]
    row = report.artist_table(records)[0]
    assert row["foreign_colour_synthetic"] == pytest.approx(own["foreign_colour"])
    assert row["foreign_colour_photos"] == pytest.approx(off["foreign_colour"])
    assert "foreign colour photos" in "\n".join(report._artist_markdown([row]))


def _domed_normals(n=N, tilt=0.006, seed=5):
    """A stationary texture's normals (RMS slope ~0.05, as the network's) with and without the faint radial tilt a
    flash leaves (a Gaussian dome 0.35 N wide, off-centre); and the dome's centre."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float64)
    tex = np.fft.irfft2(np.fft.rfft2(rng.normal(size=(n, n))) * np.exp(
        -2 * (np.pi * 1.5) ** 2 * (np.fft.fftfreq(n)[:, None] ** 2 + np.fft.rfftfreq(n)[None, :] ** 2)), s=(n, n))
    tex *= 0.05 / np.hypot(*np.gradient(tex)).mean()
    centre, s = (0.4 * n, 0.6 * n), 0.35 * n
    dome = tilt * s * np.sqrt(np.e) * np.exp(-((yy + 0.5 - centre[0]) ** 2 + (xx + 0.5 - centre[1]) ** 2) / (2 * s * s))

    def normals(h):
        gy, gx = np.gradient(h)
        v = np.stack([-gx, gy, np.ones_like(h)], -1)
        return (v / np.linalg.norm(v, axis=-1, keepdims=True)).astype(np.float32)

    return normals(tex + dome), normals(tex), centre


def test_height_lowband_error_compares_the_broad_shapes():
    rng = np.random.default_rng(6)
    yy, xx = np.mgrid[0:48, 0:64] / 64.0
    truth = np.sin(2 * np.pi * 1.5 * xx) * np.cos(2 * np.pi * yy) + 0.3 * rng.normal(size=(48, 64))
    assert bm.height_lowband_error(truth, truth) == pytest.approx(0.0, abs=1e-12)
    # offset, scale and tilt do not count
    assert bm.height_lowband_error(5 + 3 * truth + 2 * xx - yy, truth) == pytest.approx(0.0, abs=1e-12)
    dome = np.exp(-((xx - 0.5) ** 2 + (yy - 0.35) ** 2) / 0.1)
    assert bm.height_lowband_error(dome, truth) > 1.0  # all broad, none of it the truth's
    assert bm.height_lowband_error(-truth, truth) <= 4.0
    assert bm.height_lowband_error(np.zeros((48, 64)), np.zeros((48, 64))) == 0.0
    with pytest.raises(ValueError, match="size"):
        bm.height_lowband_error(truth, truth[:, :32])


def test_relief_metrics_see_the_flash_dome_in_the_height():
    """The written height of normals with the flash's faint tilt (svbrdf.runtime.core.relief) has no dome; the
    plainly integrated one, scored the same way, has; every case gets the radial scores, ground truth the broad
    error."""
    from svbrdf.runtime.core.relief import height_from_normals
    from svbrdf.runtime.quality import relief_radial

    domed, flat, centre = _domed_normals()
    pred = _bumpy_maps(seed=4)._with({**dict(_bumpy_maps(seed=4).items()), "normal": domed})
    gt = _bumpy_maps(seed=4)._with({**dict(_bumpy_maps(seed=4).items()), "normal": flat})
    got = bm.relief_metrics(pred, gt, centre)
    assert set(got) == set(bm.RELIEF_METRICS)
    assert abs(got["relief_radial_corr"]) < 0.15 and got["height_lowband_err"] < 0.1, got
    plain = height_from_normals(domed, zero="unit", low_cut=0)[0]
    truth = height_from_normals(flat, zero="unit", low_cut=0)[0]
    assert relief_radial(plain, centre)["relief_radial_corr"] < -0.5
    assert bm.height_lowband_error(plain, truth) > 3 * got["height_lowband_err"]
    assert set(bm.relief_metrics(pred, centre=centre)) == {"relief_radial_corr", "relief_radial_share"}
    assert bm.relief_metrics(Maps(roughness=pred.roughness)) == {}
    assert set(bm.RELIEF_METRICS) <= set(bm.evaluate(pred, gt=gt, centre=centre))
