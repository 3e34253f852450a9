"""The specular error on the shared sets' near-black materials apart from the rest, per method and count, from
benchmark records (``svbrdf-bench ... --out DIR``: DIR/results.json): what `black_share` (the v2 run from 18589,
``../chunks/README.md``) is meant to change. A case is near-black when its true base colour's mean is below
0.01 linear (read from the shared sets' ground truth as the bench reads it: 29 of the 38 synthetic cases, most of
them with a dielectric specular of 0.043); the normal angle, slope correlation, re-render and grazing RMSE of the
same two groups too (near-black / other). ``black_level_probe.py`` imports :func:`darkness` for the same split.

    python docs/benchmarks/prior-v2/scripts/black_cases.py RESULTS.json [RESULTS.json ...]
"""
import json
import sys
from collections import defaultdict

import numpy as np

from svbrdf.trainer.bench.datasets import find_cases, read_gt

DATA = "../shared/data"
#: A synthetic case is near-black below this mean linear base colour (the procedural dielectrics' darkest).
NEAR_BLACK = 0.01


def darkness(data: str = DATA) -> dict:
    """{found ground-truth case: True when it is near-black} for every synthetic case under ``data``."""
    return {c: float(read_gt(c.path, c.format)[0].diffuse.mean()) < NEAR_BLACK
            for c in find_cases(data) if c.kind == "gt"}


def mean(records, key):
    """Mean of ``key`` over the records that have it (nan when none does)."""
    values = [r[key] for r in records if r.get(key) is not None]
    return float(np.mean(values)) if values else float("nan")


def main(paths) -> None:
    black = {c.name for c, dark in darkness().items() if dark}
    rows = defaultdict(lambda: {"black": [], "other": []})
    for path in paths:
        for r in json.load(open(path))["records"]:
            if r.get("kind") == "synthetic" and r.get("specular_rmse") is not None:
                key = (r["method"], r.get("iterations"))
                rows[key]["black" if r["case"] in black else "other"].append(r)
    print(f"near-black cases: {len(black)}")
    for (method, it), v in sorted(rows.items(), key=lambda kv: str(kv[0])):
        b, o = v["black"], v["other"]
        print(f"{method} @{it}: specular RMSE near-black {mean(b, 'specular_rmse'):.4f} (n {len(b)}), "
              f"other {mean(o, 'specular_rmse'):.4f} (n {len(o)}); normal angle {mean(b, 'normal_angle_deg'):.2f} / "
              f"{mean(o, 'normal_angle_deg'):.2f} deg, slope corr {mean(b, 'normal_slope_corr'):.3f} / "
              f"{mean(o, 'normal_slope_corr'):.3f}; re-render {mean(b, 'rerender_rmse'):.4f} / "
              f"{mean(o, 'rerender_rmse'):.4f}, grazing {mean(b, 'grazing_rmse'):.4f} / {mean(o, 'grazing_rmse'):.4f}")


if __name__ == "__main__":
    main(sys.argv[1:])
