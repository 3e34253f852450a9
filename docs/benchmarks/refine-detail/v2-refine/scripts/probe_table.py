"""Markdown table of a ``refine_probe.py`` JSON (means over its materials, one row per variant and count).

    python docs/benchmarks/refine-detail/v2-refine/scripts/probe_table.py docs/benchmarks/refine-detail/v2-refine/c2_procedural.json
"""
import json
import sys

K = {"rerender_rmse": "re-render", "input_rmse": "input light", "diffuse_rmse": "diffuse", "specular_rmse": "specular",
     "roughness_rmse": "roughness", "normal_angle_deg": "normal °", "normal_slope_corr": "slope corr",
     "detail_normal": "detail normal", "grazing_rmse": "grazing", "burn_in": "burn-in"}
print("| variant | " + " | ".join(K.values()) + " |")
print("|---" * (len(K) + 1) + "|")
for name, row in json.load(open(sys.argv[1])).items():
    print(f"| {name} | " + " | ".join(f"{row[k]:.4f}" for k in K) + " |")
