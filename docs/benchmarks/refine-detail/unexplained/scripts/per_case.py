"""Per-case comparison of two benchmark runs at one count: which synthetic cases' re-render and which photos'
burn-in got better or worse, and by how much.

    python docs/benchmarks/refine-detail/unexplained/scripts/per_case.py BEFORE/results.json AFTER/results.json [ITERS]
"""
import json, sys
import numpy as np


def records(path, iters):
    return {r["case"]: r for r in json.load(open(path))["records"] if r.get("iterations") == iters}


before, after = sys.argv[1], sys.argv[2]
iters = int(sys.argv[3]) if len(sys.argv) > 3 else 150
a, b = records(before, iters), records(after, iters)
groups = {"synthetic re-render": ([c for c in a if a[c]["kind"] == "synthetic" and c in b], "rerender_rmse", 1e-4),
          "synthetic base colour": ([c for c in a if a[c]["kind"] == "synthetic" and c in b], "diffuse_rmse", 1e-4),
          "photos burn-in": ([c for c in a if a[c]["kind"] == "photo" and a[c].get("capture_rmse") is None and c in b],
                             "burn_in", 1e-3),
          "capture relit": ([c for c in a if a[c].get("capture_rmse") is not None and c in b], "capture_rmse", 1e-4)}
for name, (cases, key, tol) in groups.items():
    d = np.array([b[c][key] - a[c][key] for c in cases])
    worst = sorted(zip(d, cases), reverse=True)[:3]
    listed = ", ".join(f"{c.split('/')[-1]} {a[c][key]:.4f} -> {b[c][key]:.4f}" for _, c in worst)
    print(f"{name} ({key}, n {len(cases)}): mean {np.mean([a[c][key] for c in cases]):.4f} -> "
          f"{np.mean([b[c][key] for c in cases]):.4f}; better {(d < -tol).sum()}, worse {(d > tol).sum()}; "
          f"worst {listed}")
