"""The v2 recipe from scratch at 128 px (batch 8, crops of 256 px photos, 16 px detail windows, fp32, one thread):
does the stage one learn normals, with a tanh or a linear height, a heavier normal term, no relighting, or normals
alone? Held-out normal error (the trainer's validation batch, 16 photos) and the height's pre-activation every 50.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/height_scratch.py TAG STEPS OUT.jsonl ['{...}']

The JSON holds PriorConfig overrides plus ``"height"`` ("tanh" or "linear", default linear), ``"weights"``
(:data:`svbrdf.trainer.losses.SUPERVISED_WEIGHTS` overrides; normals alone: the other three 0 with no relighting,
detail or amount terms) and ``"slopes": true`` (decoder_nr gives two slope channels and the roughness:
``scripts/slopes_patch.py``, a test-only change of the network).
"""
import dataclasses
import json
import sys
from pathlib import Path

import torch

import svbrdf.trainer.losses as L

tag, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
over = json.loads(sys.argv[4]) if len(sys.argv) > 4 else {}
if over.pop("slopes", False):
    sys.path.insert(0, str(Path(__file__).parent))
    import slopes_patch  # noqa: F401
height = over.pop("height", "linear")
L.SUPERVISED_WEIGHTS.update(over.pop("weights", {}))

from svbrdf.runtime.maps import SLICES  # noqa: E402
from svbrdf.trainer.prior import PriorTrainer, map_errors, prior_preset  # noqa: E402
from height_common import tilt, train_and_evaluate  # noqa: E402

cfg = prior_preset("v2")
cfg = dataclasses.replace(cfg, generator=dataclasses.replace(cfg.generator, height_activation=height), size=128,
                          photo_size=256, batch=8, amount_windows=(16,), iters=3000, eval_batch=16, bf16=False,
                          batched=True, log_every=1, **over)
tr = PriorTrainer(cfg, device="cpu", threads=1)
photos, maps = tr.eval_set()
flat = maps.clone()
flat[:, SLICES["normal"]] = torch.tensor([0.0, 0.0, 1.0]).view(1, 3, 1, 1)


def evaluate(step):
    g = tr.generator.eval()
    with torch.no_grad():
        p = g(photos)
        pre = g._decoded("decoder_nr", g.forward_features(photos))[:, 0] + g.out_offset[0]
    rec = {"tag": tag, "step": step, **{k: round(v, 4) for k, v in map_errors(p, maps).items()},
           "flat_deg": round(map_errors(flat, maps)["normal_deg"], 4), "tilt": round(tilt(p[:, SLICES["normal"]]), 3),
           "pre_mean": round(float(pre.mean()), 3), "pre_std": round(float(pre.std()), 3)}
    print(json.dumps(rec), flush=True)
    with open(out, "a") as f:
        f.write(json.dumps(rec) + "\n")


train_and_evaluate(tr, n, evaluate)
