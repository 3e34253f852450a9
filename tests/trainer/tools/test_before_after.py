"""The before/after picture grid (svbrdf.trainer.tools.before_after): one row per photo and preset, burn-in JSON."""

import json

import numpy as np
import pytest

from svbrdf.runtime.io.images import read_image, write_image
from svbrdf.trainer import train as T
from svbrdf.trainer.config import resolve
from svbrdf.trainer.tools import before_after


@pytest.fixture
def tiny_ckpt(tmp_path):
    photo = T.photo_to_tensor(np.random.default_rng(0).uniform(0, 1, (40, 40, 3)).astype(np.float32))
    trainer = T.Trainer(photo, resolve("tiny", iters_pretrain=1), stage="pretrain", threads=1)
    trainer.run()
    path = tmp_path / "tiny.pt"
    trainer.save(path)
    return path


def test_grid_rows_and_burn_in(tmp_path, tiny_ckpt):
    photos = []
    for i, name in enumerate(("a.png", "b.png")):
        img = np.random.default_rng(i).uniform(0.1, 0.6, (40, 52, 3))
        write_image(tmp_path / name, img, bits=8, srgb_encode=True)
        photos.append(str(tmp_path / name))
    out = tmp_path / "grid.png"
    args = [*photos, "--presets", "tiny,tiny", "--iters", "2", "--size", "32", "--init", str(tiny_ckpt),
            "--out", str(out)]
    assert before_after.main(args) == 0
    grid = read_image(out)
    assert grid.shape == (4 * 32, 8 * 32, 3)  # 2 photos x 2 presets; photo, 4 maps, 3 relit panels
    rec = json.loads(out.with_suffix(".json").read_text())
    assert [r["preset"] for r in rec["rows"]] == ["tiny"] * 4 and all(r["burn_in"] >= 0 for r in rec["rows"])
    assert before_after.main(args) == 2  # exists: refused without --force
    assert before_after.main([str(tmp_path / "missing.png"), "--init", str(tiny_ckpt), "--out",
                              str(tmp_path / "x.png")]) == 2


def test_a_row_may_carry_settings(tmp_path, tiny_ckpt, capsys):
    assert before_after._preset_spec("fast+flash_trend=false+lr=1e-4+perceptual=pyramid") == \
        ("fast", {"flash_trend": False, "lr": 1e-4, "perceptual": "pyramid"})
    img = np.random.default_rng(0).uniform(0.1, 0.6, (40, 40, 3))
    write_image(tmp_path / "a.png", img, bits=8, srgb_encode=True)
    out = tmp_path / "grid.png"
    base = [str(tmp_path / "a.png"), "--iters", "1", "--size", "32", "--init", str(tiny_ckpt), "--out", str(out)]
    assert before_after.main([*base, "--presets", "tiny+flash_trend=false,tiny+flash_trend=true"]) == 0
    rec = json.loads(out.with_suffix(".json").read_text())
    assert [r["preset"] for r in rec["rows"]] == ["tiny+flash_trend=false", "tiny+flash_trend=true"]
    for bad in ("tiny+no_such_setting=1", "tiny+flash_trend"):
        assert before_after.main([*base, "--presets", bad, "--force"]) == 2
        assert "error" in capsys.readouterr().err


def test_an_unwritable_format_is_refused_before_any_fine_tune(tmp_path, tiny_ckpt, capsys, monkeypatch):
    img = np.random.default_rng(0).uniform(0.1, 0.6, (40, 40, 3))
    write_image(tmp_path / "a.png", img, bits=8, srgb_encode=True)
    monkeypatch.setattr(before_after, "photo_burn_in", None)  # a fine-tune reaching its scoring would fail
    out = tmp_path / "grid.jpg"
    assert before_after.main([str(tmp_path / "a.png"), "--presets", "tiny", "--iters", "1", "--size", "32",
                              "--init", str(tiny_ckpt), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "unsupported output format '.jpg'" in err and err.count("\n") == 1
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_a_row_larger_than_the_panel_size_lines_up():
    from svbrdf.runtime.core.maps import Maps
    from svbrdf.runtime.outputs.texture_set import PANEL_SIZE

    s = PANEL_SIZE + 8
    rng = np.random.default_rng(0)
    maps = Maps(diffuse=rng.uniform(0, 1, (s, s, 3)).astype(np.float32),
                specular=np.full((s, s, 1), 0.04, np.float32), roughness=np.full((s, s, 1), 0.5, np.float32),
                normal=np.tile(np.array([0, 0, 1], np.float32), (s, s, 1)))
    row = before_after.row_image(rng.uniform(0, 1, (s, s, 3)).astype(np.float32), maps)
    assert row.shape == (s, 8 * s, 3)


def test_presets_split_at_commas_outside_brackets():
    assert before_after.split_presets('fast-v1,fast+anchor_maps=["normal","roughness"]+lr=1e-4,') == [
        "fast-v1", 'fast+anchor_maps=["normal","roughness"]+lr=1e-4']
    name, settings = before_after._preset_spec('fast+anchor_maps=["normal","roughness"]')
    assert name == "fast" and settings == {"anchor_maps": ["normal", "roughness"]}
