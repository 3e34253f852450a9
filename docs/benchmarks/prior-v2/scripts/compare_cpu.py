"""v1's generator against the U-Net candidate at equal wall time on the CPU, on the prior's own held-out batch.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/compare_cpu.py --minutes 10 --out runs/compare_cpu

Both run the v1 recipe (svbrdf.trainer.prior.PriorConfig defaults: 128 px, batches of 8, per-map L1 + relighting,
the numpy photo stream) with the peak learning rate of the shipped run (1e-3) and differ only in the generator:
``wen`` width 0.25 (v1's) and ``unet`` width 0.25, 4 levels (v2's). Each first times 5 iterations, sets its cosine
schedule to end at the time limit (``iters = minutes * 60 / seconds per iteration``), then trains with that limit
on one thread; one after the other, never in parallel. At the end: map errors (:func:`svbrdf.trainer.prior.map_errors`)
on the fixed validation batch (``PriorTrainer.eval_set``: 16 materials of their own seed, identical for both runs).
Writes one JSON line per run to ``--out``/results.jsonl and prints it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import torch

from svbrdf.trainer.models import GeneratorConfig
from svbrdf.trainer.prior import PriorConfig, PriorTrainer

ARCHS = {
    "wen": GeneratorConfig(width=0.25, train_encoder=True),
    "unet": GeneratorConfig(width=0.25, decoder_blocks=4, train_encoder=True, arch="unet"),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=10.0)
    ap.add_argument("--archs", default="wen,unet")
    ap.add_argument("--out", default="runs/compare_cpu")
    a = ap.parse_args()
    torch.set_num_threads(1)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for arch in a.archs.split(","):
        cfg = PriorConfig(generator=ARCHS[arch], lr=1e-3, eval_every=0, checkpoint_every=0)
        probe = PriorTrainer(cfg, device="cpu", threads=1)
        t0 = time.perf_counter()
        for _ in range(5):
            probe.iteration()
        per_iter = (time.perf_counter() - t0) / 5
        iters = max(10, int(a.minutes * 60.0 / per_iter))
        trainer = PriorTrainer(dataclasses.replace(cfg, iters=iters), device="cpu", threads=1,
                               log_path=out / f"{arch}.jsonl")
        t0 = time.perf_counter()
        trainer.run(max_seconds=a.minutes * 60.0)
        wall = time.perf_counter() - t0
        rec = {"arch": arch, "parameters": sum(p.numel() for p in trainer.generator.parameters()),
               "planned_iters": iters, "iters": trainer.step, "samples": trainer.step * cfg.batch,
               "seconds": round(wall, 1), "s_per_iter": round(wall / max(trainer.step, 1), 4),
               "held_out": {k: round(v, 4) for k, v in trainer.evaluate().items()}}
        with open(out / "results.jsonl", "a", encoding="utf-8") as f:
            f.write(json.dumps(rec) + "\n")
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
