"""TrainConfig.post: the runtime's PostProcess as the trainer's post-processing settings, and the records before it."""

from pathlib import Path

import pytest

from svbrdf.runtime.post import PostProcess
from svbrdf.trainer.config import NO_POST, TRAIN_PRESETS, TrainConfig, flat_settings, parse_settings, resolve

MODELS = Path(__file__).resolve().parents[2] / "models"

#: The post-processing settings as the checkpoints before ``TrainConfig.post`` recorded them (flat keys).
OLD_KEYS = ("flash_trend", "uniform_specular", "highlight_fill", "even_lighting")


def _old_record(cfg: TrainConfig) -> dict:
    """``cfg`` as a checkpoint of the previous format records it: no ``post``, four flat keys."""
    d = cfg.to_dict()
    post = d.pop("post")
    d.update({k: post[k] for k in OLD_KEYS})
    return d


def test_the_post_field_is_the_runtime_type_and_the_presets_set_it():
    paper, fast = resolve("paper"), resolve("fast")
    assert type(paper.post) is PostProcess and paper.post == NO_POST
    assert NO_POST == PostProcess.off().replace(even_lighting=0.0)  # the paper: no correction, the photo as it is
    assert fast.post == PostProcess(even_lighting=0.25, colour_from_photo=False, highlight_fill=True,
                                    fill_patches=True, flash_trend=True, uniform_specular=True)
    assert resolve("fast-v1").post == NO_POST and fast.even_lighting == 0.25 and paper.even_lighting == 0.0
    assert TrainConfig(post=PostProcess.off()).post.even_lighting == 0.0  # None and 0 are one value here
    with pytest.raises(ValueError, match="post must be a PostProcess"):
        TrainConfig(post={"flash_trend": True})


def test_old_flat_records_load_to_the_same_settings_and_round_trip():
    for name, cfg in TRAIN_PRESETS.items():
        assert TrainConfig.from_dict(_old_record(cfg)) == cfg, name
        assert TrainConfig.from_dict(cfg.to_dict()) == cfg, name
    # A record that lacks some post settings: the paper's (none) for those.
    d = _old_record(TRAIN_PRESETS["paper"])
    del d["highlight_fill"], d["even_lighting"]
    assert TrainConfig.from_dict({**d, "flash_trend": True}).post == NO_POST.replace(flash_trend=True)
    assert TrainConfig.from_dict({**TRAIN_PRESETS["paper"].to_dict(), "post": {"uniform_specular": True}}).post \
        == NO_POST.replace(uniform_specular=True)
    with pytest.raises(ValueError, match="unknown training settings: post.sharpen"):
        TrainConfig.from_dict({"post": {"sharpen": True}})


def test_the_packaged_stage_one_records_the_fast_settings():
    torch = pytest.importorskip("torch")
    from svbrdf.trainer.checkpoint import load_checkpoint

    path = MODELS / "svbrdf_prior_v2.pt"
    if not path.exists():
        pytest.skip("no packaged checkpoint")
    ckpt = load_checkpoint(path)
    assert "post" not in ckpt["train_config"] and "flash_trend" in ckpt["train_config"]  # the old format
    cfg = TrainConfig.from_dict(ckpt["train_config"])
    assert cfg.post == TRAIN_PRESETS["fast"].post and cfg.preset == "fast"
    # Its refine record (no post setting) merges as before.
    merged = TrainConfig.from_dict({**cfg.to_dict(), **ckpt["refine"]})
    assert merged.post == cfg.post and merged.losses.anchor == ckpt["refine"]["lambda_anchor"]
    assert torch is not None


def test_overrides_name_post_settings_in_three_ways():
    want = TRAIN_PRESETS["fast"].post.replace(flash_trend=False)
    assert resolve("fast", **{"post.flash_trend": False}).post == want
    assert resolve("fast", flash_trend=False).post == want  # the name before the post field
    assert resolve("fast", post={"flash_trend": False}).post == want  # the other fields stay the preset's
    assert resolve("fast", post=want).post == want
    assert resolve("fast", **parse_settings(["post.even_lighting=0"])).even_lighting == 0.0
    assert resolve("fast", even_lighting=0.125).post.even_lighting == 0.125
    with pytest.raises(ValueError, match="unknown training settings: post.nope"):
        resolve("fast", **{"post.nope": 1})
    with pytest.raises(ValueError, match="even_lighting must be"):
        resolve("fast", **{"post.even_lighting": 2.0})
    with pytest.raises(ValueError, match="post must be"):
        resolve("fast", post=3)


def test_flat_settings_spreads_post():
    flat = flat_settings(resolve("fast").to_dict())
    assert flat["post.flash_trend"] is True and flat["post.even_lighting"] == 0.25 and "post" not in flat
    assert flat["optim.lr"] == resolve("fast").optim.lr and flat_settings({"lr": 1.0}) == {"optim.lr": 1.0}
