"""Replay the ``quality="auto"`` stopping rule over recorded fine-tunes, for a grid of its two settings.

Run as ``python -m svbrdf.trainer.bench.early_stop RESULTS_JSON [--windows 2,3,4,5] [--tols 0,0.01,0.02,0.05]``
on the ``results.json`` of an ``svbrdf-bench`` run whose ``finetune`` runs were evaluated at every evaluation
step of the trainer (``--iters 0,50,100,...`` with the preset's ``eval_every``): each run records its label-free
evaluation history (``run.evals``), so any rule setting can be replayed without training again. For each
(window, tolerance): the mean training-time saving over the cases (``1 - t_stop / t_run``, 0 when the rule never
fires), the mean and worst error ratio (error at the stop / error at the end of the run) and how many runs it
stopped. The rule itself is :func:`svbrdf.trainer.train.plateau_reached`, the same function the trainer calls.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence

import numpy as np

from svbrdf.trainer.train import plateau_reached


def replay(records: Sequence[Mapping[str, Any]], window: int, tol: float, preset: Optional[str] = None,
           metric: str = "rerender_rmse") -> Dict[str, Any]:
    """Saving and error price of the rule (``window``, ``tol``) on the recorded ``finetune`` runs."""
    runs: Dict[str, Dict[str, Any]] = {}
    for r in records:
        if r["method"] != "finetune" or (preset and r.get("preset") != preset) or r.get(metric) is None:
            continue
        entry = runs.setdefault(r["case"], {"run": r.get("run") or {}, "error": {}})
        entry["error"][r["iterations"]] = r[metric]
    savings: List[float] = []
    ratios: List[float] = []
    fired = 0
    for entry in runs.values():
        evals, total = entry["run"].get("evals"), entry["run"].get("run_train_seconds")
        if not evals or not total:
            continue
        err, last = entry["error"], max(entry["error"])
        stop = next((e for k, e in enumerate(evals)
                     if plateau_reached([v["render_l1"] for v in evals[:k + 1]], window, tol)), None)
        if stop is None or stop["step"] not in err:
            savings.append(0.0)
            ratios.append(1.0)
            continue
        fired += 1
        savings.append(1.0 - stop["train_seconds"] / total)
        ratios.append(err[stop["step"]] / err[last])
    if not savings:
        return {"window": window, "tol": tol, "runs": 0}
    return {"window": window, "tol": tol, "runs": len(savings), "fired": fired, "saving": float(np.mean(savings)),
            "error_ratio_mean": float(np.mean(ratios)), "error_ratio_max": float(np.max(ratios))}


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.bench.early_stop", description=__doc__.split("\n\n")[0])
    p.add_argument("results", type=Path, help="results.json of an svbrdf-bench run with finetune evaluations")
    p.add_argument("--windows", default="2,3,4,5", help="comma list of plateau_window values")
    p.add_argument("--tols", default="0,0.01,0.02,0.05,0.1", help="comma list of plateau_render_tol values")
    p.add_argument("--preset", default=None, help="only the finetune runs of this preset")
    p.add_argument("--markdown", type=Path, default=None, help="also write the table to this file")
    args = p.parse_args(argv)
    try:
        records = json.loads(args.results.read_text())["records"]
        windows = [int(v) for v in args.windows.split(",")]
        tols = [float(v) for v in args.tols.split(",")]
    except (OSError, ValueError, KeyError) as e:
        print(f"early_stop: error: {args.results}: {e}", file=sys.stderr)
        return 2
    rows = [replay(records, w, t, args.preset) for w in windows for t in tols]
    if not any(r["runs"] for r in rows):
        print(f"early_stop: error: {args.results}: no finetune run with a recorded evaluation history",
              file=sys.stderr)
        return 2
    lines = ["| window | tol | runs | stopped | time saved | error ratio mean | error ratio worst |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['window']} | {r['tol']:g} | {r['runs']} | {r['fired']} | {100 * r['saving']:.0f} % | "
                     f"{r['error_ratio_mean']:.3f} | {r['error_ratio_max']:.3f} |")
    text = "\n".join(lines) + "\n"
    print(text, end="")
    if args.markdown:
        args.markdown.write_text(f"```\npython -m svbrdf.trainer.bench.early_stop "
                                 f"{' '.join(sys.argv[1:] if argv is None else argv)}\n```\n\n" + text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
