"""The preview's post-processing steps judged by the artist measures: the flash-trend removal and the single
specular level (svbrdf.runtime.session.FLASH_TREND / UNIFORM_SPECULAR) switched off one at a time, every case of
the benchmark's selection, the artist table of each variant side by side (same cases, same run).

    OMP_NUM_THREADS=1 python docs/benchmarks/artist/scripts/preview_variants.py 'PATTERNS' OUT.json

Records are the benchmark's (svbrdf.trainer.bench.metrics.evaluate, report.artist_table); the variant is the
record's preset label.
"""
import json
import sys
import warnings

import svbrdf.runtime.session as S
from svbrdf.trainer.bench import report
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.bench.methods import METHODS, BenchOptions

warnings.simplefilter("ignore")
spec, out = sys.argv[1], sys.argv[2]
VARIANTS = {"default": (True, True), "no-flash-trend": (False, True), "per-pixel-specular": (True, False),
            "neither": (False, False)}
cases = load_cases(default_data(), 256, spec)
opts = BenchOptions(threads=1, repeats=1)
records = []
for c in cases:
    for label, (trend, level) in VARIANTS.items():
        S.FLASH_TREND, S.UNIFORM_SPECULAR = trend, level
        pts = []
        METHODS["preview"].run(c, opts, None, pts.append)
        m = evaluate(pts[0].maps, gt=c.gt, photo=c.photo if c.gt is None else None, centre=c.centre,
                     capture=c.capture)
        records.append({"case": c.name, "kind": c.kind, "method": "preview", "preset": label, "iterations": None,
                        "seconds": pts[0].eval_seconds, **m})
    print(c.name, flush=True)
table = report.artist_table(records)
with open(out, "w") as f:
    json.dump({"command": "python " + " ".join(sys.argv), "artist": table, "records": records}, f, indent=1)
for r in table:
    print(r["preset"], {k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()
                        if k not in ("method", "preset", "iterations")})
