"""``svbrdf-preview`` through ``main(argv)``: outputs, batch failures, overwrite rules, exit codes, light imports."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from svbrdf.runtime.cli.preview import build_parser, main
from svbrdf.runtime.cli.options import min_tile
from svbrdf.runtime.install import install_command
from svbrdf.runtime.io.images import read_image, write_image

pytest.importorskip("onnxruntime")

ERR = "svbrdf-preview: error: "
SET_FILES = ("_basecolor.png", "_normal.png", "_roughness.png", "_specular.png", "_relit.png", ".json")


@pytest.fixture
def photo(tmp_path):
    rng = np.random.default_rng(0)
    path = tmp_path / "wood.png"
    write_image(path, rng.uniform(0.1, 0.6, (48, 64, 3)).astype(np.float32), bits=8, srgb_encode=True)
    return path


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _subprocess(code):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def test_one_photo_writes_a_texture_set(photo, tiny_model, capsys):
    code, out, err = _run(capsys, photo, "--model", tiny_model, "--threads", "1")
    assert code == 0, err
    folder = photo.parent / "wood_svbrdf"  # default: beside the photo
    for suffix in SET_FILES:
        assert (folder / f"wood{suffix}").is_file(), suffix
    assert out.count("\n") == 1 and str(folder) in out and "48" in out
    assert read_image(folder / "wood_basecolor.png").shape == (48, 64, 3)
    assert read_image(folder / "wood_relit.png").shape == (48, 3 * 64, 3)
    sidecar = json.loads((folder / "wood.json").read_text())
    assert sidecar["meta"]["model"]["verified"] and sidecar["meta"]["source"] == str(photo)
    # no EXIF, no reliable fall-off: a phone's main camera across a 4:3 photo (not the model's training camera, 50)
    assert sidecar["camera"]["fov_source"] == "default"
    assert sidecar["brdf"]["render_config"]["fov_deg"] == sidecar["camera"]["fov_deg"] == pytest.approx(67.3, abs=0.01)


def test_a_clipped_highlight_is_filled_and_said(tiny_model, tmp_path, capsys):
    photo = tmp_path / "tile.png"
    rng = np.random.default_rng(2)
    img = rng.uniform(0.1, 0.6, (96, 128, 3)).astype(np.float32)
    img[40:50, 55:65] = 1.0  # a clipped flash highlight
    write_image(photo, img, bits=8, srgb_encode=True)
    code, out, err = _run(capsys, photo, "--model", tiny_model, "--threads", "1", "-o", tmp_path / "o")
    assert code == 0, err
    assert "before highlight fill and flash-trend removal" in out
    fill = json.loads((tmp_path / "o" / "tile.json").read_text())["meta"]["highlight_fill"]
    assert fill["filled"] and fill["pixels"] > 100 and fill["patches"] >= 1


def test_options_reach_the_texture_set(tiny_model, tmp_path, capsys):
    photo = tmp_path / "wood.png"
    rng = np.random.default_rng(1)
    write_image(photo, rng.uniform(0.1, 0.6, (300, 400, 3)).astype(np.float32), bits=8, srgb_encode=True)
    out_dir = tmp_path / "out"
    code, out, _ = _run(capsys, photo, "--model", tiny_model, "-o", out_dir, "--normal", "dx", "--format", "exr",
                        "--fov", "40", "--quiet", "--tile", "256")
    assert code == 0 and out == ""
    sidecar = json.loads((out_dir / "wood.json").read_text())
    assert sidecar["normal_convention"]["name"] == "dx"
    assert sidecar["brdf"]["render_config"]["fov_deg"] == 40.0
    assert sidecar["meta"]["tiles"] == 4  # 300 x 400 in 256 px tiles, overlap 64: 2 rows x 2 columns
    assert (out_dir / "wood_normal.exr").is_file() and not (out_dir / "wood_normal.png").exists()


def test_tile_below_the_minimum_is_refused_with_the_minimum(capsys):
    assert min_tile() == 256  # 4 x tiling.DEFAULT_OVERLAP
    code, out, err = _run(capsys, "p.png", "--tile", "255")
    assert code == 2 and out == ""
    assert f"{ERR}--tile must be >= 256 " in err and "got 255" in err
    assert build_parser().parse_args(["p.png", "--tile", "256"]).tile == 256


def test_greyscale_photo_warns_once(tiny_model, tmp_path, capsys):
    grey = tmp_path / "grey.png"
    rng = np.random.default_rng(2)
    write_image(grey, rng.uniform(0.1, 0.6, (48, 64, 1)).astype(np.float32), bits=8, srgb_encode=True)
    code, _, err = _run(capsys, grey, "--model", tiny_model, "-o", tmp_path / "g")
    assert code == 0, err
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert warnings == [f"svbrdf-preview: warning: {grey}: greyscale photo (no colour); the model invents the "
                        "colour of the diffuse and specular maps"]
    code, _, err = _run(capsys, grey, "--model", tiny_model, "-o", tmp_path / "q", "--quiet")
    assert code == 0 and err == ""


def test_colour_photo_does_not_warn(photo, tiny_model, tmp_path, capsys):
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "c")
    assert code == 0 and "warning" not in err


def test_batch_progress_lines_off_a_terminal_and_nothing_when_quiet(photo, tiny_model, tmp_path, capsys):
    second = tmp_path / "stone.png"
    write_image(second, read_image(photo), bits=8, srgb_encode=True)
    code, out, err = _run(capsys, photo, second, "--model", tiny_model, "-o", tmp_path / "b")
    assert code == 0, err
    assert len(out.splitlines()) == 2  # the two report lines on stdout
    lines = err.strip().splitlines()  # stderr is captured, not a terminal: plain lines, no carriage returns
    assert [line.split(" [")[0] for line in lines] == ["svbrdf-preview: 1/2", "svbrdf-preview: 2/2"]
    assert "\r" not in err and ("photo/s" in lines[-1] or "s/photo" in lines[-1])
    code, out, err = _run(capsys, photo, second, "--model", tiny_model, "-o", tmp_path / "b", "--force", "-q")
    assert code == 0 and out == "" and err == ""


def test_real_photo(shared_data, tiny_model, tmp_path, capsys):
    photos = sorted((shared_data / "deschaintre18-real").glob("*.png"))
    if not photos:
        pytest.skip("no deschaintre18-real photos in the shared data")
    code, _, err = _run(capsys, photos[0], "--model", tiny_model, "-o", tmp_path, "--max-size", "64")
    assert code == 0, err
    sidecar = json.loads((tmp_path / f"{photos[0].stem}.json").read_text())
    assert sidecar["meta"]["resized"] and max(sidecar["size"].values()) == 64


def test_batch_with_a_bad_file(photo, tiny_model, tmp_path, capsys):
    bad = tmp_path / "broken.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n not really")
    out_dir = tmp_path / "out"
    code, out, err = _run(capsys, bad, photo, "--model", tiny_model, "-o", out_dir)
    assert code == 1
    lines = [line for line in err.strip().splitlines() if not line.startswith("svbrdf-preview: 1/2 [")
             and not line.startswith("svbrdf-preview: 2/2 [")]  # the batch's progress lines
    assert len(lines) == 1 and lines[0].startswith(ERR) and "broken.png" in lines[0]
    assert "failed 1]" in err.strip().splitlines()[-1]
    assert (out_dir / "wood.json").is_file() and not (out_dir / "broken.json").exists()
    assert "wood" in out and "broken" not in out
    code, _, err = _run(capsys, bad, "--model", tiny_model, "-o", out_dir, "--verbose")
    assert code == 1 and "Traceback" in err


def test_a_photo_too_small_for_tileable_is_one_line_and_writes_nothing(tiny_model, tmp_path, capsys):
    small = tmp_path / "chip.png"
    rng = np.random.default_rng(3)
    write_image(small, rng.uniform(0.1, 0.6, (12, 20, 3)).astype(np.float32), bits=8, srgb_encode=True)
    out_dir = tmp_path / "out"
    code, out, err = _run(capsys, small, "--model", tiny_model, "-o", out_dir, "--tileable", "--view")
    assert code == 1 and out == ""
    assert err.strip().splitlines() == [f"{ERR}{small}: --tileable: maps of 20x12 px are too small to make tileable "
                                        "(at least 16 px a side)"]
    assert not out_dir.exists()  # no half-written set, no page
    # The same photo is fine without --tileable (the model itself takes it).
    code, _, err = _run(capsys, small, "--model", tiny_model, "-o", out_dir, "-q")
    assert code == 0, err


def test_same_output_name_twice_in_a_batch(photo, tiny_model, tmp_path, capsys):
    other = tmp_path / "b" / "wood.png"
    other.parent.mkdir()
    other.write_bytes(photo.read_bytes())
    code, _, err = _run(capsys, photo, other, "--model", tiny_model, "-o", tmp_path / "out")
    assert code == 1 and "same output name" in err


def test_force_semantics(photo, tiny_model, tmp_path, capsys):
    out_dir = tmp_path / "out"
    assert _run(capsys, photo, "--model", tiny_model, "-o", out_dir)[0] == 0
    files = [out_dir / f"wood{s}" for s in SET_FILES]
    for f in files:
        os.utime(f, ns=(10**18, 10**18))
    before = {f: f.read_bytes() for f in files}
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", out_dir)
    assert code == 1 and "exists" in err and "--force" in err
    assert all(f.read_bytes() == before[f] and f.stat().st_mtime_ns == 10**18 for f in files)
    assert _run(capsys, photo, "--model", tiny_model, "-o", out_dir, "--force")[0] == 0
    assert all(f.stat().st_mtime_ns != 10**18 for f in files)


def test_an_existing_user_file_is_left_untouched(photo, tiny_model, tmp_path, capsys):
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    mine = out_dir / "wood_basecolor.png"
    mine.write_bytes(b"my own file")
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", out_dir)
    assert code == 1 and "wood_basecolor.png" in err
    assert "(use --force to overwrite)" in err and "force=True" not in err  # the API's wording, translated
    assert mine.read_bytes() == b"my own file"
    assert sorted(p.name for p in out_dir.iterdir()) == ["wood_basecolor.png"]  # nothing else written


@pytest.mark.parametrize("argv", [
    [],
    ["p.png", "--tile", "0"],
    ["p.png", "--tile", "8"],
    ["p.png", "--iters", "5"],
    ["p.png", "--normal", "yz"],
    ["p.png", "--fov", "500"],
    ["p.png", "--refine", "--iters", "3", "--quality", "auto"],
    ["p.png", "--network-size", "4"],
    ["p.png", "--network-size", "0"],
    ["p.png", "--network-size", "half"],
])
def test_usage_errors_exit_2(argv, capsys):
    code, out, err = _run(capsys, *argv)
    assert code == 2 and out == ""
    assert "usage: svbrdf-preview" in err and ERR in err and "Traceback" not in err


def test_missing_model_is_one_line(photo, tmp_path, capsys):
    code, _, err = _run(capsys, photo, "--model", tmp_path / "none.onnx")
    assert code == 1 and err.strip().splitlines() == [f"{ERR}{tmp_path / 'none.onnx'}: model file not found"]


def test_help_and_version(capsys):
    code, out, _ = _run(capsys, "--help")
    assert code == 0 and "examples:" in out and "--refine" in out
    code, out, _ = _run(capsys, "--version")
    assert code == 0 and out.startswith("svbrdf-preview ")


def test_version_imports_nothing_heavy():
    res = _subprocess(
        "import sys; from svbrdf.runtime.cli.preview import main; code = main(['--version']); "
        "heavy = [m for m in ('onnxruntime', 'OpenImageIO', 'torch') if m in sys.modules]; "
        "assert code == 0 and not heavy, (code, heavy)"
    )
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("svbrdf-preview ")


def test_session_and_cli_do_not_import_torch():
    res = _subprocess(
        "import svbrdf.runtime.inference.session, svbrdf.runtime.cli.preview, svbrdf.runtime.inference.manifest, svbrdf.runtime.inference.tiling, sys; "
        "assert 'torch' not in sys.modules, 'torch was imported'"
    )
    assert res.returncode == 0, res.stderr


def test_refine_without_torch(photo, tiny_model):
    res = _subprocess(
        "import sys; sys.modules['torch'] = sys.modules['kornia'] = None; from svbrdf.runtime.cli.preview import main; "
        f"sys.exit(main([{str(photo)!r}, '--model', {str(tiny_model)!r}, '--refine']))"
    )
    assert res.returncode == 2
    hint = f'--refine needs torch (the "train" extra), not installed here: {install_command()}'
    assert res.stderr.strip().splitlines() == [ERR + hint]
    assert not (photo.parent / "wood_svbrdf").exists()


def test_refine_with_torch(photo, tiny_model, tmp_path, capsys):
    pytest.importorskip("torch")
    code, out, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "out", "--refine", "--iters", "1",
                          "--threads", "1")
    assert code == 0, err
    meta = json.loads((tmp_path / "out" / "wood.json").read_text())["meta"]
    rec = meta["refine"]
    from svbrdf.trainer.refine import FOLDS  # --iters 1: one step a fit

    # one step a fit: each fold judged (until one the fit does not win), then the final fit if every fold won
    assert rec["kept"] in ("refined", "preview") and rec["iterations"] == rec["folds"] + (rec["shifts"] is not None)
    assert rec["folds"] == FOLDS or rec["shifts"] is None
    assert {"heldout_rmse_preview", "heldout_rmse_refined", "seconds"} <= set(rec)
    # The terminal line says which maps were kept and both held-out figures.
    figures = f"{rec['heldout_rmse_refined']:.3f} vs the preview's {rec['heldout_rmse_preview']:.3f}"
    assert ((f"refined ({FOLDS + 1} it): held-out error " if rec["kept"] == "refined" else
             "refine kept the preview: held-out error ") + figures) in out
    # stderr is not a terminal here: one plain progress line with the step, ETA and the fit's error
    lines = err.strip().splitlines()
    assert any(line.startswith(f"refine wood.png: 1/{FOLDS + 1} [") and "rmse " in line for line in lines)
    assert "\r" not in err
    code, out, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "out", "--refine", "--iters", "1",
                          "--threads", "1", "--quiet", "--force")
    assert code == 0 and out == "" and err == ""


def test_normal_accepts_the_api_names_and_the_short_alias():
    parser = build_parser()
    assert parser.parse_args(["a.png"]).normal == "opengl"
    assert parser.parse_args(["a.png", "--normal", "gl"]).normal == "opengl"
    assert parser.parse_args(["a.png", "--normal", "opengl"]).normal == "opengl"
    assert parser.parse_args(["a.png", "--normal", "dx"]).normal == "dx"
    with pytest.raises(SystemExit):
        parser.parse_args(["a.png", "--normal", "directx"])


def test_target_gltf_writes_a_material(photo, tiny_model, tmp_path, capsys):
    out_dir = tmp_path / "gl"
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", out_dir, "--target", "gltf")
    assert code == 0, err
    assert list(out_dir.glob("*.gltf")), sorted(p.name for p in out_dir.iterdir())
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "x", "--target", "usd", "--normal", "dx")
    assert code == 1 and "apply to --target generic only" in err


def test_target_ambientcg_writes_the_library_set_with_height_and_ao(photo, tiny_model, tmp_path, capsys):
    out_dir = tmp_path / "acg"
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", out_dir, "--target", "ambientcg", "-q")
    assert code == 0, err
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(
        f"wood{s}" for s in ("_Color.png", "_NormalGL.png", "_NormalDX.png", "_Roughness.png", "_Specular.png",
                             "_Displacement.png", "_AmbientOcclusion.png", ".mtlx", ".json", "_relit.png"))
    gltf = tmp_path / "gl"
    assert _run(capsys, photo, "--model", tiny_model, "-o", gltf, "--target", "gltf", "-q")[0] == 0
    assert json.loads((gltf / "wood.gltf").read_text())["materials"][0]["occlusionTexture"] == {"index": 2}


def test_refine_quality_auto_and_the_kept_preview_on_the_terminal(photo, tiny_model, tmp_path, capsys,
                                                                    monkeypatch):
    pytest.importorskip("torch")
    from svbrdf.trainer import refine as refine_module

    monkeypatch.setattr(refine_module, "MARGIN", 1.0)  # no fit can win: the preview is kept, and said so
    code, out, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "a", "--refine", "--quality", "auto",
                          "--threads", "1")
    assert code == 0, err
    meta = json.loads((tmp_path / "a" / "wood.json").read_text())["meta"]
    rec = meta["refine"]
    assert rec["kept"] == "preview" and rec["reason"] == "held-out error" and rec["iterations"] >= 1
    assert f"refine kept the preview: held-out error {rec['heldout_rmse_refined']:.3f} vs the preview's " \
           f"{rec['heldout_rmse_preview']:.3f}, the fit not better on held-out fold 1" in out
    assert rec["folds"] == 1 and rec["folds_won"] == 0  # the first fold lost: the others were not fitted
    # The kept maps are the preview's: the same files as without --refine.
    assert _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "b", "--threads", "1")[0] == 0
    assert (tmp_path / "a" / "wood_roughness.png").read_bytes() == (tmp_path / "b" / "wood_roughness.png").read_bytes()


# ------------------------------------------------------------------------------------------ --maps
def test_maps_subset_writes_only_those_files_and_no_relit_panel(photo, tiny_model, tmp_path, capsys):
    out_dir = tmp_path / "out"
    code, out, err = _run(capsys, photo, "--model", tiny_model, "-o", out_dir, "--maps", "normal,basecolor",
                          "--threads", "1")
    assert code == 0, err
    assert sorted(p.name for p in out_dir.iterdir()) == ["wood.json", "wood_basecolor.png", "wood_normal.png"]
    assert err.strip().splitlines() == ["svbrdf-preview: note: no relit panel with --maps (it renders all four maps)"]
    sidecar = json.loads((out_dir / "wood.json").read_text())
    assert sidecar["maps"] == ["diffuse", "normal"] and sidecar["meta"]["maps"] == ["diffuse", "normal"]
    assert sidecar["meta"]["model"]["graph"] == "full"  # maps of both decoders
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "r", "--maps", "roughness", "-q")
    assert code == 0 and err == ""
    assert sorted(p.name for p in (tmp_path / "r").iterdir()) == ["wood.json", "wood_roughness.png"]
    assert json.loads((tmp_path / "r" / "wood.json").read_text())["meta"]["model"]["graph"] == "normal_roughness"


def test_maps_usage_errors(photo, tiny_model, tmp_path, capsys):
    code, out, err = _run(capsys, photo, "--model", tiny_model, "--maps", "normal,albedo")
    errors = [line for line in err.splitlines() if line.startswith(ERR)]
    assert code == 2 and out == "" and len(errors) == 1
    assert "unknown map name 'albedo'" in errors[0] and "diffuse, specular, roughness, normal" in errors[0]
    code, _, err = _run(capsys, photo, "--model", tiny_model, "--maps", "normal", "--target", "unreal")
    assert code == 2 and "--maps needs --target generic" in err
    assert not (photo.parent / "wood_svbrdf").exists()


def test_maps_with_a_model_without_parts_warns_once(photo, tiny_model, tmp_path, capsys):
    for f in tiny_model.parent.glob("tiny.*"):  # main graph, manifest and checkpoint; no part files
        if f.suffixes in ([".onnx"], [".json"], [".pt"]):
            (tmp_path / f.name).write_bytes(f.read_bytes())
    manifest = json.loads((tmp_path / "tiny.json").read_text())
    del manifest["parts"]
    (tmp_path / "tiny.json").write_text(json.dumps(manifest))
    other = tmp_path / "oak.png"
    other.write_bytes(photo.read_bytes())
    code, out, err = _run(capsys, photo, other, "--model", tmp_path / "tiny.onnx", "-o", tmp_path / "out",
                          "--maps", "specular")
    assert code == 0, err
    assert err.count("svbrdf-preview: warning: tiny.onnx was exported without part graphs") == 1
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        "oak.json", "oak_specular.png", "wood.json", "wood_specular.png"]


def test_refine_with_maps_writes_only_those(photo, tiny_model, tmp_path, capsys):
    pytest.importorskip("torch")
    code, out, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "out", "--refine", "--iters", "1",
                          "--threads", "1", "--maps", "roughness", "-q")
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["wood.json", "wood_roughness.png"]
    meta = json.loads((tmp_path / "out" / "wood.json").read_text())["meta"]
    from svbrdf.trainer.refine import FOLDS

    rec = meta["refine"]
    assert meta["maps"] == ["roughness"]
    assert rec["iterations"] == rec["folds"] + (rec["shifts"] is not None) <= FOLDS + 1


# ------------------------------------------------------------------------------------------ height and AO
def test_height_and_ao_are_written_by_default(photo, tiny_model, tmp_path, capsys):
    from svbrdf.runtime.core.relief import denormalise, slope_correlation
    from svbrdf.runtime.io.images import image_info

    out_dir = tmp_path / "o"
    code, out, err = _run(capsys, photo, "--model", tiny_model, "-o", out_dir, "--threads", "1")
    assert code == 0, err
    for suffix in ("_height.png", "_ao.png"):
        info = image_info(out_dir / f"wood{suffix}")
        assert info["channels"] == 1 and info["dtype"] == "uint16" and (info["width"], info["height"]) == (64, 48)
    sidecar = json.loads((out_dir / "wood.json").read_text())
    relief = sidecar["relief"]
    assert relief["maps"] == ["height", "ao"] and relief["tileable"] is False
    assert sidecar["meta"]["timings"]["relief"] >= 0
    height = denormalise(read_image(out_dir / "wood_height.png", raw=True)[..., 0], relief["height_scale"])
    normal = read_image(out_dir / "wood_normal.png", raw=True) * 2 - 1
    corr = slope_correlation(height, normal)
    assert corr["x"] > 0.5 and corr["y"] > 0.5, corr  # a random tiny model: its normals have curl; real ones: >= 0.9
    ao = read_image(out_dir / "wood_ao.png", raw=True)
    assert 0.6 <= float(ao.mean()) <= 1.0


def test_maps_height_or_ao_alone_computes_the_normal_map_and_writes_it(photo, tiny_model, tmp_path, capsys):
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "h", "--maps", "height", "-q")
    assert code == 0 and err == ""
    assert sorted(p.name for p in (tmp_path / "h").iterdir()) == ["wood.json", "wood_height.png", "wood_normal.png"]
    sidecar = json.loads((tmp_path / "h" / "wood.json").read_text())
    assert sidecar["meta"]["model"]["graph"] == "normal_roughness" and sidecar["relief"]["maps"] == ["height"]
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "a", "--maps", "ao,roughness",
                        "--format", "exr", "--tileable", "-q")
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["wood.json", "wood_ao.exr", "wood_normal.exr",
                                                                  "wood_roughness.exr"]
    relief = json.loads((tmp_path / "a" / "wood.json").read_text())["relief"]
    assert relief["tileable"] is True and relief["maps"] == ["ao"]
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "n", "--maps",
                        "diffuse,specular,roughness,normal", "-q")
    assert code == 0 and not list((tmp_path / "n").glob("*_height.png"))  # the four maps only, as before
    code, _, err = _run(capsys, photo, "--model", tiny_model, "--maps", "height,depth")
    assert code == 2 and "unknown map name 'depth'" in err and "relief maps: height, ao" in err
    code, _, err = _run(capsys, photo, "--model", tiny_model, "-o", tmp_path / "s", "--ao-strength", "1", "-q")
    assert code == 0 and json.loads((tmp_path / "s" / "wood.json").read_text())["relief"]["ao"]["strength"] == 1.0
    code, _, err = _run(capsys, photo, "--model", tiny_model, "--ao-strength", "0")
    assert code == 2 and "--ao-strength: must be a finite number > 0" in err


def test_network_size_picks_the_path_and_is_recorded(tiny_model, tmp_path, capsys):
    """A 96 x 64 photo with ``--network-size 32``: the network sees 32 x 22 block means and the maps are at the
    photo's size (the sidecar records both); ``full``: the network at the photo's own size, no upsampling."""
    path = tmp_path / "p.png"
    rng = np.random.default_rng(3)
    write_image(path, rng.uniform(0.1, 0.6, (64, 96, 3)).astype(np.float32), bits=8, srgb_encode=True)
    for value, network in (("32", [22, 32]), ("full", None)):
        out = tmp_path / value
        code, _, err = _run(capsys, path, "-o", out, "--model", tiny_model, "--network-size", value)
        assert code == 0, err
        meta = json.loads((out / "p.json").read_text())["meta"]
        assert meta["size"] == [64, 96] and meta.get("network_size") == network
        assert read_image(out / "p_roughness.png").shape[:2] == (64, 96)
        assert ("upsample" in meta["timings"]) == (network is not None)


@pytest.mark.parametrize("network_size", ["full", "64"])  # the photo read whole; read strip by strip (guided path)
def test_a_truncated_jpeg_is_one_error_line_exit_1_and_nothing_written(tiny_model, tmp_path, capsys, network_size):
    """libjpeg only warns about a JPEG cut short (and decodes grey where its data is missing): the photo is refused
    with one line naming it, exit 1, no file in the output folder; the whole JPEG is processed."""
    import OpenImageIO as oiio

    rng = np.random.default_rng(7)
    buf = oiio.ImageBuf(oiio.ImageSpec(320, 240, 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), rng.uniform(0.1, 0.6, (240, 320, 3)).astype(np.float32))
    good = tmp_path / "good.jpg"
    assert buf.write(str(good)), buf.geterror()
    bad = tmp_path / "cut.jpg"
    bad.write_bytes(good.read_bytes()[: good.stat().st_size * 2 // 5])
    code, out, err = _run(capsys, bad, "-o", tmp_path / "out", "--model", tiny_model, "--network-size", network_size,
                          "--threads", "1")
    assert code == 1 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"{ERR}{bad}: unreadable, corrupt or truncated image ("), err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    code, _, err = _run(capsys, good, "-o", tmp_path / "out", "--model", tiny_model, "--network-size", network_size,
                        "--threads", "1", "-q")
    assert code == 0, err
    assert (tmp_path / "out" / "good_basecolor.png").is_file()


# --- the camera (issue 68): the field of view from the flash's fall-off, a flash out of frame, --fov 0 ----------

def test_the_sidecar_records_an_estimated_camera(tiny_model, tmp_path, capsys, flash_plane):
    photo = flash_plane(tmp_path / "plane.png", 70.0)
    code, _, err = _run(capsys, photo, "--model", tiny_model, "--threads", "1", "-o", tmp_path / "o")
    assert code == 0 and "warning" not in err, err
    sidecar = json.loads((tmp_path / "o" / "plane.json").read_text())
    camera = sidecar["camera"]
    assert camera["fov_source"] == "estimated" and abs(camera["fov_deg"] - 70.0) < 7.0, camera
    assert sidecar["brdf"]["render_config"]["fov_deg"] == camera["fov_deg"]
    # --fov overrides the estimate
    code, _, err = _run(capsys, photo, "--model", tiny_model, "--threads", "1", "-o", tmp_path / "f", "--fov", "40")
    assert code == 0 and json.loads((tmp_path / "f" / "plane.json").read_text())["camera"]["fov_source"] == "option"


@pytest.mark.parametrize("refine", [(), ("--refine", "--iters", "1")], ids=["preview", "refine"])
def test_a_flash_out_of_frame_is_one_warning_and_the_maps(refine, tiny_model, tmp_path, capsys, flash_plane):
    import math

    if refine:
        pytest.importorskip("torch")
    photo = flash_plane(tmp_path / "side.png", 45.0, light=[2.5, 0.0, 1.0 / math.tan(math.radians(22.5))])
    code, out, err = _run(capsys, photo, "--model", tiny_model, "--threads", "1", "-o", tmp_path / "o", *refine)
    assert code == 0, err
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert len(warnings) == 1 and "Traceback" not in err
    assert warnings[0].startswith(f"svbrdf-preview: warning: {photo}: the flash highlight is out of frame; the maps "
                                  "assume a camera of ")
    for suffix in SET_FILES:
        assert (tmp_path / "o" / f"side{suffix}").is_file(), suffix
    camera = json.loads((tmp_path / "o" / "side.json").read_text())["camera"]
    assert camera["highlight"] == "out of frame" and f"{camera['fov_deg']:.1f} deg" in warnings[0]


@pytest.mark.parametrize("fov", ["0", "-5", "0.5", "171", "nan"])
def test_a_zero_or_absurd_fov_is_refused(fov, capsys):
    code, out, err = _run(capsys, "p.png", "--fov", fov)
    assert code == 2 and out == "" and "--fov must be in [1, 170] degrees" in err and "Traceback" not in err
