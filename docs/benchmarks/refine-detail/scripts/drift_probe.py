"""Why longer fine-tunes get worse (issue 27, item 3), on held-out procedural materials (seed 987654, not a
training seed of the stage one; never the shared sets): the default refine run to 600 iterations, evaluated at
0 / 150 / 300 / 600 against the truth, once as shipped and once with each loss term switched off. One JSON line per
(material, variant, iteration) with the benchmark's metrics (svbrdf.trainer.bench.metrics.evaluate), and per run
the trainer's own label-free evaluation curve (``evals``: render_l1 on held-out tiles), to see whether it tracks.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/drift_probe.py N VARIANTS OUT.jsonl [PART PARTS]

VARIANTS: semicolon-separated ``label=JSON`` overrides of ``fast`` (``default={}`` for the shipped preset), e.g.
``'default={};nogan={"lambda_gan":0}'``. Resumable: lines already in OUT are skipped.
"""
import json
import sys
import time
import warnings
from pathlib import Path

import torch

from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.cases import BenchCase
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

warnings.simplefilter("ignore")
n, spec, out = int(sys.argv[1]), sys.argv[2], Path(sys.argv[3])
part, parts = (int(sys.argv[4]), int(sys.argv[5])) if len(sys.argv) > 5 else (0, 1)
variants = {}
for item in spec.split(";"):
    label, ovr = item.split("=", 1)
    variants[label] = json.loads(ovr)
ITERS = [0, 150, 300, 600]
done = set()
if out.exists():
    for line in out.read_text().splitlines():
        r = json.loads(line)
        done.add((r["material"], r["variant"]))
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, _ = simulate_photos(maps, PriorConfig(), rng)
with out.open("a") as f:
    for i in range(part, n, parts):
        photo = photos[i].permute(1, 2, 0).numpy().copy()
        gt = Maps.unpack(gts[i].permute(1, 2, 0).numpy())
        case = BenchCase(f"proc{i}", "", "synthetic", "procedural", photo, gt, (128.0, 128.0), None)
        for label, ovr in variants.items():
            if (f"proc{i}", label) in done:
                continue
            t = time.time()
            pts, errs = [], []
            opts = BenchOptions(iters=ITERS, threads=1, repeats=1, train_overrides=ovr)
            run = METHODS["finetune"].run(case, opts, "fast", pts.append)
            for p in pts:
                m = evaluate(p.maps, gt=gt, centre=case.centre)
                errs.append(f"{p.iterations}:{m['rerender_rmse']:.4f}")
                f.write(json.dumps({"material": f"proc{i}", "name": names[i], "variant": label,
                                    "iterations": p.iterations, "train_seconds": p.train_seconds, **m,
                                    "evals": run["evals"] if p.iterations == ITERS[-1] else None}) + "\n")
            f.flush()
            print(f"proc{i} {names[i]} {label} {time.time() - t:.0f}s " + " ".join(errs), flush=True)
