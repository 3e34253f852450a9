"""The paper's fine-tunes beside ``fast`` (issue 27, item 5) on the 4 tuning cases, at the counts a CPU allows:
means per preset and iteration count over the cases every run has, from ``svbrdf-bench`` results files.

    python docs/benchmarks/refine-detail/scripts/side_by_side.py RESULTS.json [RESULTS.json ...] > OUT.md

``finetune`` records of every file are grouped by (preset, iterations); only the cases present in every file
count (the artist run's ``fast`` records hold all 59 cases).
"""
import json
import sys

import numpy as np

KEYS = [("rerender_rmse", "re-render RMSE"), ("diffuse_rmse", "diffuse"), ("specular_rmse", "specular"),
        ("roughness_rmse", "roughness"), ("normal_angle_deg", "normal °"), ("grazing_rmse", "grazing RMSE"),
        ("grazing_hp_corr", "grazing detail corr"), ("normal_slope_corr", "normal slope corr"),
        ("burn_in", "burn-in"), ("train_seconds", "train s")]
files = [[r for r in json.load(open(p))["records"] if r["method"] == "finetune" and not r.get("truncated")]
         for p in sys.argv[1:]]
cases = set.intersection(*({r["case"] for r in recs} for recs in files))
groups = {}
for recs in files:
    for r in recs:
        if r["case"] in cases:
            groups.setdefault((r["preset"], r["iterations"]), []).append(r)
print(f"{len(cases)} cases: " + ", ".join(sorted(c.split('/')[-1][:28] for c in cases)))
print()
print("| preset | iterations | " + " | ".join(h for _, h in KEYS) + " |")
print("|---" * (len(KEYS) + 2) + "|")
for (preset, it), recs in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1])):
    cells = []
    for k, _ in KEYS:
        vals = [r[k] for r in recs if r.get(k) is not None]
        cells.append(f"{np.mean(vals):.4f}" if vals else "-")
    print(f"| {preset} | {it} | " + " | ".join(cells) + " |")
