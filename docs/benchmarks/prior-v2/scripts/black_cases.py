"""The specular error on the shared sets' near-black materials apart from the rest, per method and count, from
benchmark records (``svbrdf-bench ... --out DIR``: DIR/results.json): what `black_share` (the v2 run from 18589,
``../chunks/README.md``) is meant to change. A case is near-black when its true base colour's mean is below
0.01 linear (read from the shared sets' ground truth as the bench reads it: 29 of the 38 synthetic cases, most of
them with a dielectric specular of 0.043); the normal angle, slope correlation, re-render and grazing RMSE of the same two groups too (near-black / other).

    python docs/benchmarks/prior-v2/scripts/black_cases.py RESULTS.json [RESULTS.json ...]
"""
import json, sys
from collections import defaultdict
import numpy as np
from svbrdf.trainer.bench.datasets import find_cases, read_gt

black = {c.name for c in find_cases("../shared/data") if c.kind == "gt"
         and float(read_gt(c.path, c.format)[0].diffuse.mean()) < 0.01}
rows = defaultdict(lambda: {"black": [], "other": []})
for path in sys.argv[1:]:
    for r in json.load(open(path))["records"]:
        if r.get("kind") == "synthetic" and r.get("specular_rmse") is not None:
            key = (r["method"], r.get("iterations"))
            rows[key]["black" if r["case"] in black else "other"].append(r)
print(f"near-black cases: {len(black)}")


def mean(records, key):
    return np.mean([r[key] or 0.0 for r in records])


for (method, it), v in sorted(rows.items(), key=lambda kv: str(kv[0])):
    b, o = v["black"], v["other"]
    print(f"{method} @{it}: specular RMSE near-black {mean(b, 'specular_rmse'):.4f} (n {len(b)}), "
          f"other {mean(o, 'specular_rmse'):.4f} (n {len(o)}); normal angle {mean(b, 'normal_angle_deg'):.2f} / "
          f"{mean(o, 'normal_angle_deg'):.2f} deg, slope corr {mean(b, 'normal_slope_corr'):.3f} / "
          f"{mean(o, 'normal_slope_corr'):.3f}; re-render {mean(b, 'rerender_rmse'):.4f} / "
          f"{mean(o, 'rerender_rmse'):.4f}, grazing {mean(b, 'grazing_rmse'):.4f} / {mean(o, 'grazing_rmse'):.4f}")
