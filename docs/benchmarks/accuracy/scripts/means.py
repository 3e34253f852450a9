"""Means of a benchmark's records to four decimals, per kind, method, preset and iteration count (the criteria
tables of the README are read off these; the rounded tables come from ``svbrdf.trainer.tools.accuracy_tables``).

    python docs/benchmarks/accuracy/scripts/means.py docs/benchmarks/accuracy/trend/results.json
"""
import json
import sys
from collections import defaultdict

import numpy as np

KEYS = ("rerender_rmse", "input_rmse", "burn_in", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg")
doc = json.load(open(sys.argv[1]))
groups = defaultdict(lambda: defaultdict(list))
for r in doc["records"]:
    key = (r["kind"], r["method"], r.get("preset") or "-", r.get("iterations"))
    for k in KEYS:
        if r.get(k) is not None:
            groups[key][k].append(r[k])
print("kind method preset iterations n " + " ".join(KEYS))
for key in sorted(groups, key=str):
    g = groups[key]
    print(*key, len(g["burn_in"]), " ".join(f"{np.mean(g[k]):.4f}" if g[k] else "-" for k in KEYS))
