"""Does the trainer's own label-free evaluation (render_l1 of the photo on held-out tiles, ``evals`` of a
drift_probe.py run) pick the right stopping point? For each (material, variant): stop at the evaluated iteration
count (150 / 300 / 600; 0 when asked) whose nearest render_l1 is lowest, against always 150 and the oracle.

    python docs/benchmarks/refine-detail/scripts/stop_rule_probe.py docs/benchmarks/refine-detail/drift_procedural.jsonl
"""
import json
import sys

import numpy as np

rs = [json.loads(line) for line in open(sys.argv[1])]
runs = {}
for r in rs:
    runs.setdefault((r["material"], r["variant"]), {})[r["iterations"]] = r
for variant in sorted({v for _, v in runs}):
    fixed, chosen, best, picks = [], [], [], []
    for (m, v), pts in runs.items():
        if v != variant or 600 not in pts:
            continue
        evals = pts[600]["evals"]

        def l1(it):
            return min(evals, key=lambda e: abs(e["step"] - it))["render_l1"]
        pick = min((150, 300, 600), key=l1)
        picks.append(pick)
        fixed.append(pts[150]["rerender_rmse"])
        chosen.append(pts[pick]["rerender_rmse"])
        best.append(min(pts[i]["rerender_rmse"] for i in (150, 300, 600)))
    print(f"{variant:8s} n={len(fixed)} always-150 {np.mean(fixed):.4f}  render_l1 pick {np.mean(chosen):.4f} "
          f"(picks {picks})  oracle {np.mean(best):.4f}")
