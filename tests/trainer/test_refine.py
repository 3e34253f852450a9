"""svbrdf.trainer.refine: the refine behind ``svbrdf-preview --refine``: one specular and one roughness level fitted
to the photo, and the cross-validated held-out test that keeps the preview unless the fit wins on every fold."""

import numpy as np
import pytest

from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, render
from svbrdf.trainer import refine as refine_module
from svbrdf.trainer.refine import FOLDS, MARGIN, holdout_folds, refine

S = 64
CONFIG = ZHAO.replace(fov_deg=50.0)


def _maps(specular: float, roughness: float, tint=(1.0, 1.0, 1.0), size: int = S) -> Maps:
    yy, xx = (np.mgrid[0:size, 0:size] + 0.5) / size
    grain = 0.5 + 0.15 * np.sin(23 * xx + 3 * np.sin(7 * yy))
    diffuse = np.stack([grain * 0.9, grain * 0.6, grain * 0.35], -1) * np.asarray(tint)
    normal = np.zeros((size, size, 3), np.float32)
    normal[..., 2] = 1.0
    return Maps(diffuse=diffuse.astype(np.float32), specular=np.full((size, size, 1), specular, np.float32),
                roughness=np.full((size, size, 1), roughness, np.float32), normal=normal)


def _photo(truth: Maps, exposure: float = 0.6) -> np.ndarray:
    """The truth's flash photo with the refine's physics: the camera above the centre, inverse-square fall-off."""
    return np.clip(render(truth, None, CONFIG.replace(falloff=True)) * exposure, 0, 1).astype(np.float32)


def test_the_refine_recovers_the_gloss_of_a_wrong_preview(monkeypatch):
    truth = _maps(0.3, 0.3)
    preview = _maps(0.05, 0.6)  # too dull, too rough
    monkeypatch.setattr(refine_module, "PRIOR_WEIGHT", 0.001)  # the photo's evidence alone: the truth comes back
    out = refine(_photo(truth), preview, CONFIG, threads=1)
    assert out.meta["refine"]["kept"] == "refined"
    assert abs(float(out.specular.mean()) - 0.3) < 0.03 and abs(float(out.roughness.mean()) - 0.3) < 0.03
    monkeypatch.undo()
    steps = []  # the default pull toward the preview: part of the way, in the truth's direction
    out = refine(_photo(truth), preview, CONFIG, threads=1, callback=lambda s, n, e: steps.append((s, n, e)))
    rec = out.meta["refine"]
    assert rec["kept"] == "refined" and rec["reason"] is None and out is not preview
    assert rec["heldout_rmse_refined"] < rec["heldout_rmse_preview"] * (1 - MARGIN)
    assert rec["shifts"]["specular_logit"] > 0 > rec["shifts"]["roughness_logit"]
    assert float(out.specular.mean()) > 0.05 and float(out.roughness.mean()) < 0.6
    # The base colour and the normals are the preview's: no highlight baked in, nothing flattened.
    np.testing.assert_array_equal(out.diffuse, preview.diffuse)
    np.testing.assert_array_equal(out.normal, preview.normal)
    # FOLDS held-out fits, then one on all pixels: the steps counted over all of them.
    total = (FOLDS + 1) * refine_module.ITERS
    assert [s[0] for s in steps] == list(range(1, total + 1)) and {s[1] for s in steps} == {total}
    assert set(rec) >= {"kept", "heldout_rmse_preview", "heldout_rmse_refined", "iterations", "seconds",
                        "burn_in_preview", "burn_in_refined", "shifts", "fold_ratios"}
    assert rec["folds_won"] == rec["folds"] == FOLDS and max(rec["fold_ratios"]) < 1 - MARGIN
    assert rec["iterations"] == total and not rec["stopped_early"] and rec["seconds"] > 0 and "burn_in" in out.meta


def test_a_photo_the_fit_cannot_explain_keeps_the_preview():
    rng = np.random.default_rng(1)
    photo = rng.uniform(0.05, 0.9, (S, S, 3)).astype(np.float32)  # grey noise: nothing a gloss level explains
    preview = _maps(0.04, 0.5, tint=(1 / 0.9, 1 / 0.6, 1 / 0.35))  # grey, as the noise is on average
    out = refine(photo, preview, CONFIG, iters=40, threads=1)
    rec = out.meta["refine"]
    assert out is preview and rec["kept"] == "preview" and rec["reason"] == "held-out error"
    assert rec["folds_won"] == rec["folds"] - 1 and rec["shifts"] is None and rec["iterations"] == rec["folds"] * 40
    assert "burn_in" in out.meta and rec["burn_in_preview"] == out.meta["burn_in"]["burn_in"]


def test_a_fit_that_loses_on_one_fold_keeps_the_preview_and_stops_there():
    """Cross-validation, not a pooled figure: the photo is the truth's except on one fold, where it is the preview's
    own render; the fit loses on that fold, so the preview is kept (without it every fold wins: the first test),
    and the folds after it are not fitted."""
    truth, preview = _maps(0.3, 0.3), _maps(0.05, 0.6)
    folds = holdout_folds(S, S)
    steps = []
    photo = np.where((folds == 2)[..., None], _photo(preview), _photo(truth))
    rec = refine(photo, preview, CONFIG, threads=1, callback=lambda s, n, e: steps.append(s)).meta["refine"]
    assert rec["kept"] == "preview" and rec["reason"] == "held-out error" and rec["shifts"] is None
    assert rec["folds"] == 3 and rec["folds_won"] == 2
    assert max(rec["fold_ratios"][:2]) < 1 - MARGIN < 1.03 < rec["fold_ratios"][2]
    assert rec["iterations"] == 3 * refine_module.ITERS == len(steps)


def test_a_refine_that_raises_the_burn_in_keeps_the_preview(monkeypatch):
    monkeypatch.setattr(refine_module, "BURN_GUARD", -10.0)  # any burn-in is too much
    preview = _maps(0.05, 0.6)
    out = refine(_photo(_maps(0.3, 0.3)), preview, CONFIG, iters=30, threads=1)
    assert out is preview and out.meta["refine"]["kept"] == "preview" and out.meta["refine"]["reason"] == "burn-in"


def test_a_photo_larger_than_the_fit_is_fitted_on_block_means_and_returned_whole(monkeypatch):
    monkeypatch.setattr(refine_module, "FIT_SIDE", 32)
    monkeypatch.setattr(refine_module, "PRIOR_WEIGHT", 0.001)
    preview = _maps(0.05, 0.6, size=80)
    out = refine(_photo(_maps(0.3, 0.3, size=80)), preview, CONFIG, iters=60, threads=1)
    assert out.shape == (80, 80) and out.meta["refine"]["fit_size"] == [27, 27]
    assert out.meta["refine"]["kept"] == "refined" and float(out.specular.mean()) > 0.1


def test_quality_auto_stops_when_the_fit_stops_improving():
    photo, preview = _photo(_maps(0.04, 0.5)), _maps(0.04, 0.5)  # the preview is the truth: nothing to fit
    out = refine(photo, preview, CONFIG, quality="auto", iters=500, threads=1)
    assert out.meta["refine"]["stopped_early"] and out.meta["refine"]["iterations"] < 500


def test_holdout_folds_deal_the_blocks_evenly_by_a_fixed_draw():
    f = holdout_folds(64, 40, block=16)  # 4 x 3 blocks, the last column 8 px wide
    assert f.shape == (64, 40) and sorted(np.unique(f)) == list(range(FOLDS))
    blocks = f[::16, ::16]
    assert sorted(np.bincount(blocks.ravel())) == [3, 3, 3, 3]
    assert (f == blocks.repeat(16, 0).repeat(16, 1)[:64, :40]).all()  # whole blocks
    np.testing.assert_array_equal(f, holdout_folds(64, 40, block=16))
    assert not (f == holdout_folds(64, 40, block=16, seed=1)).all()
    assert (holdout_folds(8, 8, block=16) == 0).all()  # one block: fold 0


def test_the_cli_help_states_the_refines_constants():
    from svbrdf.runtime.cli.preview import build_parser  # the runtime cannot import them: torch

    text = " ".join(build_parser().format_help().split()).replace("cross- validation", "cross-validation")
    assert f"at least {MARGIN:.0%} better in each of {FOLDS} cross-validation folds" in text
    assert f"each of its fits (at most {FOLDS} cross-validation folds, judged in turn until one is lost, and the " \
           f"final one; default {refine_module.ITERS})" in text and f"(at most {refine_module.ITERS} steps)" in text


def test_refine_argument_errors():
    photo, preview = _photo(_maps(0.3, 0.3)), _maps(0.05, 0.6)
    with pytest.raises(ValueError, match="unknown quality"):
        refine(photo, preview, CONFIG, quality="best")
    with pytest.raises(ValueError, match="iters"):
        refine(photo, preview, CONFIG, iters=0)
    with pytest.raises(ValueError, match="the preview is 64x64 px, the photo 32x32"):
        refine(photo[:32, :32], preview, CONFIG)
    with pytest.raises(ValueError):
        refine(photo, preview.subset("normal"), CONFIG)


def test_the_bench_method_runs_the_runtime_refine_with_the_cases_camera():
    from svbrdf.trainer.bench.cases import BenchCase, CaptureViews
    from svbrdf.trainer.bench.datasets import CaptureCalibration
    from svbrdf.trainer.bench.methods import METHODS, BenchOptions, case_render_config

    method = METHODS["refine"]
    opts = BenchOptions(threads=1, repeats=1)
    if method.unavailable(opts):
        pytest.skip(method.unavailable(opts))
    photo = _photo(_maps(0.3, 0.3))
    case = BenchCase("p", "p.png", "photo", "photo", photo, None, (32.0, 32.0))
    points = []
    run = method.run(case, opts, None, points.append)
    (point,) = points
    assert point.maps.shape == (S, S) and point.maps.meta["refine"] is run["refine"]
    # A real photo: the camera svbrdf-preview takes from its pixels (no EXIF here), not the bench's default.
    from svbrdf.runtime.workflow.camera import image_camera

    assert run["fov_deg"] == image_camera(photo)["fov_deg"] and point.train_seconds == run["refine"]["seconds"]
    # A view of a calibrated capture: the same (the calibration is the evaluation's, which svbrdf-preview lacks).
    calib = CaptureCalibration(path=None, width_cm=10.0, views={0: ((1.0, 0.0, 11.0), (1.0, 0.0, 11.0))})
    view = BenchCase("v", "v.png", "photo", "photo", photo, None, (32.0, 32.0), capture=CaptureViews(calib, 0, {}))
    assert case_render_config(view, opts.config).fov_deg == image_camera(photo)["fov_deg"]
    # A synthetic case: the camera it was rendered with.
    synthetic = BenchCase("s", "s.png", "synthetic", "des18", photo, _maps(0.3, 0.3), (32.0, 32.0))
    assert case_render_config(synthetic, opts.config) is opts.config
