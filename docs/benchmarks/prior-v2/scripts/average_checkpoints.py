"""The mean of several v2 checkpoints' generator weights, saved as a copy of the last (what a moving average of
the weights would give; the probe behind ``PriorConfig.ema``).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/average_checkpoints.py OUT.pt CKPT CKPT [CKPT ...]

Every checkpoint must have the last one's architecture (a linear height: from 4964 on in the v2 run).
"""
import sys

import torch

from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.trainer.prior import PriorConfig, PriorTrainer

out, sources = sys.argv[1], sys.argv[2:]
trainers = []
for s in sources:
    c = load_checkpoint(s)
    t = PriorTrainer(PriorConfig.from_dict(c["prior_config"]), device="cpu", threads=1)
    t.load_resume(c, s)
    trainers.append(t)
weights = trainers[-1].generator.state_dict()
with torch.no_grad():
    for k, v in weights.items():
        if v.is_floating_point():
            v.copy_(sum(t.generator.state_dict()[k] for t in trainers) / len(trainers))
trainers[-1].save(out)
print(f"saved {out}: the mean of {len(sources)} checkpoints' weights (step {trainers[-1].step})")
