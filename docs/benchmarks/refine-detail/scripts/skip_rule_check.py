"""What ``--quality auto``'s skip rule (:func:`svbrdf.trainer.bench.report.skip_rule_passes`: the preview's
input-flash RMSE and the network's burn-in at or below the thresholds of :mod:`svbrdf.runtime.preview_check`) does
with a stage one, from its preview and refine records: per group (synthetic re-render, real-capture relit, photos' input-light RMSE) how many cases it skips, the
preview's and the refine's error on the skipped and on the refined ones, and the mean error of ``auto`` (the
preview where skipped, the refine elsewhere) beside always refining and never refining.

    python docs/benchmarks/refine-detail/scripts/skip_rule_check.py PREVIEW/results.json REFINE/results.json [ITERS]
"""
import json
import sys

import numpy as np

from svbrdf.runtime.preview_check import SKIP_REFINE_BURN_IN, SKIP_REFINE_RMSE
from svbrdf.trainer.bench.report import skip_rule_passes

it = int(sys.argv[3]) if len(sys.argv) > 3 else 150
preview = {r["case"]: r for r in json.load(open(sys.argv[1]))["records"] if r["method"] == "preview"}
refine = {r["case"]: r for r in json.load(open(sys.argv[2]))["records"]
          if r["method"] == "finetune" and r["iterations"] == it}
groups = {"synthetic": ("rerender_rmse", []), "capture": ("capture_rmse", []), "photo": ("input_rmse", [])}
for case, p in preview.items():
    if case not in refine:
        continue
    group = "synthetic" if p["kind"] == "synthetic" else "capture" if p.get("capture_rmse") is not None else "photo"
    metric, rows = groups[group]
    rows.append((skip_rule_passes(p), p[metric], refine[case][metric]))
print(f"thresholds: input-flash RMSE <= {SKIP_REFINE_RMSE}, burn-in <= {SKIP_REFINE_BURN_IN}; refine at {it}")
print("| group (error) | cases | skipped | skipped: preview / refine | refined: preview / refine | auto | always refine | never |")
print("|---|---|---|---|---|---|---|---|")
for group, (metric, rows) in groups.items():
    if not rows:
        continue
    v = np.array(rows, dtype=float)
    s = v[:, 0] > 0
    pair = lambda m: f"{v[m, 1].mean():.4f} / {v[m, 2].mean():.4f}" if m.any() else "–"  # noqa: E731
    print(f"| {group} ({metric}) | {len(v)} | {int(s.sum())} | {pair(s)} | {pair(~s)} | "
          f"{np.where(s, v[:, 1], v[:, 2]).mean():.4f} | {v[:, 2].mean():.4f} | {v[:, 1].mean():.4f} |")
