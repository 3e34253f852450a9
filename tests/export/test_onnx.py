"""ONNX export of the generator (svbrdf.export.onnx) and the ``svbrdf-export`` CLI."""

import json
import warnings

import numpy as np
import pytest

torch = pytest.importorskip("torch")
onnx = pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")
pytest.importorskip("onnxscript")

from svbrdf.export import onnx as export_onnx  # noqa: E402
from svbrdf.export.cli import main  # noqa: E402
from svbrdf.export.onnx import OPSET, export_generator  # noqa: E402
from svbrdf.runtime.errors import ModelError, SvbrdfError  # noqa: E402
from svbrdf.runtime.core.maps import MAP_NAMES, SLICES  # noqa: E402
from svbrdf.runtime.inference.manifest import DECODERS, MANIFEST_SCHEMA, PARTS, map_layout, sha256_file  # noqa: E402
from svbrdf.trainer.checkpoint import build_checkpoint, save_checkpoint  # noqa: E402
from svbrdf.trainer.config import resolve  # noqa: E402
from svbrdf.trainer.models import DECODER_MAPS, MODEL_PRESETS, Generator  # noqa: E402

SIZES = ((32, 32), (33, 45), (40, 64))


def _generator():
    torch.manual_seed(1)
    return Generator(MODEL_PRESETS["tiny"]).eval()


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "tiny.onnx"
    generator = _generator()
    meta = {"train_config": resolve("tiny", fov_deg=45.0).to_dict(), "stage": "finetune", "step": 3,
            "photo": {"name": "p.png", "sha256": "f" * 64, "height": 40, "width": 50}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        report = export_generator(generator, out, sizes=SIZES, meta=meta)
    return out, generator, report


@pytest.mark.integration
def test_onnxruntime_matches_torch(exported):
    out, generator, report = exported
    assert [p["size"] for p in report["parity"]] == [list(s) for s in SIZES]
    assert report["max_abs_diff"] <= 1e-4
    # Checked here too, independently of the exporter's own report, with other inputs.
    sess = ort.InferenceSession(str(out), providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(5)
    for h, w in SIZES + ((8, 8), (9, 130)):
        x = rng.random((1, 3, h, w), dtype=np.float32)
        got = sess.run(["maps"], {"image": x})[0]
        with torch.inference_mode():
            ref = generator(torch.from_numpy(x)).numpy()
        assert got.shape == (1, 8, h, w)
        np.testing.assert_allclose(got, ref, atol=1e-4, rtol=0)


@pytest.mark.integration
def test_graph_contract(exported):
    out, _, report = exported
    model = onnx.load(str(out))
    onnx.checker.check_model(model, full_check=True)
    assert {o.domain: o.version for o in model.opset_import}[""] == OPSET == report["opset"]
    dims = lambda v: [d.dim_param or d.dim_value for d in v.type.tensor_type.shape.dim]  # noqa: E731
    assert [i.name for i in model.graph.input] == ["image"] and dims(model.graph.input[0]) == [1, 3, "H", "W"]
    assert [o.name for o in model.graph.output] == ["maps"] and dims(model.graph.output[0]) == [1, 8, "H", "W"]
    # one file per graph, no .data
    assert sorted(p.name for p in out.parent.iterdir()) == [
        "tiny.diffuse_specular.onnx", "tiny.json", "tiny.normal_roughness.onnx", "tiny.onnx"]


@pytest.mark.integration
def test_metadata_and_manifest(exported):
    out, _, report = exported
    manifest = json.loads(out.with_suffix(".json").read_text())
    assert manifest["schema"] == MANIFEST_SCHEMA and manifest["file"] == "tiny.onnx"
    assert manifest["sha256"] == sha256_file(out) == report["sha256"]
    assert manifest["maps"] == map_layout()
    assert manifest["input"]["min_size"] == 8 and manifest["input"]["layout"] == "NCHW"
    assert manifest["render_config"]["fov_deg"] == 45.0
    assert manifest["training"]["preset"] == "tiny" and manifest["training"]["step"] == 3
    assert manifest["training"]["generator_config"] == MODEL_PRESETS["tiny"].to_dict()
    assert manifest["photo"]["name"] == "p.png" and manifest["photo"]["sha256"] == "f" * 64
    assert manifest["opset"] == OPSET and manifest["exporter"]["torch"] == str(torch.__version__)
    assert manifest["parity"]["results"] == report["parity"]
    assert manifest["checkpoint"] is None  # exported from a module, not a file
    props = {p.key: json.loads(p.value) for p in onnx.load(str(out)).metadata_props}
    assert "sha256" not in props and "file" not in props
    assert props == {k: v for k, v in manifest.items() if k not in ("sha256", "file", "parity", "parts")}


def _channels(maps):
    own = np.zeros(8, bool)
    for n in maps:
        own[SLICES[n]] = True
    return own


@pytest.mark.integration
def test_parts_are_one_decoder_each_and_match_the_full_graph(exported):
    out, generator, report = exported
    manifest = json.loads(out.with_suffix(".json").read_text())
    assert set(manifest["parts"]) == set(PARTS) == set(report["parts"])
    full = ort.InferenceSession(str(out), providers=["CPUExecutionProvider"])
    full_weights = sum(t.ByteSize() for t in onnx.load(str(out)).graph.initializer)
    rng = np.random.default_rng(11)
    photos = [rng.random((1, 3, h, w), dtype=np.float32) for h, w in ((32, 32), (9, 130), (45, 33))]
    for part, maps in PARTS.items():
        entry = manifest["parts"][part]
        path = out.with_name(entry["file"])
        assert entry["file"] == f"tiny.{part}.onnx" and entry["maps"] == list(maps)
        assert entry["sha256"] == sha256_file(path) == report["parts"][part]["sha256"]
        assert [p["size"] for p in entry["parity"]["results"]] == [list(s) for s in SIZES]
        model = onnx.load(str(path))
        onnx.checker.check_model(model, full_check=True)
        props = {p.key: json.loads(p.value) for p in model.metadata_props}
        assert props["part"] == {"name": part, "maps": list(maps)} and props["maps"] == map_layout()
        # The other decoder is not in the file: about half the full graph's weights.
        assert sum(t.ByteSize() for t in model.graph.initializer) < 0.7 * full_weights
        sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        own = _channels(maps)
        for x in photos:
            got = sess.run(["maps"], {"image": x})[0]
            ref = full.run(["maps"], {"image": x})[0]
            assert got.shape == ref.shape == (1, 8) + x.shape[2:]
            np.testing.assert_allclose(got[:, own], ref[:, own], atol=1e-5, rtol=0)
            assert np.isnan(got[:, ~own]).all()


def test_parts_follow_the_generator_decoders():
    g = Generator(MODEL_PRESETS["tiny"])
    assert sorted(map(sorted, PARTS.values())) == sorted(map(sorted, DECODER_MAPS.values()))
    assert sorted(m for d in DECODERS for m in d.maps) == sorted(MAP_NAMES)  # each map from one decoder
    for d in DECODERS:
        assert isinstance(getattr(g, d.module), torch.nn.Module) and PARTS[d.part] == DECODER_MAPS[d.module]
        assert set(g.decode(g.forward_features(torch.zeros(1, 3, 16, 16)), maps=d.maps)) == set(d.maps)
    assert all(tuple(n for n in MAP_NAMES if n in maps) == maps for maps in PARTS.values())  # packing order


@pytest.mark.integration
def test_refuses_to_overwrite(exported):
    out, generator, _ = exported
    before = out.read_bytes()
    with pytest.raises(SvbrdfError, match="exists"):
        export_generator(generator, out)
    with pytest.raises(SvbrdfError, match=r"\.onnx"):
        export_generator(generator, out.with_suffix(".bin"))
    assert out.read_bytes() == before


def test_an_existing_part_file_blocks_the_whole_export(tmp_path):
    mine = tmp_path / "m.diffuse_specular.onnx"
    mine.write_bytes(b"my own file")
    with pytest.raises(SvbrdfError, match=r"m\.diffuse_specular\.onnx: exists"):
        export_generator(_generator(), tmp_path / "m.onnx")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.diffuse_specular.onnx"]
    assert mine.read_bytes() == b"my own file"


@pytest.mark.integration
def test_part_parity_failure_writes_nothing(tmp_path, monkeypatch):
    real = export_onnx._parity

    def broken_parts(path, generator, sizes, maps=MAP_NAMES):  # the full graph passes, a part does not
        results = real(path, generator, sizes, maps)
        return [{**r, "max_abs_diff": 1.0} for r in results] if maps != MAP_NAMES else results

    monkeypatch.setattr(export_onnx, "_parity", broken_parts)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        with pytest.raises(ModelError, match=r"m\.\w+\.onnx: onnxruntime and torch differ"):
            export_generator(_generator(), tmp_path / "m.onnx", sizes=((16, 16),))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.integration
def test_parity_failure_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.setattr(export_onnx, "PARITY_ATOL", 0.0)  # any float difference now fails
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        with pytest.raises(ModelError, match="differ"):
            export_generator(_generator(), tmp_path / "m.onnx", sizes=((16, 16),))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.integration
def test_cli(tmp_path, capsys):
    ckpt_path = tmp_path / "run" / "ck.pt"
    config = resolve("tiny")
    save_checkpoint(ckpt_path, build_checkpoint(generator=_generator(), discriminator=None,
                                                train_config=config.to_dict(), stage="pretrain", step=5, iters=5,
                                                photo={"name": "a.png", "sha256": "a" * 64}))
    out = tmp_path / "models" / "v1.onnx"
    assert main([str(ckpt_path), "-o", str(out)]) == 0
    stdout = capsys.readouterr().out
    assert str(out) in stdout and "max |diff|" in stdout and "normal_roughness" in stdout
    assert all(out.with_name(f"v1.{p}.onnx").is_file() for p in PARTS)
    manifest = json.loads(out.with_suffix(".json").read_text())
    assert manifest["checkpoint"] == {"file": "ck.pt", "path": str(ckpt_path.resolve()),
                                      "sha256": sha256_file(ckpt_path)}
    assert manifest["training"]["stage"] == "pretrain" and manifest["training"]["step"] == 5

    assert main([str(ckpt_path), "-o", str(out)]) == 1  # exists, no --force
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [f"svbrdf-export: error: {out}: exists (use --force to overwrite)"]
    out.unlink()
    out.with_suffix(".json").unlink()  # only the parts are left: still refused
    assert main([str(ckpt_path), "-o", str(out)]) == 1
    assert "v1.normal_roughness.onnx: exists" in capsys.readouterr().err and not out.exists()
    assert main([str(tmp_path / "missing.pt")]) == 1
    assert "no such checkpoint" in capsys.readouterr().err
    assert main([str(ckpt_path), "-o", str(tmp_path / "x.bin")]) == 2
    assert main(["--opset"]) == 2


@pytest.mark.integration
def test_a_stage_ones_network_input_travels_to_the_manifest_the_preview_and_the_fine_tune(tmp_path):
    from svbrdf.runtime.inference import session as session_module
    from svbrdf.runtime.inference.pipeline import estimate
    from svbrdf.runtime.post import PostProcess
    from svbrdf.trainer.checkpoint import clean_checkpoint, load_checkpoint
    from svbrdf.trainer.stage import finetune_config

    raw = tmp_path / "run.pt"
    save_checkpoint(raw, build_checkpoint(generator=_generator(), discriminator=None,
                                          train_config=resolve("fast").to_dict(), stage="prior", step=5, iters=5))
    clean_checkpoint(raw, tmp_path / "v2.pt", network_input="photo")
    out = tmp_path / "v2.onnx"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        export_generator(tmp_path / "v2.pt", out, check=False)
    record = {"mode": "photo", "even_lighting": 0.0}
    assert json.loads(out.with_suffix(".json").read_text())["network_input"] == record
    props = {p.key: json.loads(p.value) for p in onnx.load(str(out)).metadata_props}
    assert props["network_input"] == record
    session = session_module.load_session(out, threads=1)
    assert session.even_lighting is None and session.input_lighting(0.25) is None  # the record overrides a default
    photo = np.random.default_rng(0).uniform(0.1, 0.6, (32, 40, 3)).astype(np.float32)
    assert estimate(photo, session, post=PostProcess(even_lighting=0.25)).meta["even_lighting"] is None
    assert finetune_config(resolve("fast"), load_checkpoint(tmp_path / "v2.pt"))[0].even_lighting == 0.0
    # without a record (v1): the runtime's default and the preset's
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        export_generator(raw, tmp_path / "v1.onnx", check=False)
    assert "network_input" not in json.loads((tmp_path / "v1.json").read_text())
    assert session_module.load_session(tmp_path / "v1.onnx", threads=1).even_lighting == 0.25
    assert finetune_config(resolve("fast"), load_checkpoint(raw))[0].even_lighting == resolve("fast").even_lighting


@pytest.mark.integration
@pytest.mark.parametrize("width", [0.0, 0.25])
def test_a_fine_tuned_models_network_input_reaches_the_runtime(tmp_path, width):
    """A fine-tune records its input in ``train_config.post.even_lighting`` (TrainConfig.post); the runtime reads a
    fine-tuned model's at ``train_config.even_lighting``, which the export writes from it."""
    from svbrdf.runtime.inference import session as session_module

    cfg = resolve("fast", **{"post.even_lighting": width})
    raw = tmp_path / "ft.pt"
    save_checkpoint(raw, build_checkpoint(generator=_generator(), discriminator=None, train_config=cfg.to_dict(),
                                          stage="finetune", step=5, iters=5))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        export_generator(raw, tmp_path / "ft.onnx", check=False)
    recorded = json.loads((tmp_path / "ft.json").read_text())["training"]["train_config"]
    assert recorded["post"]["even_lighting"] == recorded["even_lighting"] == width
    assert session_module.load_session(tmp_path / "ft.onnx", threads=1).input_lighting(0.5) == (width or None)


@pytest.mark.integration
@pytest.mark.parametrize("height", ["tanh", "linear"])
def test_the_unet_candidate_exports_with_its_parts_and_matches_torch(tmp_path, height):
    from svbrdf.trainer.models import GeneratorConfig

    with torch.random.fork_rng():
        torch.manual_seed(2)
        generator = Generator(GeneratorConfig(width=0.125, decoder_blocks=3, arch="unet",
                                              height_activation=height)).eval()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        report = export_generator(generator, tmp_path / "unet.onnx", sizes=SIZES)
    assert report["max_abs_diff"] <= export_onnx.PARITY_ATOL
    assert all(p["max_abs_diff"] <= export_onnx.PARITY_ATOL for p in report["parts"].values())
    manifest = json.loads((tmp_path / "unet.json").read_text())
    assert manifest["training"]["generator_config"]["arch"] == "unet"
    assert manifest["training"]["generator_config"]["height_activation"] == height
    sess = ort.InferenceSession(str(tmp_path / "unet.onnx"), providers=["CPUExecutionProvider"])
    x = np.random.default_rng(3).random((1, 3, 37, 53), dtype=np.float32)  # not a multiple of 8: padded inside
    with torch.inference_mode():
        want = generator(torch.from_numpy(x)).numpy()
    np.testing.assert_allclose(sess.run(None, {"image": x})[0], want, atol=export_onnx.PARITY_ATOL)


@pytest.mark.integration
def test_the_shipped_checkpoint_builds_its_class_and_exports_the_shipped_graph(tmp_path):
    # Golden check of the generator classes: the packaged checkpoint, rebuilt by the factory and exported again, gives
    # what the packaged ONNX graph (exported from it before the classes were split) gives, and so does torch.
    from pathlib import Path

    from svbrdf.trainer.checkpoint import load_generator
    from svbrdf.trainer.models import UNetGenerator

    models = Path(__file__).resolve().parents[2] / "models"
    generator, meta = load_generator(models / "svbrdf_prior_v2.pt")
    assert type(generator) is UNetGenerator and meta["generator_config"]["arch"] == "unet"
    with warnings.catch_warnings():  # the full graph only, as export_generator traces it (its parts cost 2x more)
        warnings.simplefilter("ignore", FutureWarning)
        export_onnx._export(export_onnx._Graph(generator).eval(), tmp_path / "again.onnx", OPSET, "shipped")
    x = np.random.default_rng(7).random((1, 3, 45, 70), dtype=np.float32)  # not a multiple of 16: padded inside
    with torch.inference_mode():
        want = generator(torch.from_numpy(x)).numpy()
    for graph in (models / "svbrdf_prior_v2.onnx", tmp_path / "again.onnx"):
        sess = ort.InferenceSession(str(graph), providers=["CPUExecutionProvider"])
        np.testing.assert_allclose(sess.run(None, {"image": x})[0], want, atol=export_onnx.PARITY_ATOL, rtol=0)
    shipped = ort.InferenceSession(str(models / "svbrdf_prior_v2.onnx"), providers=["CPUExecutionProvider"])
    again = ort.InferenceSession(str(tmp_path / "again.onnx"), providers=["CPUExecutionProvider"])
    np.testing.assert_allclose(again.run(None, {"image": x})[0], shipped.run(None, {"image": x})[0],
                               atol=1e-5, rtol=0)
