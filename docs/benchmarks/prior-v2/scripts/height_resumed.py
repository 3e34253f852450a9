"""A v2 checkpoint continued N iterations at batch B (fp32, eager, one thread), its tanh height linearised where it
stands first (``linearise_height``); held-out map errors (the trainer's 32 validation photos) and the normals' tilt
every 50 iterations.

    git show 6c6232b:docs/benchmarks/prior-v2/resume.pt > /tmp/r4745.pt       # the run at 4745, tanh
    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/height_resumed.py /tmp/r4745.pt TAG N B OUT.jsonl ['{...}']

The JSON holds PriorConfig overrides and ``"weights"`` (:data:`svbrdf.trainer.losses.SUPERVISED_WEIGHTS` overrides).
"""
import dataclasses
import json
import sys

import torch

import svbrdf.trainer.losses as L
from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.trainer.prior import PriorConfig, PriorTrainer, map_errors
from height_common import tilt, train_and_evaluate

src, tag, n, batch, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
over = json.loads(sys.argv[6]) if len(sys.argv) > 6 else {}
L.SUPERVISED_WEIGHTS.update(over.pop("weights", {}))
ckpt = load_checkpoint(src)
cfg = dataclasses.replace(PriorConfig.from_dict(ckpt["prior_config"]), batch=batch, eval_batch=32, bf16=False, **over)
tr = PriorTrainer(cfg, device="cpu", threads=1)
tr.load_resume(ckpt, src)
photos, maps = tr.eval_set()


def evaluate(step):
    tr.generator.eval()
    with torch.no_grad():
        p = tr.generator(photos)
    rec = {"tag": tag, "at": step, **{k: round(v, 4) for k, v in map_errors(p, maps).items()},
           "tilt": round(tilt(p[:, SLICES["normal"]]), 3), "truth_tilt": round(tilt(maps[:, SLICES["normal"]]), 3),
           "slope_corr": round(1.0 - float(L.slope_correlation_loss(p, maps)), 4)}
    print(json.dumps(rec), flush=True)
    with open(out, "a") as f:
        f.write(json.dumps(rec) + "\n")


if tr.config.generator.height_activation == "tanh":
    evaluate("tanh")
    print("k", tr.linearise_height(), flush=True)
train_and_evaluate(tr, n, evaluate)
