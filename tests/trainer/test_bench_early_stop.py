"""svbrdf.trainer.bench.early_stop: replaying the stopping rule over recorded evaluation histories."""

import json

import pytest

from svbrdf.trainer.bench import early_stop


def _records(l1, errors, seconds_per_eval=10.0):
    evals = [{"step": 50 * (k + 1), "train_seconds": seconds_per_eval * (k + 1), "render_l1": v}
             for k, v in enumerate(l1)]
    run = {"evals": evals, "run_train_seconds": seconds_per_eval * len(l1)}
    return [{"case": "c", "method": "finetune", "preset": "fast", "iterations": 50 * k, "rerender_rmse": e,
             "run": run} for k, e in enumerate(errors)]


def test_replay_saving_and_price():
    # evaluations at 50..300; window 2, tol 0: the best of (0.11, 0.12) at step 150 is not below 0.10
    recs = _records([0.10, 0.11, 0.12, 0.09, 0.09, 0.09], [0.3, 0.2, 0.22, 0.24, 0.2, 0.2, 0.2])
    r = early_stop.replay(recs, window=2, tol=0.0)
    assert r["fired"] == 1 and r["saving"] == pytest.approx(1 - 30 / 60)
    assert r["error_ratio_mean"] == pytest.approx(0.24 / 0.2)
    assert early_stop.replay(recs, window=6, tol=0.0)["saving"] == 0.0  # never enough evaluations


def test_cli_table_and_errors(tmp_path, capsys):
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"records": _records([0.1, 0.1, 0.1], [0.3, 0.2, 0.2, 0.2])}))
    assert early_stop.main([str(path), "--windows", "1", "--tols", "0"]) == 0
    assert "| 1 | 0 | 1 | 1 | 33 % |" in capsys.readouterr().out
    path.write_text(json.dumps({"records": []}))
    assert early_stop.main([str(path)]) == 2
    assert early_stop.main([str(tmp_path / "missing.json")]) == 2
