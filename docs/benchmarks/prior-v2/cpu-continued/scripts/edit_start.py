"""A stage-one checkpoint with entries of its ``prior_config`` replaced, to continue it with another recipe
(``svbrdf-train prior --resume OUT --iters N`` then re-spreads the cosine from the checkpoint's step to N).

    python docs/benchmarks/prior-v2/cpu-continued/scripts/edit_start.py CKPT OUT.pt '{"lambda_amount": 2.0}'
"""
import json
import sys

import torch

src, dst, edits = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
ckpt = torch.load(src, weights_only=False, map_location="cpu")
ckpt["prior_config"].update(edits)
print(dst, {k: ckpt["prior_config"][k] for k in edits}, "step", ckpt.get("step"))
torch.save(ckpt, dst)
