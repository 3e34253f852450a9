"""Item 3's stop rule on recorded shared-set fine-tunes: per case the true error at 0 / 150 / 300 / 600 iterations,
the count the label-free held-out-tile photo error (``eval/render_l1``) would pick among 150 / 300 / 600, and where
the ``quality="auto"`` plateau rule fired (its true error interpolated linearly between the evaluated counts: the
bench measures only those); means per error kind (synthetic re-render RMSE, real-capture relit RMSE).

    python docs/benchmarks/refine-detail/scripts/stop_rule_shared.py RESULTS.json   # a run with --iters 0,150,300,600
"""
import json
import sys
from collections import defaultdict

import numpy as np

COUNTS = (150, 300, 600)


def at(true, step):
    """True error at ``step`` (linear between the evaluated counts; the first count below it)."""
    if step <= COUNTS[0]:
        return true[COUNTS[0]]
    for a, b in zip(COUNTS, COUNTS[1:]):
        if a <= step <= b:
            return true[a] + (true[b] - true[a]) * (step - a) / (b - a)
    return true[COUNTS[-1]]


runs = defaultdict(dict)
for r in json.load(open(sys.argv[1]))["records"]:
    if r["method"] == "finetune":
        runs[r["case"]][r["iterations"]] = r
rows = defaultdict(list)
print("| case | error | 0 | 150 | 300 | 600 | render_l1 picks | plateau stop at | error there (interpolated) |")
print("|---|---|---|---|---|---|---|---|---|")
for case, d in sorted(runs.items()):
    metric = "rerender_rmse" if d[600].get("rerender_rmse") is not None else "capture_rmse"
    l1 = {e["step"]: e["render_l1"] for e in d[600]["run"]["evals"]}
    pick = min(COUNTS, key=lambda k: l1[k])
    true = {k: d[k][metric] for k in (0, *COUNTS)}
    stop = (d[600]["run"].get("plateau") or {}).get("step", 600)
    rows[metric].append([true[0], true[150], true[300], true[600], true[pick], at(true, stop), min(true[k] for k in COUNTS)])
    print(f"| {case.split('/')[-1][:28]} | {metric} | " + " | ".join(f"{true[k]:.4f}" for k in (0, *COUNTS)) +
          f" | {pick} | {stop} | {at(true, stop):.4f} |")
print()
print("| error | n | preview (0) | always 150 | always 300 | always 600 | render_l1 pick | plateau stop | oracle of 150/300/600 |")
print("|---|---|---|---|---|---|---|---|---|")
for metric, v in rows.items():
    m = np.mean(v, axis=0)
    print(f"| {metric} | {len(v)} | " + " | ".join(f"{x:.4f}" for x in m) + " |")
