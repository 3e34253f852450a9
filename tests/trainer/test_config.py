"""The preset tables of svbrdf.trainer.config: one description per preset, the benchmark's ablations apart."""

import argparse
from pathlib import Path

from svbrdf.trainer import cli
from svbrdf.trainer.config import BENCH_PRESETS, CLI_PRESETS, PRESET_DESCRIPTIONS, TRAIN_PRESETS, resolve

README = Path(__file__).resolve().parents[2] / "README.md"


def _stage_parser(stage="fit"):
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[stage]


def test_every_preset_is_described_once_and_resolvable():
    assert set(PRESET_DESCRIPTIONS) == set(TRAIN_PRESETS)
    assert set(BENCH_PRESETS) <= set(TRAIN_PRESETS)
    assert set(CLI_PRESETS) == set(TRAIN_PRESETS) - set(BENCH_PRESETS)
    for name in TRAIN_PRESETS:  # the ablations too: svbrdf-bench and recorded checkpoints resolve them
        assert resolve(name).preset == name


def test_svbrdf_train_offers_its_presets_and_not_the_ablations():
    action = next(a for a in _stage_parser()._actions if a.dest == "preset")
    assert sorted(action.choices) == sorted(CLI_PRESETS)
    help_text = cli.preset_help()
    for name in CLI_PRESETS:
        assert f"\n  {name} " in help_text or f"\n  {name}\n" in help_text
    assert PRESET_DESCRIPTIONS["fast-v1"].split()[0] in help_text
    for name in BENCH_PRESETS:
        assert PRESET_DESCRIPTIONS[name] not in help_text and f"\n  {name}" not in help_text


def test_readme_names_every_preset():
    text = README.read_text(encoding="utf-8")
    for name in TRAIN_PRESETS:
        if name != "tiny":  # for tests only
            assert f"`{name}`" in text, name


def test_parse_settings_reads_json_values_and_keeps_strings():
    import pytest

    from svbrdf.trainer.config import parse_settings

    assert parse_settings(["lr=1e-4", "flash_trend=false", "perceptual=pyramid", "betas=[0.5, 0.9]"]) == \
        {"lr": 1e-4, "flash_trend": False, "perceptual": "pyramid", "betas": [0.5, 0.9]}
    assert parse_settings([]) == {}
    for bad in ("lr", "=1"):
        with pytest.raises(ValueError, match="expected KEY=VALUE"):
            parse_settings([bad])
