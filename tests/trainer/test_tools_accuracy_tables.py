"""The accuracy tables tool: means per run over hand-made records, tuning cases left out, ablation rows."""

import json

import pytest

from svbrdf.trainer.tools import accuracy_tables as at


def _rec(case, method, preset, it, err, burn, kind="synthetic"):
    r = {"case": case, "kind": kind, "method": method, "preset": preset, "iterations": it, "burn_in": burn,
         "burn_diffuse": burn, "burn_specular": 0.0, "burn_roughness": 0.0, "burn_normal": 0.0}
    if kind == "synthetic":
        r.update(rerender_rmse=err, diffuse_rmse=err, specular_rmse=err, roughness_rmse=err, normal_angle_deg=10 * err)
    else:
        r.update(input_rmse=err)
    return r


def _doc():
    recs = [_rec("a", "finetune", "fast", 600, 0.1, 0.2), _rec("tune_b", "finetune", "fast", 600, 0.3, 0.6),
            _rec("a", "baseline", None, None, 0.5, 0.0), _rec("tune_b", "baseline", None, None, 0.7, 0.0),
            _rec("p", "finetune", "fast", 600, 0.2, 0.4, kind="photo")]
    return {"records": recs, "cases": [{"name": "a", "gt_burn_in": 0.1}, {"name": "tune_b", "gt_burn_in": 0.3}]}


def test_tables(tmp_path):
    path = tmp_path / "results.json"
    path.write_text(json.dumps(_doc()))
    out = tmp_path / "tables.md"
    assert at.main([str(path), "--tuning", "tune_*", "--ablation", f"x={path}:finetune:fast:600",
                    "--ablation", f"b={path}:baseline:-:-", "--ablation", f"t={path}:finetune:fast:600:tune_*",
                    "--out", str(out)]) == 0
    text = out.read_text()
    assert "| finetune fast, 600 it | 2 | 0.200 | 0.400 |" in text  # mean over both cases
    assert "| finetune fast, 600 it | 1 | 0.100 | 0.200 |" in text  # the tuning case left out
    assert "| ground truth | 2 | 0 | 0.200 |" in text and "| ground truth | 1 | 0 | 0.100 |" in text
    assert "| x | 2 | 0.200 |" in text and "| b | 2 | 0.600 |" in text and "| t | 1 | 0.300 |" in text
    assert "| finetune fast, 600 it | 1 | 0.200 | - | 0.400 |" in text  # the photo, no fall-off run given
    with pytest.raises(SystemExit):
        at.main([str(path), "--ablation", f"y={path}:scratch:fast:600", "--out", str(out)])
