"""Why the joins of the photos that miss the 1.2 criterion carry more energy than natural pairs (issue 28).

For each (photo, map) over 1.2 in results.json: the energy across the repaired joins against (a) the natural
neighbour pairs (the join score) and (b) the photo's own gradient at the joins' sources, the repair's target
(svbrdf.runtime.tileable._guidance). (b) near 1 means the join is as smooth as the material is where it was cut.

    OMP_NUM_THREADS=1 python docs/benchmarks/tileable/scripts/join_diagnosis.py
"""
import json
import warnings
from pathlib import Path

import numpy as np

warnings.simplefilter("ignore")
ROOT = Path(__file__).resolve().parents[4]
DATA = ROOT.parent / "shared" / "data"
import svbrdf.runtime.tileable as T
from svbrdf.runtime.session import estimate, load_session
s = load_session(threads=1)
doc = json.loads((ROOT / "docs/benchmarks/tileable/results.json").read_text())
fails = {}
for c in doc["cases"]:
    bad = [n for n, v in c["methods"]["cut"]["join"].items() if v is not None and v > 1.2]
    if bad:
        fails[c["photo"]] = bad
for p, names in fails.items():
    m = estimate(DATA / p, s)
    t, src = T.make_tileable(m, return_source=True)
    for n in names:
        a = getattr(t, n).astype(np.float32); inp = getattr(m, n).astype(np.float32)
        je, ge, ne = [], [], []
        for axis, step in ((1, (0, 1)), (0, (1, 0))):
            nxt = np.roll(src, -1, axis=axis)
            nat = np.all(nxt - src == np.array(step), axis=-1)
            e = ((np.roll(a, -1, axis=axis) - a) ** 2).sum(-1)
            g = (T._guidance(a, src, inp, axis) ** 2).sum(-1)
            je.append(e[~nat]); ge.append(g[~nat]); ne.append(e[nat])
        je, ge, ne = map(np.concatenate, (je, ge, ne))
        print(p.split("/")[-1], n, "join/natural", round(je.mean() / ne.mean(), 2), "join/source-gradient", round(je.mean() / ge.mean(), 2), "source-gradient/natural", round(ge.mean() / ne.mean(), 2))
