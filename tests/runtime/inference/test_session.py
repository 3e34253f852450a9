"""Model lookup and verification (svbrdf.runtime.inference.manifest) and onnxruntime preview inference (svbrdf.runtime.inference.session)."""

import json
import shutil
import warnings

import numpy as np
import pytest

from svbrdf.runtime.errors import ImageError, ModelError, SvbrdfError
from svbrdf.runtime.io.images import write_image
from svbrdf.runtime.core.maps import MAP_NAMES, Maps
from svbrdf.runtime.inference.manifest import (
    MODEL_ENV, find_checkpoint, find_model, map_layout, network_input_record, recorded_even_lighting,
)
from svbrdf.runtime.inference.tiling import tile_boxes

from ..conftest import TINY_FOV

pytest.importorskip("onnxruntime")
from svbrdf.runtime.inference.session import FULL, PreviewSession, load_session
from svbrdf.runtime.inference.pipeline import estimate  # noqa: E402


def _texture(h, w, seed=0):
    """A stationary material-like photo: a few oriented sinusoids plus fine noise, linear, around 0.35."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    tex = np.zeros((h, w, 3), np.float32)
    for _ in range(6):
        fy, fx = rng.uniform(0.05, 0.4, 2)
        tex += np.sin(fy * yy + fx * xx + rng.uniform(0, 2 * np.pi))[..., None] * rng.uniform(0.02, 0.08, 3)
    return np.clip(0.35 + tex + 0.03 * rng.standard_normal((h, w, 3)), 0, 1).astype(np.float32)


def _check_maps(maps, shape):
    assert maps.shape == shape
    for name in ("diffuse", "specular", "roughness"):
        arr = getattr(maps, name)
        assert arr.dtype == np.float32 and arr.min() >= 0 and arr.max() <= 1, name
    norm = np.linalg.norm(maps.normal, axis=-1)
    np.testing.assert_allclose(norm, 1.0, atol=1e-5)
    assert maps.normal[..., 2].min() >= 0


# ------------------------------------------------------------------------------------------ model lookup
def test_explicit_model_is_verified_against_its_manifest(tiny_model):
    info = find_model(tiny_model)
    assert info.verified and info.source == "argument" and info.note == ""
    assert info.manifest_path == tiny_model.with_suffix(".json")
    assert info.sha256 == json.loads(info.manifest_path.read_text())["sha256"]
    assert find_checkpoint(info) == tiny_model.with_suffix(".pt")


def test_tampered_model_is_refused(tiny_model, tmp_path):
    model = tmp_path / "tiny.onnx"
    shutil.copy(tiny_model.with_suffix(".json"), tmp_path / "tiny.json")
    data = bytearray(tiny_model.read_bytes())
    data[len(data) // 2] ^= 0xFF
    model.write_bytes(bytes(data))
    with pytest.raises(ModelError, match="sha256"):
        find_model(model)
    with pytest.raises(ModelError, match="sha256"):
        load_session(model)


def test_shared_manifest_and_env_lookup(tiny_model, tmp_path, monkeypatch):
    model = tmp_path / "renamed.onnx"
    shutil.copy(tiny_model, model)
    manifest = json.loads(tiny_model.with_suffix(".json").read_text())
    (tmp_path / "manifest.json").write_text(json.dumps({**manifest, "file": "renamed.onnx"}))
    monkeypatch.setenv(MODEL_ENV, str(model))
    info = find_model()
    assert info.source == "env" and info.verified and info.manifest_path.name == "manifest.json"
    monkeypatch.setenv(MODEL_ENV, str(tmp_path / "missing.onnx"))
    with pytest.raises(ModelError, match=MODEL_ENV):
        find_model()


def test_model_with_a_foreign_layout_is_refused(tiny_model, tmp_path):
    shutil.copy(tiny_model, tmp_path / "m.onnx")
    manifest = json.loads(tiny_model.with_suffix(".json").read_text())
    manifest["maps"] = list(reversed(manifest["maps"]))
    (tmp_path / "m.json").write_text(json.dumps(manifest))
    with pytest.raises(ModelError, match="layout"):
        find_model(tmp_path / "m.onnx")


def test_model_without_manifest_loads_unverified_from_embedded_metadata(tiny_model, tmp_path):
    shutil.copy(tiny_model, tmp_path / "bare.onnx")
    sess = load_session(tmp_path / "bare.onnx", threads=1)
    assert not sess.info.verified and "not verified" in sess.info.note
    assert sess.metadata["maps"] == map_layout()
    assert sess.render_config.fov_deg == TINY_FOV
    with pytest.raises(ModelError, match="no training checkpoint"):
        find_checkpoint(sess.info)


def test_missing_and_corrupt_models(tmp_path, monkeypatch):
    with pytest.raises(ModelError, match="not found"):
        find_model(tmp_path / "nope.onnx")
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not a protobuf at all")
    with pytest.raises(ModelError, match="onnxruntime cannot load"):
        load_session(bad)
    monkeypatch.delenv(MODEL_ENV, raising=False)
    from importlib import resources

    if (resources.files("svbrdf.models") / "manifest.json").is_file():
        assert find_model().source == "packaged"
    else:
        with pytest.raises(ModelError, match="pass --model or set SVBRDF_MODEL"):
            find_model()


# ------------------------------------------------------------------------------------------ inference
def test_a_model_is_shown_the_input_it_was_trained_on(session, monkeypatch):
    config = session.metadata["training"]["train_config"]
    for stage, train_even, want in [("pretrain", 0.0, None), ("finetune", 0.25, 0.25), ("fit", 0.5, 0.5),
                                    ("finetune", None, None), ("prior", 0.0, 0.25), (None, 0.0, 0.25)]:
        config = {k: v for k, v in config.items() if k != "even_lighting"}
        if train_even is not None:
            config["even_lighting"] = train_even
        monkeypatch.setitem(session.metadata, "training", {"stage": stage, "train_config": config})
        assert session.even_lighting == session.input_lighting(0.25) == want, (stage, train_even)
    monkeypatch.setitem(session.metadata, "training", None)  # a bare module's export: as a stage one
    assert session.even_lighting == session.input_lighting(0.25) == 0.25
    assert session.input_lighting(None) is None and session.input_lighting(0.125) == 0.125


def test_a_stage_one_is_shown_what_its_network_input_record_says(session, monkeypatch):
    training = {**session.metadata["training"], "stage": "prior"}
    monkeypatch.setitem(session.metadata, "training", training)
    for record, want in [({"mode": "photo", "even_lighting": 0.0}, None), ({"mode": "even", "even_lighting": 0.125},
                                                                          0.125), (None, 0.25)]:
        if record is None:
            monkeypatch.delitem(session.metadata, "network_input", raising=False)
        else:
            monkeypatch.setitem(session.metadata, "network_input", record)
        assert session.input_lighting(0.25) == want, record  # 0.25: the runtime's default, v1's (no record)
    # a fine-tuned model is shown what it was trained on, whatever a record says
    monkeypatch.setitem(session.metadata, "training", {**training, "stage": "finetune",
                                                       "train_config": {"even_lighting": 0.5}})
    monkeypatch.setitem(session.metadata, "network_input", network_input_record("photo", 0.25))
    assert session.input_lighting(0.25) == 0.5


@pytest.mark.parametrize("record", [{"mode": "photo", "even_lighting": 0.25}, {"mode": "even", "even_lighting": 0},
                                    {"mode": "dim", "even_lighting": 0.1}, {"mode": "even"}, "photo"])
def test_an_invalid_network_input_record_is_refused_at_load(tiny_model, tmp_path, record):
    shutil.copy(tiny_model, tmp_path / "m.onnx")
    manifest = json.loads(tiny_model.with_suffix(".json").read_text())
    manifest["network_input"] = record
    (tmp_path / "m.json").write_text(json.dumps(manifest))
    with pytest.raises(ModelError, match=r"m\.onnx: invalid network_input"):
        load_session(tmp_path / "m.onnx", threads=1)


def test_network_input_records():
    assert network_input_record("photo", 0.25) == {"mode": "photo", "even_lighting": 0.0}
    assert network_input_record("even", 0.25) == {"mode": "even", "even_lighting": 0.25}
    assert recorded_even_lighting({}) is None
    assert recorded_even_lighting({"network_input": network_input_record("photo", 0.25)}) == 0.0
    with pytest.raises(ValueError, match="unknown network input 'raw'"):
        network_input_record("raw", 0.25)


def test_session_reads_the_manifest(session, tiny_model):
    assert isinstance(session, PreviewSession)
    assert session.path == tiny_model and session.providers[-1] == "CPUExecutionProvider"
    assert session.render_config.fov_deg == TINY_FOV  # from the training config, not the default 66
    assert session.metadata["training"]["step"] == 7


@pytest.mark.parametrize("stage, even", [("prior", 0.25), ("prior", None), ("finetune", 0.125), ("finetune", 0.0)])
def test_estimate_array_in_one_pass(session, stage, even, monkeypatch):
    from svbrdf.runtime.post import PostProcess
    from svbrdf.runtime.post.flash_trend import even_lighting

    # A stage one is shown the photo evenly lit at the runtime's width; a fine-tuned model at its own training's.
    post = PostProcess(even_lighting=even if stage == "prior" else 0.3)
    training = {**session.metadata["training"], "stage": stage,
                "train_config": {**session.metadata["training"]["train_config"], "even_lighting": even}}
    monkeypatch.setitem(session.metadata, "training", training)
    even = even or None
    assert session.input_lighting(post.even_lighting) == even
    photo = _texture(37, 58)
    maps = estimate(photo, session, post=post)
    _check_maps(maps, (37, 58))
    meta = maps.meta
    assert meta["tiles"] == 1 and not meta["resized"] and meta["size"] == [37, 58] and meta["even_lighting"] == even
    assert meta["model"]["sha256"] == session.info.sha256 and meta["model"]["verified"]
    assert set(meta["timings"]) == {"read", "resize", "infer", "post"}
    assert maps.render_config == session.render_config and maps.render_config.fov_deg == TINY_FOV
    assert "render_config" not in meta  # a typed field, not a dict in the metadata
    # The maps are the model's output on the photo evenly lit (or as it is), clipped/renormalised, the colour from
    # the photo, the flash trend removed; the post-processing reads the photo itself.
    raw = session.run(photo if even is None else even_lighting(photo, even))
    assert even is None or not np.allclose(raw, session.run(photo), atol=1e-3)  # the input did change
    from svbrdf.runtime.quality.burn_in import photo_burn_in
    from svbrdf.runtime.post.flash_trend import remove_flash_trend, uniform_specular
    from svbrdf.runtime.post.highlight_fill import fill_highlight
    from svbrdf.runtime.post.photo_colour import photo_colour

    model = Maps.unpack(raw).clipped()
    model = model._with({**dict(model.items()), "diffuse": photo_colour(model.diffuse, photo)})
    want = uniform_specular(remove_flash_trend(fill_highlight(model, photo), photo=photo))
    assert meta["highlight_fill"] == want.meta["highlight_fill"]
    for name in ("diffuse", "specular", "roughness", "normal"):
        np.testing.assert_allclose(getattr(maps, name), getattr(want, name), atol=1e-6)
    assert meta["flash_trend"] == want.meta["flash_trend"]
    assert meta["uniform_specular"] == want.meta["uniform_specular"] and np.ptp(maps.specular) == 0
    assert meta["burn_in"] == photo_burn_in(maps, photo)  # the label-free burn-in is returned with the maps
    assert meta["burn_in_model"] == photo_burn_in(model, photo)  # and that of the network's maps


def test_estimate_file_and_downsizing(session, tmp_path):
    path = tmp_path / "photo.png"
    write_image(path, _texture(100, 150), bits=16, srgb_encode=True)
    with pytest.warns(UserWarning, match=r"downsized from 150x100 to 64x43 pixels \(long side limit 64"):
        maps = estimate(path, session, max_size=64)
    _check_maps(maps, (43, 64))  # 100 x 150 scaled by 64 / 150, rounded
    assert maps.meta["resized"] and maps.meta["input_size"] == [100, 150] and maps.meta["source"] == str(path)


@pytest.mark.filterwarnings("ignore:.*greyscale photo")  # all-zero inputs are greyscale; not what is tested
def test_estimate_refuses_bad_images(session, tmp_path):
    with pytest.raises(ImageError, match="at least 8x8"):
        estimate(np.zeros((7, 100, 3), np.float32), session)
    with pytest.raises(ImageError, match="below 8 px"):
        estimate(np.zeros((10, 400, 3), np.float32), session, max_size=100)
    with pytest.raises(ImageError, match=r"\(H, W, 3\)"):
        estimate(np.zeros((10, 10), np.float32), session)
    nan = np.zeros((10, 10, 3), np.float32)
    nan[3, 3, 1] = np.nan
    with pytest.raises(ImageError, match="NaN"):
        estimate(nan, session)
    with pytest.raises(ImageError, match="no such file"):
        estimate(tmp_path / "missing.png", session)
    with pytest.raises(ValueError, match="overlap"):
        estimate(np.zeros((10, 10, 3), np.float32), session, tile=16, overlap=9)


def test_tiled_estimate_agrees_with_one_pass_away_from_seams(session):
    """Tolerance: on pixels covered by one tile only, mean |diff| <= 0.015, max <= 0.1 (diffuse, specular,
    roughness) and a mean normal angle <= 12 deg. The generator's instance norms see per-tile statistics, so
    the agreement is approximate everywhere (measured on this random tiny model: mean 0.005, max 0.044,
    5 deg); a 37 px misregistration gives mean 0.05, max 0.4, 57 deg and fails the same check."""
    h, w, tile, overlap = 96, 352, 128, 32
    photo = _texture(h, w, seed=3)
    whole = estimate(photo, session)
    tiled = estimate(photo, session, tile=tile, overlap=overlap)
    _check_maps(tiled, (h, w))
    assert tiled.meta["tiles"] == 4 and whole.meta["tiles"] == 1
    cover = np.zeros((h, w), int)
    for y0, x0, th, tw in tile_boxes(h, w, tile, overlap):
        cover[y0:y0 + th, x0:x0 + tw] += 1
    away = cover == 1
    assert away.mean() > 0.5

    def close(a, b):
        d = np.abs(a.pack() - b.pack())[away][:, :5]  # diffuse, specular, roughness
        angle = np.degrees(np.arccos(np.clip(np.sum(a.normal * b.normal, -1), -1, 1)))[away]
        return d.mean() <= 0.015 and d.max() <= 0.1 and angle.mean() <= 12.0

    assert close(tiled, whole)
    assert not close(estimate(np.roll(photo, 37, axis=1), session), whole)  # the check can fail



# ------------------------------------------------------------------------------------------ maps on demand
def _copy_model(tiny_model, folder, parts=True):
    """The tiny model's files in ``folder``; without ``parts`` its manifest is that of an older export."""
    for f in tiny_model.parent.glob("tiny*"):
        if parts or f.suffix != ".onnx" or f == tiny_model:
            shutil.copy(f, folder / f.name)
    if not parts:
        manifest = json.loads(tiny_model.with_suffix(".json").read_text())
        del manifest["parts"]
        (folder / "tiny.json").write_text(json.dumps(manifest))
    return folder / "tiny.onnx"


@pytest.mark.parametrize("maps,graph", [
    (("normal",), "normal_roughness"),
    (("roughness", "normal"), "normal_roughness"),
    (("diffuse",), "diffuse_specular"),
    (("specular", "diffuse"), "diffuse_specular"),
    (("diffuse", "normal"), FULL),  # both decoders: one encoder pass beats two parts
])
def test_a_subset_runs_only_the_graph_it_needs_and_equals_the_full_estimate(tiny_model, session, maps, graph):
    photo = _texture(40, 56, seed=1)
    full = estimate(photo, session)
    sess = load_session(tiny_model, threads=1, maps=maps)
    assert sess.loaded == (graph,) and sess.graph_for() == graph  # created at load, nothing else
    got = estimate(photo, sess)
    assert sess.loaded == (graph,)
    assert got.names == tuple(n for n in MAP_NAMES if n in maps)
    assert all(getattr(got, n) is None for n in MAP_NAMES if n not in maps)
    assert got.meta["maps"] == list(got.names) and got.meta["model"]["graph"] == graph
    for name, arr in got.items():
        np.testing.assert_allclose(arr, getattr(full, name), atol=1e-5, err_msg=name)


def test_other_graphs_are_created_on_first_use(tiny_model):
    sess = load_session(tiny_model, threads=1, maps=["normal"])
    photo = _texture(16, 24)
    assert estimate(photo, sess).names == ("normal",)  # the session's maps are the default
    assert estimate(photo, sess, maps="basecolor").names == ("diffuse",)  # alias of diffuse
    assert sess.loaded == ("normal_roughness", "diffuse_specular")
    assert estimate(photo, sess, maps=MAP_NAMES).complete
    assert sess.loaded == ("normal_roughness", "diffuse_specular", FULL)
    assert estimate(photo, sess, maps=["specular"]).names == ("specular",)  # cached: no new session
    assert len(sess.loaded) == 3


def test_tiled_subset_equals_the_tiled_full_estimate(tiny_model, session):
    photo = _texture(96, 160, seed=4)
    full = estimate(photo, session, tile=64, overlap=16)
    sess = load_session(tiny_model, threads=1, maps=["diffuse", "specular"])
    got = estimate(photo, sess, tile=64, overlap=16)
    assert got.meta["tiles"] == full.meta["tiles"] == 6 and sess.loaded == ("diffuse_specular",)
    assert got.names == ("diffuse", "specular")
    for name, arr in got.items():
        np.testing.assert_allclose(arr, getattr(full, name), atol=1e-5, err_msg=name)


def test_unknown_map_names_are_one_line_errors(tiny_model, session, tmp_path):
    with pytest.raises(SvbrdfError, match=r"unknown map name 'albedo'; valid names: diffuse, specular, roughness, "
                                          r"normal"):
        load_session(tmp_path / "missing.onnx", maps=["normal", "albedo"])  # checked before the model lookup
    with pytest.raises(SvbrdfError, match="unknown map name 'height'"):
        estimate(_texture(16, 16), session, maps=["height"])


def test_a_model_without_parts_falls_back_to_the_full_graph_with_one_note(tiny_model, session, tmp_path):
    model = _copy_model(tiny_model, tmp_path, parts=False)
    sess = load_session(model, threads=1, maps=["roughness"])
    assert sess.info.verified and sess.info.parts == {} and sess.loaded == (FULL,)
    photo = _texture(24, 32)
    with pytest.warns(UserWarning, match="exported without part graphs: computing all maps to return roughness"):
        got = estimate(photo, sess)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per session
        again = estimate(photo, sess, maps=["diffuse"])
    assert got.names == ("roughness",) and again.names == ("diffuse",) and got.meta["model"]["graph"] == FULL
    np.testing.assert_allclose(got.roughness, estimate(photo, session).roughness, atol=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # all four maps, or maps of both decoders, are no fallback
        load_session(model, threads=1).run(photo)
        estimate(photo, load_session(model, threads=1), maps=["diffuse", "normal"])


def test_a_missing_part_file_falls_back_and_a_corrupt_one_is_refused(tiny_model, tmp_path):
    model = _copy_model(tiny_model, tmp_path)
    (tmp_path / "tiny.diffuse_specular.onnx").unlink()
    sess = load_session(model, threads=1, maps=["diffuse"])
    assert sess.loaded == (FULL,)
    with pytest.warns(UserWarning, match="part graph file missing"):
        assert estimate(_texture(16, 16), sess).names == ("diffuse",)

    part = tmp_path / "tiny.normal_roughness.onnx"
    data = bytearray(part.read_bytes())
    data[len(data) // 2] ^= 0xFF
    part.write_bytes(bytes(data))
    assert load_session(model, threads=1).loaded == (FULL,)  # parts are verified when first used
    with pytest.raises(ModelError, match=r"tiny\.normal_roughness\.onnx: sha256 does not match"):
        load_session(model, threads=1, maps=["normal"])


def test_a_part_file_is_not_a_model_and_a_bad_parts_entry_is_refused(tiny_model, tmp_path):
    shutil.copy(tiny_model.with_name("tiny.normal_roughness.onnx"), tmp_path / "nr.onnx")
    with pytest.raises(ModelError, match="a part graph .*pass the full model file"):
        load_session(tmp_path / "nr.onnx")
    model = _copy_model(tiny_model, tmp_path)
    manifest = json.loads(model.with_suffix(".json").read_text())
    manifest["parts"]["normal_roughness"]["maps"] = ["normal"]
    model.with_suffix(".json").write_text(json.dumps(manifest))
    with pytest.raises(ModelError, match="invalid 'parts' entry"):
        find_model(model)


def test_photo_colour_gives_the_base_colour_the_photos_balance():
    from svbrdf.runtime.post.photo_colour import photo_colour

    rng = np.random.default_rng(3)
    grey = np.clip(0.3 + 0.1 * rng.standard_normal((64, 64, 1)), 0.05, 1).repeat(3, -1).astype(np.float32)
    tint = np.array([0.9, 0.4, 0.2], np.float32)
    photo = grey * tint
    photo[28:36, 28:36] = 1.0  # a clipped white highlight, left out
    out = photo_colour(grey, photo)
    mean = out.reshape(-1, 3).mean(0)
    np.testing.assert_allclose(mean / mean.mean(), tint / tint.mean(), rtol=0.02)  # the photo's balance
    assert abs(out.mean() - grey.mean()) < 0.02 * grey.mean()  # luminance kept (up to clipping)
    unclipped = out.max(-1) < 1.0
    np.testing.assert_allclose((out[..., 0] / out[..., 2])[unclipped], tint[0] / tint[2], rtol=1e-4)


def test_photo_colour_keeps_grey_grey_and_balanced_colours_unchanged():
    from svbrdf.runtime.post.photo_colour import photo_colour

    rng = np.random.default_rng(4)
    diffuse = rng.uniform(0.1, 0.6, (32, 32, 3)).astype(np.float32)
    grey_photo = np.repeat(rng.uniform(0.05, 0.5, (32, 32, 1)), 3, -1).astype(np.float32)
    grey_out = photo_colour(np.repeat(diffuse[..., :1], 3, -1), grey_photo)
    assert np.abs(grey_out - grey_out[..., :1]).max() < 1e-6
    balanced = photo_colour(diffuse, diffuse * 0.5)  # the photo already has the diffuse's balance
    np.testing.assert_allclose(balanced, diffuse, rtol=1e-5, atol=1e-6)
    assert photo_colour(diffuse, np.ones_like(diffuse)) is diffuse  # all clipped: nothing to learn from
