"""How much room the cuts get (runtime.tileable._zone), checked on data the benchmark does not report on: 8 held-out
procedural materials (seed 4242, 384 px, their ground-truth maps) and the bundled example's preview. Prints, per set
and for the zone of ``o`` columns (today's) and a wider one of ``2 o - 4`` (the cut up to 4 columns from the wrap),
the geometric mean over diffuse, roughness and normal of the join score of the raw cuts and of the repaired result;
then the medians. The wider zone wins here (0.87 vs 0.98 raw) but lost on the shared photos, whose preview maps
have network border pixels that the wider zone keeps (see ``_zone``'s docstring).

    OMP_NUM_THREADS=1 python docs/benchmarks/tileable/scripts/zone_check.py
"""
import warnings
from pathlib import Path

import numpy as np
import torch

import svbrdf.runtime.tileable as T
from svbrdf.runtime.session import estimate, load_session
from svbrdf.trainer.procedural import sample_materials
from svbrdf.trainer.train import to_maps

warnings.simplefilter("ignore")
ROOT = Path(__file__).resolve().parents[4]
ZONES = {"o": T._zone, "2o - 4": lambda o: max(1, 2 * o - 4)}


def gmean(values):
    v = [x for x in values if x]
    return float(np.exp(np.mean(np.log(v))))


def main():
    mats, names = sample_materials(8, 384, torch.Generator().manual_seed(4242))
    sets = [(names[i], to_maps(mats[i:i + 1])) for i in range(8)]
    sets.append(("example", estimate(ROOT / "runtime/examples/carved_wood.png", load_session(threads=1))))
    res = {k: [] for k in ZONES}
    today = T._zone
    try:
        for name, m in sets:
            for label, zone in ZONES.items():
                T._zone = zone
                raw, src = T.make_tileable(m, repair=False, return_source=True)
                fixed = T.make_tileable(m)
                r = gmean(T.cut_scores(getattr(raw, n), src)["ratio"] for n in ("diffuse", "roughness", "normal"))
                f = gmean(T.cut_scores(getattr(fixed, n), src)["ratio"] for n in ("diffuse", "roughness", "normal"))
                res[label].append((r, f))
                print(f"{name:14s} zone {label:7s} raw {r:.2f} repaired {f:.2f}", flush=True)
    finally:
        T._zone = today
    for label, v in res.items():
        print(f"zone {label}: median raw {np.median([a for a, _ in v]):.2f}, repaired {np.median([b for _, b in v]):.2f}")


if __name__ == "__main__":
    main()
