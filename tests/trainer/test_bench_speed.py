"""svbrdf.trainer.bench.speed: variants are built and timed side by side (no timing is asserted)."""

import json

from svbrdf.trainer.bench import speed


def test_variants_measured_and_written(tmp_path, one_torch_thread):
    out = tmp_path / "speed"
    assert speed.main(["--preset", "tiny", "--size", "64", "--iters", "1", "--repeats", "2",
                       "--variants", "base,fp32,channels_last", "--out", str(out)]) == 0
    doc = json.loads((out / "results.json").read_text())
    assert [r["variant"] for r in doc["rows"]] == ["base", "fp32", "channels_last"]
    assert all(len(r["all"]) == 2 and r["seconds_per_iteration"] > 0 for r in doc["rows"])
    assert doc["rows"][0]["ratio_to_first"] == 1.0
    assert "| channels_last |" in (out / "results.md").read_text()
    assert speed.main(["--preset", "tiny", "--out", str(out)]) == 2  # exists, no --force
    assert speed.main(["--variants", "warp", "--out", str(tmp_path / "x")]) == 2
    assert speed.main(["--variants", "base,preset:nope", "--out", str(tmp_path / "y")]) == 2


def test_another_preset_as_a_variant(tmp_path, one_torch_thread, monkeypatch):
    built = {}
    real = speed._trainer

    def spy(preset, size, variant, threads):
        trainer = real(preset, size, variant, threads)
        built[variant] = trainer.config.preset
        return trainer

    monkeypatch.setattr(speed, "_trainer", spy)
    out = tmp_path / "speed"
    assert speed.main(["--preset", "tiny", "--size", "64", "--iters", "1", "--repeats", "1",
                       "--variants", "base,preset:fast-v1", "--out", str(out)]) == 0
    assert built == {"base": "tiny", "preset:fast-v1": "fast-v1"}
    rows = json.loads((out / "results.json").read_text())["rows"]
    assert [r["variant"] for r in rows] == ["base", "preset:fast-v1"]


def test_settings_as_a_variant_and_the_anchor_is_timed(one_torch_thread):
    anchored = speed._trainer("tiny", 64, "set:lambda_anchor=3+anchor_maps=[\"normal\"]", 1)
    assert anchored.config.lambda_anchor == 3.0 and anchored.config.anchor_maps == ("normal",)
    assert anchored.anchor is not None and anchored.anchor.shape == (1, 8, 64, 64)
    assert anchored.iteration()["nr/anchor"] is not None  # the pull is part of the timed iteration
    assert speed._trainer("tiny", 64, "base", 1).anchor is None  # tiny pulls nothing
    assert not speed._known("set:lambda_anchor=-1") and not speed._known("set:warp=1")
    assert speed._known("set:lambda_anchor=0")
    # Checked against the preset it will change: the joint schedule needs 1:1:1 updates, which paper has not.
    assert speed._known("set:schedule=joint", "fast") and not speed._known("set:schedule=joint", "paper")
