"""Means of ``flat_probe.py``'s per-case results over the groups of the artist measures (synthetic cases with
ground truth, the Henzler photos, the bath_tile capture), several JSON files merged.

    python docs/benchmarks/refine-detail/flat-input/scripts/flat_table.py A.json [B.json ...]
"""
import json, sys

import numpy as np

cases = {}
for f in sys.argv[1:]:
    cases.update(json.load(open(f))["cases"])
groups = {"synthetic": lambda n: "henzler" not in n and "guo" not in n, "photos": lambda n: "henzler" in n,
          "capture": lambda n: "guo" in n}
cols = [("synthetic", "rerender_rmse"), ("synthetic", "diffuse_rmse"), ("synthetic", "specular_rmse"),
        ("synthetic", "roughness_rmse"), ("synthetic", "normal_angle_deg"), ("synthetic", "grazing_rmse"),
        ("synthetic", "detail_diffuse"), ("synthetic", "detail_roughness"), ("synthetic", "burn_in"),
        ("photos", "burn_in"), ("capture", "capture_rmse"), ("capture", "capture_ssim"), ("capture", "burn_in")]
variants = list(next(iter(cases.values())))
print("| variant | " + " | ".join(f"{k} {g}" for g, k in cols) + " |")
print("|---" * (len(cols) + 1) + "|")
for v in variants:
    vals = []
    for g, k in cols:
        xs = [c[v][k] for n, c in cases.items() if groups[g](n) and c[v].get(k) is not None]
        vals.append(f"{np.mean(xs):.4f} ({len(xs)})" if xs else "-")
    print(f"| {v} | " + " | ".join(vals) + " |")
