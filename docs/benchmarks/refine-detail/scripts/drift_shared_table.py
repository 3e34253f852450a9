"""The drift table on the shared subset from svbrdf-bench result folders (one row per variant and iteration count).

    python docs/benchmarks/refine-detail/scripts/drift_shared_table.py LABEL=runs/bench/FOLDER [LABEL=FOLDER ...]

Means over the cases of each kind: synthetic re-render RMSE (10 lights), per-map RMSE, grazing RMSE and burn-in;
for the real photos of a multi-view capture, the relit RMSE and SSIM at the other views.
"""
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

SYNTH = ("rerender_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "grazing_rmse", "burn_in")
CAPTURE = ("capture_rmse", "capture_ssim")


def rows(label, folder):
    recs = json.loads((Path(folder) / "results.json").read_text())["records"]
    by_it = defaultdict(lambda: defaultdict(list))
    for r in recs:
        keys = SYNTH if r["kind"] == "synthetic" else CAPTURE
        for k in keys:
            if r.get(k) is not None:
                by_it[r["iterations"]][k].append(r[k])
    out = []
    for it in sorted(by_it):
        m = by_it[it]
        cells = [f"{np.mean(m[k]):.4f}" if m[k] else "-" for k in SYNTH + CAPTURE]
        n = f"{len(m['rerender_rmse'])}/{len(m['capture_rmse'])}"
        out.append(f"| {label} | {it} | " + " | ".join(cells) + f" | {n} |")
    return out


def main(argv):
    print("| variant | it | re-render (synthetic) | diffuse | specular | roughness | grazing | burn-in | capture relit "
          "RMSE | capture SSIM | n synthetic/capture |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for item in argv:
        label, folder = item.split("=", 1)
        print("\n".join(rows(label, folder)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
