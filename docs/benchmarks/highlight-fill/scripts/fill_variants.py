"""The highlight fill judged by the artist measures on the shared sets: every case of the benchmark's selection,
the preview and (with REFINE_ITERS > 0) the default refine, each without the fill, with the fill as one copy
(svbrdf.runtime.highlight_fill.PATCHES False) and as shipped, side by side in one run. The refine is trained once
per case; its final maps are post-processed each way (the trainer's ``postprocess`` wrapped, so every variant
sees the same network output).

    OMP_NUM_THREADS=1 python docs/benchmarks/highlight-fill/scripts/fill_variants.py 'PATTERNS' REFINE_ITERS OUT.json

Records are the benchmark's (svbrdf.trainer.bench.metrics.evaluate), the variant in the record's preset label;
the table is svbrdf.trainer.bench.report.artist_table, plus the per-map RMSE of the synthetic cases. Resumable:
cases already in OUT.json's records are kept.
"""
import json
import os
import sys
import warnings

import numpy as np

import svbrdf.runtime.highlight_fill as F
import svbrdf.runtime.session as S
import svbrdf.trainer.train as T
from svbrdf.trainer.bench import report
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.bench.methods import METHODS, BenchOptions

warnings.simplefilter("ignore")
spec, iters, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
records = json.load(open(out))["records"] if os.path.exists(out) else []
done = {r["case"] for r in records}
cases = load_cases(default_data(), 256, spec)
stash = {}
_post = T.postprocess


def both(maps, photo, **kw):
    """The trainer's post-processing without the fill and with one copy (stashed), and as configured (returned)."""
    stash["no fill"] = _post(maps, photo, **{**kw, "highlight_fill": False})
    F.PATCHES = False
    stash["one copy"] = _post(maps, photo, **kw)
    F.PATCHES = True
    return _post(maps, photo, **kw)


T.postprocess = both


def record(c, method, label, maps, seconds, iterations=None):
    m = evaluate(maps, gt=c.gt, photo=c.photo if c.gt is None else None, centre=c.centre, capture=c.capture)
    fill = maps.meta.get("highlight_fill") or {}
    return {"case": c.name, "kind": c.kind, "method": method, "preset": label, "iterations": iterations,
            "seconds": seconds, "filled": bool(fill.get("filled")), "fill_share": fill.get("share"), **m}


for c in cases:
    if c.name in done:
        continue
    new = []
    for label, fill, patches in (("no fill", False, True), ("one copy", True, False), ("fill", True, True)):
        S.HIGHLIGHT_FILL, F.PATCHES = fill, patches
        pts = []
        METHODS["preview"].run(c, BenchOptions(threads=1, repeats=1), None, pts.append)
        new.append(record(c, "preview", label, pts[0].maps, pts[0].eval_seconds))
    F.PATCHES = True
    if iters > 0:
        pts = []
        opts = BenchOptions(iters=[iters], threads=1, repeats=1, train_overrides={"highlight_fill": True})
        METHODS["finetune"].run(c, opts, "fast", pts.append)
        p = pts[-1]
        for label in ("no fill", "one copy"):
            new.append(record(c, "finetune", label, stash[label], p.train_seconds, p.iterations))
        new.append(record(c, "finetune", "fill", p.maps, p.train_seconds, p.iterations))
    records += new
    with open(out + ".tmp", "w") as f:
        json.dump({"command": "python " + " ".join(sys.argv), "records": records}, f)
    os.replace(out + ".tmp", out)
    print(c.name, [(r["method"], r["preset"], r["filled"], round(r["burn_in"], 3)) for r in new], flush=True)

table = report.artist_table(records)
synth = {}
for (method, label) in sorted({(r["method"], r["preset"]) for r in records}):
    rs = [r for r in records if r["method"] == method and r["preset"] == label and r.get("diffuse_rmse") is not None]
    synth[f"{method} / {label}"] = {k: float(np.mean([r[k] for r in rs])) for k in
                                    ("rerender_rmse", "diffuse_rmse", "roughness_rmse", "specular_rmse",
                                     "normal_rmse")} if rs else {}
with open(out, "w") as f:
    json.dump({"command": "python " + " ".join(sys.argv), "artist": table, "synthetic_rmse": synth,
               "records": records}, f, indent=1)
for r in table:
    print(r["method"], r["preset"], {k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()
                                     if k not in ("method", "preset", "iterations")})
for k, v in synth.items():
    print(k, {a: round(b, 4) for a, b in v.items()})
