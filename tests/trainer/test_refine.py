"""svbrdf.trainer.refine: the fine-tune behind ``svbrdf-preview --refine`` and its ``--quality auto`` skip rule."""

import numpy as np
import pytest
import torch

from svbrdf.runtime.quality import preview_check
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, render
from svbrdf.trainer.checkpoint import build_checkpoint, save_checkpoint
from svbrdf.trainer.config import resolve
from svbrdf.trainer.models import Generator
from svbrdf.trainer.refine import refine, refine_config


@pytest.fixture
def tiny_ckpt(tmp_path):
    config = resolve("tiny")
    torch.manual_seed(0)
    ckpt = build_checkpoint(generator=Generator(config.generator), discriminator=None,
                            train_config=config.to_dict(), stage="pretrain", step=1, iters=1)
    return save_checkpoint(tmp_path / "tiny.pt", ckpt)


def _photo_and_preview(size=48):
    rng = np.random.default_rng(0)
    normal = np.zeros((size, size, 3), np.float32)
    normal[..., 2] = 1.0
    maps = Maps(diffuse=rng.uniform(0.2, 0.8, (size, size, 3)).astype(np.float32),
                specular=np.full((size, size, 1), 0.04, np.float32),
                roughness=np.full((size, size, 1), 0.5, np.float32), normal=normal,
                meta={"burn_in": {"burn_in": 0.1}})
    return np.clip(render(maps, None, ZHAO), 0, 1), maps


def test_refine_runs_the_checkpoint_preset(tiny_ckpt):
    photo, _ = _photo_and_preview()
    steps = []
    maps = refine(photo, tiny_ckpt, iters=2, threads=1, name="p.png",
                  callback=lambda trainer, rec: steps.append(rec["step"]))
    assert maps.shape == (48, 48) and steps == [1, 2]
    assert maps.meta["refine"] == {"checkpoint": str(tiny_ckpt), "iterations": 2, "stopped_early": False,
                                   "notes": maps.meta["refine"]["notes"]}
    assert 0.0 <= maps.meta["burn_in"]["burn_in"]


def test_quality_auto_skips_when_the_preview_explains_the_photo(tiny_ckpt, monkeypatch):
    photo, preview = _photo_and_preview()
    no_lookup = lambda: pytest.fail("a skipped fine-tune must not look up its checkpoint")  # noqa: E731
    out = refine(photo, no_lookup, quality="auto", preview=preview, render_config=ZHAO)
    assert out is preview and out.meta["refine"]["skipped"] is True
    assert out.meta["refine"]["preview_input_rmse"] == pytest.approx(0.0, abs=1e-6)
    monkeypatch.setattr(preview_check, "SKIP_REFINE_BURN_IN", 0.05)  # a burnt-in preview is refined
    photo, preview = _photo_and_preview()
    out = refine(photo, lambda: tiny_ckpt, quality="auto", iters=1, threads=1, preview=preview, render_config=ZHAO)
    assert out is not preview and out.meta["refine"]["iterations"] == 1
    assert out.meta["refine"]["preview_burn_in"] == 0.1 and "preview_input_rmse" in out.meta["refine"]


def test_refine_argument_errors(tiny_ckpt):
    photo, preview = _photo_and_preview()
    with pytest.raises(ValueError, match="unknown quality"):
        refine(photo, tiny_ckpt, quality="best")
    with pytest.raises(ValueError, match="render_config"):
        refine(photo, tiny_ckpt, quality="auto", preview=preview)


def test_refine_config_uses_this_versions_preset_or_the_recorded_settings():
    recorded = resolve("tiny", iters_finetune=99, lr=1e-3).to_dict()
    assert refine_config({"train_config": recorded}).iters_finetune == resolve("tiny").iters_finetune
    cfg = refine_config({"train_config": recorded}, "auto", iters=5)
    assert cfg.quality == "auto" and cfg.iters_finetune == 5
    unknown = {**recorded, "preset": "retired"}
    assert refine_config({"train_config": unknown}).lr == 1e-3


def test_the_fine_tune_renders_with_the_photos_camera(tiny_ckpt):
    photo, _ = _photo_and_preview()
    seen = []
    refine(photo, tiny_ckpt, iters=1, threads=1, render_config=ZHAO.replace(fov_deg=23.0),
           callback=lambda trainer, rec: seen.append((trainer.config.render["fov_deg"], trainer.geometry.config.fov_deg)))
    assert seen == [(23.0, 23.0)]
    assert refine_config({"train_config": resolve("tiny").to_dict()}, fov_deg=31.0).render["fov_deg"] == 31.0
