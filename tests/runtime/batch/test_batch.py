"""``svbrdf-batch`` and :mod:`svbrdf.runtime.batch`: inputs, names, the library, resume, a SIGKILL mid-run, the
local pool."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from svbrdf.runtime.batch import (MANIFEST_FILE, OPTION_DEFAULTS, collect_photos, library_names, plan_workers,
                                  same_options)
from svbrdf.runtime.cli.batch import main
from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.images import write_image

pytest.importorskip("onnxruntime")

ERR = "svbrdf-batch: error: "
SET_SUFFIXES = ("_basecolor.png", "_normal.png", "_roughness.png", "_specular.png", "_relit.png", ".json")


def _photos(folder: Path, n: int, size=(40, 48)):
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for i in range(n):
        rng = np.random.default_rng(i)
        path = folder / f"p{i:02d}.png"
        write_image(path, rng.uniform(0.1, 0.6, (*size, 3)).astype(np.float32), bits=8, srgb_encode=True)
        out.append(path)
    return out


def _manifest(lib: Path) -> dict:
    return json.loads((lib / MANIFEST_FILE).read_text())["photos"]


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _complete(lib: Path, name: str) -> bool:
    return all((lib / name / f"{name}{s}").is_file() for s in SET_SUFFIXES)


def test_collect_photos_reads_folders_globs_and_lists(tmp_path):
    a, b, c = _photos(tmp_path / "in", 3)
    (tmp_path / "in" / "notes.txt").write_text("not a photo")
    listing = tmp_path / "list.txt"
    listing.write_text(f"# a comment\n\nin/{c.name}\n{a}\n")
    assert collect_photos([str(tmp_path / "in")]) == [a, b, c]
    assert collect_photos([str(tmp_path / "in" / "p0[12].png")]) == [b, c]
    assert collect_photos([f"@{listing}", str(b), str(c)]) == [tmp_path / "in" / c.name, a, b]
    with pytest.raises(SvbrdfError, match="no file matches"):
        collect_photos([str(tmp_path / "*.jpg")])
    with pytest.raises(SvbrdfError, match="cannot read the list"):
        collect_photos([f"@{tmp_path / 'missing.txt'}"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(SvbrdfError, match="no photos in this folder"):
        collect_photos([str(tmp_path / "empty")])


def test_duplicate_stems_get_numbered_names_and_keep_them(tmp_path):
    photos = [tmp_path / "a" / "wood.png", tmp_path / "b" / "wood.png", tmp_path / "thumbs.png"]
    names = library_names(photos, {})
    assert [names[p] for p in photos] == ["wood", "wood-2", "thumbs-2"]  # "thumbs" is the strips' folder
    # A later run keeps the names of the library, whatever the order of the photos.
    known = {str(p.resolve()): names[p] for p in photos}
    again = library_names([photos[1], tmp_path / "c" / "wood.png", photos[0]], known)
    assert again[photos[1]] == "wood-2" and again[photos[0]] == "wood"
    assert again[tmp_path / "c" / "wood.png"] == "wood-3"


def test_plan_workers_divides_the_cores():
    assert plan_workers(8, None, None) == (8, 1)
    assert plan_workers(8, None, 4) == (2, 4)
    assert plan_workers(8, 2, None) == (2, 4)
    assert plan_workers(8, 3, 2) == (3, 2)
    assert plan_workers(8, None, None, gpu=True) == (1, 8)  # the GPU refines one photo at a time
    assert plan_workers(1, None, 4) == (1, 4)


def test_library_resume_skips_done_and_retries_failed(tiny_model, tmp_path, capsys):
    photos = _photos(tmp_path / "in", 3)
    bad = tmp_path / "in" / "broken.png"
    bad.write_bytes(b"not a png")
    lib = tmp_path / "lib"
    code, out, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1")
    assert code == 1
    assert err.count(ERR) == 1 and "broken.png" in err  # one line for the bad photo, no traceback
    assert "Traceback" not in err
    records = _manifest(lib)
    assert {n: r["status"] for n, r in records.items()} == {"broken": "failed", "p00": "done", "p01": "done",
                                                            "p02": "done"}
    assert records["broken"]["error"].startswith(str(bad))
    for p in photos:
        rec = records[p.stem]
        assert _complete(lib, p.stem) and (lib / "thumbs" / f"{p.stem}.png").is_file()
        assert rec["sha256"] and rec["scores"]["rerender_rmse"] > 0 and rec["scores"]["burn_in"] >= 0
        sidecar = json.loads((lib / p.stem / f"{p.stem}.json").read_text())
        assert sidecar["meta"]["batch"]["sha256"] == rec["sha256"] and sidecar["meta"]["source"] == str(p)
    assert not (lib / ".staging").exists() or not any((lib / ".staging").iterdir())
    html = (lib / "index.html").read_text()
    assert html.index("broken") < html.index("p00")  # failed first
    assert 'src="thumbs/p00.png"' in html and "<script>" in html
    assert (lib / "index.png").is_file()

    # Fix the bad photo: the re-run does only that one.
    write_image(bad, np.full((40, 48, 3), 0.3, np.float32), bits=8, srgb_encode=True, force=True)
    before = {p.stem: (lib / p.stem / f"{p.stem}.json").stat().st_mtime_ns for p in photos}
    code, out, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1")
    assert code == 0, err
    assert "1 done, 0 failed, 3 already done" in err
    assert _manifest(lib)["broken"]["status"] == "done" and _complete(lib, "broken")
    assert before == {p.stem: (lib / p.stem / f"{p.stem}.json").stat().st_mtime_ns for p in photos}


def test_changed_options_need_force(tiny_model, tmp_path, capsys):
    _photos(tmp_path / "in", 1)
    lib = tmp_path / "lib"
    assert _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1")[0] == 0
    code, _, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1",
                        "--format", "exr")
    assert code == 1 and "with other options; use --force to redo it" in err
    assert (lib / "p00" / "p00_normal.png").is_file()
    code, _, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1",
                        "--format", "exr", "--force")
    assert code == 0, err
    assert (lib / "p00" / "p00_normal.exr").is_file() and not (lib / "p00" / "p00_normal.png").exists()
    assert _manifest(lib)["p00"]["options"]["format"] == "exr"


def test_the_network_size_is_an_option_of_the_set(tiny_model, tmp_path, capsys):
    """``--network-size`` reaches the workers (the sidecar's ``network_size``) and is recorded: another one redoes a
    set only with --force."""
    _photos(tmp_path / "in", 1, size=(40, 72))
    lib = tmp_path / "lib"
    argv = [tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1"]
    assert _run(capsys, *argv, "--network-size", "36")[0] == 0
    assert _manifest(lib)["p00"]["options"]["network_size"] == 36
    assert json.loads((lib / "p00" / "p00.json").read_text())["meta"]["network_size"] == [20, 36]
    code, _, err = _run(capsys, *argv, "--network-size", "full")
    assert code == 1 and "with other options; use --force to redo it" in err
    assert _run(capsys, *argv, "--network-size", "full", "--force")[0] == 0
    assert _manifest(lib)["p00"]["options"]["network_size"] is None
    assert "network_size" not in json.loads((lib / "p00" / "p00.json").read_text())["meta"]


def test_a_folder_that_is_not_a_library_is_refused(tiny_model, tmp_path, capsys):
    _photos(tmp_path / "in", 1)
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "mine.txt").write_text("a user's file")
    code, _, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model)
    assert code == 1 and err.strip().endswith("(not a library) (use --force to overwrite)")
    assert sorted(os.listdir(lib)) == ["mine.txt"]


def test_usage_errors_exit_2(capsys):
    code, _, err = _run(capsys, "x.png", "-o", "lib", "--iters", "3")
    assert code == 2 and f"{ERR}--iters and --quality need --refine" in err
    code, _, err = _run(capsys, "x.png", "-o", "lib", "--gpus-per-task", "1")
    assert code == 2 and "--gpus-per-task needs --ray" in err
    code, _, err = _run(capsys, "x.png")
    assert code == 2 and "-o/--out" in err


def test_view_needs_all_maps_and_writes_nothing(tiny_model, tmp_path, capsys):
    _photos(tmp_path / "in", 1)
    lib = tmp_path / "lib"
    code, out, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--view", "--maps", "normal")
    assert code == 2 and out == "" and "Traceback" not in err
    assert "usage: svbrdf-batch" in err
    assert [line for line in err.splitlines() if line.startswith(ERR)] == [
        f"{ERR}--view needs all four maps (it relights them)"]
    assert not lib.exists()


def test_view_with_a_target_writes_both(tiny_model, tmp_path, capsys):
    photo = _photos(tmp_path / "in", 1)[0]
    lib = tmp_path / "lib"
    code, _, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--view", "--target", "gltf",
                        "--workers", "1")
    assert code == 0, err
    files = sorted(p.name for p in (lib / photo.stem).iterdir())
    assert f"{photo.stem}_view.html" in files and f"{photo.stem}.gltf" in files, files


def test_tileable_and_view_reach_every_set_and_the_index(tiny_model, tmp_path, capsys):
    photos = _photos(tmp_path / "in", 2)
    small = _photos(tmp_path / "tiny", 1, size=(12, 20))[0]  # below tileable.MIN_SIZE (16 px) on one side
    small = small.rename(tmp_path / "in" / "small.png")
    lib = tmp_path / "lib"
    argv = [tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1", "--tileable", "--view"]
    code, out, err = _run(capsys, *argv)
    assert code == 1 and "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith(ERR)]
    assert errors == [f"{ERR}{small}: --tileable: maps of 20x12 px are too small to make tileable (at least 16 px "
                      "a side)"]
    records = _manifest(lib)
    assert {n: r["status"] for n, r in records.items()} == {"p00": "done", "p01": "done", "small": "failed"}
    assert not (lib / "small").exists() and not (lib / "thumbs" / "small.png").exists()
    index = (lib / "index.html").read_text()
    for p in photos:
        name = p.stem
        page = lib / name / f"{name}_view.html"
        assert _complete(lib, name) and page.is_file()  # renamed into the library with its set
        assert "window.svbrdfViewer" in page.read_text(encoding="utf-8")
        assert f"{name}_view.html" in records[name]["files"]
        assert records[name]["options"]["tileable"] is True and records[name]["options"]["view"] is True
        meta = json.loads((lib / name / f"{name}.json").read_text())["meta"]
        assert meta["tileable"]["method"] and set(meta["tileable"]["seam"]) == {"diffuse", "specular", "roughness",
                                                                               "normal"}
        assert meta["batch"]["options"]["tileable"] is True
        assert f'<a class="view" href="{name}/{name}_view.html">view</a>' in index
    assert index.count('class="view"') == 2  # none for the failed photo
    assert not (lib / ".staging").exists() or not any((lib / ".staging").iterdir())

    # The same command again: the two sets are done with these options; the small photo fails again.
    code, _, err = _run(capsys, *argv)
    assert code == 1 and "0 done, 1 failed, 2 already done" in err


def _strip_new_options(lib: Path, keys=("tileable", "view")) -> None:
    """Make ``lib`` look written before the options ``keys`` (default --tileable and --view): no such keys in the
    manifest or the sidecars."""
    doc = json.loads((lib / MANIFEST_FILE).read_text())
    for name, record in doc["photos"].items():
        for key in keys:
            del record["options"][key]
        sidecar = lib / name / f"{name}.json"
        meta = json.loads(sidecar.read_text())
        for key in keys:
            del meta["meta"]["batch"]["options"][key]
        sidecar.write_text(json.dumps(meta))
    (lib / MANIFEST_FILE).write_text(json.dumps(doc))


def test_same_options_reads_a_missing_new_key_as_its_default():
    new = {"refine": False, "tileable": False, "view": False, "model_sha256": "ab"}
    old = {"refine": False, "model_sha256": "ab"}
    assert same_options(old, new) and same_options(new, new)
    assert not same_options(old, {**new, "tileable": True}) and not same_options(old, {**new, "view": True})
    assert not same_options({**old, "refine": True}, new) and not same_options(None, new)


def test_a_library_from_before_tileable_and_view_is_not_redone(tiny_model, tmp_path, capsys):
    photos = _photos(tmp_path / "in", 2)
    lib = tmp_path / "lib"
    argv = [tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1"]
    assert _run(capsys, *argv)[0] == 0
    _strip_new_options(lib)
    stamps = {p.stem: (lib / p.stem / f"{p.stem}.json").stat().st_mtime_ns for p in photos}

    code, _, err = _run(capsys, *argv)  # without --tileable and --view: nothing to do
    assert code == 0 and "0 done, 0 failed, 2 already done" in err
    assert stamps == {p.stem: (lib / p.stem / f"{p.stem}.json").stat().st_mtime_ns for p in photos}

    code, _, err = _run(capsys, *argv, "--tileable")  # the options changed: redone, with --force only
    assert code == 1 and err.count("with other options; use --force to redo it") == 2
    assert stamps == {p.stem: (lib / p.stem / f"{p.stem}.json").stat().st_mtime_ns for p in photos}
    code, _, err = _run(capsys, *argv, "--tileable", "--force")
    assert code == 0 and "2 done, 0 failed, 0 already done" in err
    for p in photos:
        assert _manifest(lib)[p.stem]["options"]["tileable"] is True
        assert "tileable" in json.loads((lib / p.stem / f"{p.stem}.json").read_text())["meta"]


def test_local_pool_makes_the_same_library(tiny_model, tmp_path, capsys):
    _photos(tmp_path / "in", 3)
    code, _, err = _run(capsys, tmp_path / "in", "-o", tmp_path / "one", "--model", tiny_model, "--workers", "1",
                        "-q")
    assert code == 0 and err == ""
    code, _, err = _run(capsys, tmp_path / "in", "-o", tmp_path / "pool", "--model", tiny_model, "--workers", "2",
                        "-q")
    assert code == 0, err
    one, pool = _manifest(tmp_path / "one"), _manifest(tmp_path / "pool")
    assert sorted(one) == sorted(pool) == ["p00", "p01", "p02"]
    for name in one:
        assert one[name]["sha256"] == pool[name]["sha256"]
        assert one[name]["scores"]["rerender_rmse"] == pytest.approx(pool[name]["scores"]["rerender_rmse"], abs=1e-6)


@pytest.mark.integration
def test_sigkill_mid_run_then_resume_loses_and_duplicates_nothing(tiny_model, tmp_path):
    photos = _photos(tmp_path / "in", 16, size=(96, 128))
    lib = tmp_path / "lib"
    cmd = [sys.executable, "-m", "svbrdf.runtime.cli.batch", str(tmp_path / "in"), "-o", str(lib),
           "--model", str(tiny_model), "--workers", "1", "-q"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    done = 0
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            done = sum(r["status"] == "done" for r in _manifest(lib).values())
        except (OSError, ValueError, KeyError):  # not written yet (never half-written: see below)
            done = 0
        if done >= 2:
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.01)
    proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL, f"the batch ended before the kill: {proc.stderr.read()!r}"
    records = _manifest(lib)  # the manifest parses: it is only ever replaced whole
    assert 2 <= sum(r["status"] == "done" for r in records.values()) < len(photos)
    for name in os.listdir(lib):  # every set in place is complete (a set is renamed in whole)
        if not name.startswith(".") and (lib / name).is_dir() and name != "thumbs":
            assert _complete(lib, name), name

    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    records = _manifest(lib)
    assert sorted(records) == sorted(p.stem for p in photos)  # nothing lost, nothing twice
    assert all(r["status"] == "done" for r in records.values())
    sets = sorted(n for n in os.listdir(lib) if (lib / n).is_dir() and not n.startswith(".") and n != "thumbs")
    assert sets == sorted(records) and all(_complete(lib, n) for n in sets)
    assert not any((lib / ".staging").iterdir()) if (lib / ".staging").exists() else True


def test_a_set_renamed_in_before_the_manifest_is_adopted(tiny_model, tmp_path, capsys):
    """A kill between the set's rename and the manifest's rewrite: the next run adopts the set, no redo."""
    _photos(tmp_path / "in", 2)
    lib = tmp_path / "lib"
    assert _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1")[0] == 0
    doc = json.loads((lib / MANIFEST_FILE).read_text())
    del doc["photos"]["p01"]
    (lib / MANIFEST_FILE).write_text(json.dumps(doc))
    stamp = (lib / "p01" / "p01.json").stat().st_mtime_ns
    code, _, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1")
    assert code == 0 and "0 done, 0 failed, 2 already done" in err
    assert _manifest(lib)["p01"]["status"] == "done" and (lib / "p01" / "p01.json").stat().st_mtime_ns == stamp


def test_refine_batch_fine_tunes_every_photo_and_resumes(tiny_model, tmp_path, capsys):
    pytest.importorskip("torch")
    _photos(tmp_path / "in", 2)
    lib = tmp_path / "lib"
    code, out, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1",
                          "--refine", "--iters", "2", "--threads", "1")
    assert code == 0, err
    records = _manifest(lib)
    assert {n: r["status"] for n, r in records.items()} == {"p00": "done", "p01": "done"}
    from svbrdf.trainer.refine import FOLDS  # --iters 2: two steps a fit, the folds judged and the final one

    for name in records:
        rec = json.loads((lib / name / f"{name}.json").read_text())["meta"]["refine"]
        assert rec["kept"] in ("refined", "preview")  # the final fit (its shifts) only after every fold won
        assert rec["iterations"] == 2 * (rec["folds"] + (rec["shifts"] is not None)) <= 2 * (FOLDS + 1)
        assert records[name]["options"]["refine"] is True
    code, out, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1",
                          "--refine", "--iters", "2", "--threads", "1")
    assert code == 0 and "0 done, 0 failed, 2 already done" in err


def test_every_set_gets_height_and_ao_and_a_library_from_before_them_is_redone_with_force(tiny_model, tmp_path,
                                                                                          capsys):
    photos = _photos(tmp_path / "in", 2)
    lib = tmp_path / "lib"
    argv = [tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1"]
    code, _, err = _run(capsys, *argv, "--maps", "diffuse,specular,roughness,normal")  # as before the relief maps
    assert code == 0, err
    assert not list(lib.rglob("*_height.png")) and _manifest(lib)[photos[0].stem]["options"]["relief"] == []
    _strip_new_options(lib, ("relief",))  # a library written before the relief maps existed
    code, _, err = _run(capsys, *argv)  # the default now adds height and AO: those sets lack them
    assert code == 1 and err.count("with other options; use --force to redo it") == 2
    code, _, err = _run(capsys, *argv, "--force")
    assert code == 0 and "2 done" in err
    for p in photos:
        assert (lib / p.stem / f"{p.stem}_height.png").is_file() and (lib / p.stem / f"{p.stem}_ao.png").is_file()
        assert _manifest(lib)[p.stem]["options"]["relief"] == ["height", "ao"]
        sidecar = json.loads((lib / p.stem / f"{p.stem}.json").read_text())
        assert sidecar["relief"]["maps"] == ["height", "ao"] and sidecar["relief"]["height_scale"] >= 0
    code, _, err = _run(capsys, *argv)  # and now they are done
    assert code == 0 and "2 already done" in err


def test_a_batch_set_has_the_images_of_svbrdf_preview(tiny_model, tmp_path, capsys):
    """The batch's per-photo path is the preview's (the relief and the relit panel made while the maps are written):
    every image of a set, byte for byte; the thumbnail shows that relit panel."""
    from svbrdf.runtime.cli.preview import main as preview
    from svbrdf.runtime.io.images import read_image

    (photo,) = _photos(tmp_path / "in", 1, size=(70, 90))
    lib, single = tmp_path / "lib", tmp_path / "single"
    # one onnxruntime thread in both (another split of the work could round the last bits otherwise)
    code, _, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1", "--threads", "1")
    assert code == 0, err
    assert preview([str(photo), "-o", str(single), "--model", str(tiny_model), "--threads", "1"]) == 0
    images = sorted(p.name for p in single.glob("*.png"))
    assert {"p00_height.png", "p00_ao.png", "p00_relit.png"} <= set(images)
    for name in images:
        assert (lib / "p00" / name).read_bytes() == (single / name).read_bytes(), name
    thumb = read_image(lib / "thumbs" / "p00.png", raw=True)
    assert thumb.shape[1] == 6 * thumb.shape[0] and float(thumb[:, -thumb.shape[0]:].std()) > 0.01  # a relit view


def test_a_truncated_jpeg_is_recorded_as_failed_and_the_photo_beside_it_is_done(tiny_model, tmp_path, capsys):
    """A JPEG cut short (libjpeg only warns about it) fails with one line naming it; the good photo beside it is
    done."""
    import OpenImageIO as oiio

    (good,) = _photos(tmp_path / "in", 1)
    buf = oiio.ImageBuf(oiio.ImageSpec(96, 80, 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), np.random.default_rng(9).uniform(0.1, 0.6, (80, 96, 3)).astype(np.float32))
    whole = tmp_path / "whole.jpg"
    assert buf.write(str(whole)), buf.geterror()
    cut = tmp_path / "in" / "cut.jpg"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    lib = tmp_path / "lib"
    code, _, err = _run(capsys, tmp_path / "in", "-o", lib, "--model", tiny_model, "--workers", "1")
    assert code == 1
    assert err.count(ERR) == 1 and f"{cut}: unreadable, corrupt or truncated image" in err and "Traceback" not in err
    records = _manifest(lib)
    assert {n: r["status"] for n, r in records.items()} == {"cut": "failed", good.stem: "done"}
    assert records["cut"]["error"].startswith(f"{cut}: unreadable, corrupt or truncated image (")
    assert _complete(lib, good.stem) and not (lib / "cut").exists()
