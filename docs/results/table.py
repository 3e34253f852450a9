"""The README's table of run time against error, from a ``results.json`` of ``svbrdf-bench``.

    python docs/results/table.py docs/results/results.json > docs/results/table.md

One row per method, preset and iteration count; each column the mean over the cases it applies to (n in the
header): seconds over every case; the real capture's relighting over its views; re-render, grazing and the per-map
errors over the synthetic cases (ground truth); burn-in over the synthetic cases and over the real photos; the base
colour's foreign colour (CIELAB a*b* against the photo, ``runtime/quality/colour_check.py``) over the real photos.
"""

import json
import sys
from collections import defaultdict

import numpy as np

COLUMNS = [  # (header, record key, which cases)
    ("seconds", "seconds", "all"),
    ("capture relit ↓", "capture_rmse", "capture"),
    ("capture SSIM ↑", "capture_ssim", "capture"),
    ("re-render ↓", "rerender_rmse", "synthetic"),
    ("grazing ↓", "grazing_rmse", "synthetic"),
    ("diffuse", "diffuse_rmse", "synthetic"),
    ("specular", "specular_rmse", "synthetic"),
    ("roughness", "roughness_rmse", "synthetic"),
    ("normal °", "normal_angle_deg", "synthetic"),
    ("burn-in synthetic", "burn_in", "synthetic"),
    ("burn-in photos", "burn_in", "photo"),
    ("foreign colour photos", "foreign_colour", "photo"),
]
NAMES = {"baseline": "trivial baseline", "preview": "preview", "refine": "refine (`--refine`, the default)"}


def _fmt(v: float) -> str:
    return "–" if v is None else (f"{v:.3g}" if abs(v) < 100 else f"{v:.0f}")


def table(doc: dict) -> str:
    groups = defaultdict(list)
    for r in doc["records"]:
        groups[(r["method"], r["preset"], r["iterations"])].append(r)
    order = {"baseline": 0, "preview": 1, "refine": 2, "finetune": 3, "scratch": 4}
    keys = sorted(groups, key=lambda k: (order.get(k[0], 9), k[1] or "", k[2] or 0))
    counts = {}
    rows = []
    for key in keys:
        recs = groups[key]
        pick = {"all": recs, "synthetic": [r for r in recs if r["kind"] == "synthetic"],
                "photo": [r for r in recs if r["kind"] == "photo"],
                "capture": [r for r in recs if r.get("capture_rmse") is not None]}
        cells = []
        for _, field, which in COLUMNS:
            vals = [r[field] for r in pick[which] if r.get(field) is not None]
            counts[which] = max(counts.get(which, 0), len(vals))
            mean = float(np.mean(vals)) if vals else None
            cells.append("–" if mean is None else f"{mean:.2f}" if field == "normal_angle_deg" else _fmt(mean))
        method, preset, iters = key
        name = NAMES.get(method) or (f"generator fine-tune (`{preset}`) {iters}" if method == "finetune"
                                     else f"one stage: from scratch (`{preset}`) {iters}" if method == "scratch"
                                     else f"{method} `{preset}` {iters}")
        rows.append(f"| {name} | " + " | ".join(cells) + " |")
    head = [f"{h} (n {counts.get(w, 0)})" if i in (0, 1, 3, 9, 10, 11) else h for i, (h, _, w) in enumerate(COLUMNS)]
    return "\n".join(["| method | " + " | ".join(head) + " |", "|---" * (len(COLUMNS) + 1) + "|", *rows])


if __name__ == "__main__":
    with open(sys.argv[1], encoding="utf-8") as f:
        print(table(json.load(f)))
