"""Seconds per fine-tune iteration (``fast``, 256 px photo, one thread) of a U-Net stage one's generator with the
photo's context recomputed every ``context_every`` iterations and without it, taking turns so machine load affects
them alike; the median of the turns.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/photo-context/scripts/context_speed.py CKPT [ITERS] [REPEATS]
"""
import statistics
import sys
import time
import warnings

import torch

from svbrdf.trainer.config import resolve
from svbrdf.trainer.stage import make_trainer

warnings.simplefilter("ignore")
torch.set_num_threads(1)
ckpt, iters, repeats = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 20, \
    int(sys.argv[3]) if len(sys.argv) > 3 else 3
photo = torch.rand(1, 3, 256, 256, generator=torch.Generator().manual_seed(0)) * 0.6
variants = {"no context": {"photo_context": False}, "context every 1": {}, "context every 5": {"context_every": 5}}
trainers = {k: make_trainer(photo, "finetune", resolve("fast", eval_every=0, **v), init=ckpt, threads=1)
            for k, v in variants.items()}
times = {k: [] for k in variants}
for t in trainers.values():
    for _ in range(3):
        t.iteration()  # warm-up
for _ in range(repeats):
    for k, t in trainers.items():
        t0 = time.perf_counter()
        for _ in range(iters):
            t.iteration()
        times[k].append((time.perf_counter() - t0) / iters)
base = statistics.median(times["no context"])
for k, v in times.items():
    print(f"{k}: {statistics.median(v):.4f} s/it ({statistics.median(v) / base:.2f}x)")
