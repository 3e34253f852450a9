"""One table of the highlight fill's runs (fill_variants.py outputs, merged): the artist measures
(svbrdf.trainer.bench.report.artist_table) and the synthetic cases' per-map RMSE, per method and variant.

    python docs/benchmarks/highlight-fill/scripts/fill_table.py RUN1.json [RUN2.json ...] > OUT.md
"""
import json
import sys

import numpy as np

from svbrdf.trainer.bench.report import ARTIST_HEADS, _fmt, artist_table

records = [r for path in sys.argv[1:] for r in json.load(open(path))["records"]]
COLUMNS = [(k, h) for k, h in ARTIST_HEADS.items() if k not in ("seconds", "normal_angle_deg")]
RMSE = ("rerender_rmse", "diffuse_rmse", "roughness_rmse", "specular_rmse")
cases = {r["case"] for r in records}
filled = {r["case"] for r in records if r["filled"] and r["method"] == "finetune"}
print(f"{len(cases)} cases; the fill ran on {len(filled)} of them (refine), "
      f"{len({r['case'] for r in records if r['filled'] and r['method'] == 'preview'})} (preview)")
print()
print("| method | variant | " + " | ".join(h for _, h in COLUMNS) + " |")
print("|---" * (len(COLUMNS) + 2) + "|")
for row in artist_table(records):
    print(f"| {row['method']} | {row['preset']} | " + " | ".join(_fmt(row.get(k)) for k, _ in COLUMNS) + " |")
print()
print("Synthetic cases (truth known), mean RMSE; the cases where the fill ran in brackets:")
print()
print("| method | variant | " + " | ".join(RMSE) + " |")
print("|---" * (len(RMSE) + 2) + "|")
for method in ("preview", "finetune"):
    for label in ("no fill", "one copy", "fill"):
        rs = [r for r in records if r["method"] == method and r["preset"] == label and r.get("diffuse_rmse") is not None]
        if not rs:
            continue
        fs = [r for r in rs if r["case"] in filled]
        cells = [f"{np.mean([r[k] for r in rs]):.4f} ({np.mean([r[k] for r in fs]):.4f})" for k in RMSE]
        print(f"| {method} | {label} | " + " | ".join(cells) + f" |")
