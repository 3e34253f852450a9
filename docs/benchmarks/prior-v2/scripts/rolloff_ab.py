"""A v2 checkpoint continued N iterations at batch B with or without the camera's highlight roll-off (``--roll-off``),
then scored on real flash photos that no benchmark table reports and on held-out procedural photos.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/rolloff_ab.py CKPT TAG N B WHITE OUT.jsonl

WHITE 1 is the control (the run's camera), WHITE > 1 draws the white point in [1, WHITE] per photo. N = 0 scores
the checkpoint as it is. Scores, on the model's own maps (`PriorTrainer.model`: the weights' moving average where
the checkpoint has one; no runtime post-processing):
- ``burn_*``: the label-free burn-in (:func:`svbrdf.runtime.burn_in.burn_in_scores`, centred on the photo's
  highlight) of the 39 real photos of ``deschaintre18-real``, ``weiyi-auxrender/test_data/real`` and
  ``xuejiao-lgd/dataset`` (256 px centre squares; the network shown the photo as it is, as it was trained): mean and
  median per set. These sets are not in the artist benchmark (its photos are Henzler's and bath_tile).
- held-out procedural map errors (the trainer's 32 validation photos, a linear camera) and the same materials
  photographed through a roll-off of white 3 (``rolled_*``).
"""
import dataclasses
import glob
import json
import sys
import time
import warnings

import numpy as np
import torch

from svbrdf.runtime.burn_in import burn_in_scores, highlight_centre
from svbrdf.runtime.imageio import read_image
from svbrdf.trainer.bench.cases import centre_square
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.trainer.prior import PriorConfig, PriorTrainer, map_errors, sample_batch

warnings.filterwarnings("ignore")
src, tag, n, batch, white, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), \
    sys.argv[6]
D = "../shared/data"
SETS = {"des18": f"{D}/deschaintre18-real/*.png", "weiyi": f"{D}/weiyi-auxrender/test_data/real/*.png",
        "xuejiao": f"{D}/xuejiao-lgd/dataset/**/*.png"}
ckpt = load_checkpoint(src)
cfg = PriorConfig.from_dict(ckpt["prior_config"])
cfg = dataclasses.replace(cfg, batch=batch, bf16=False, camera={**cfg.camera, "white": (1.0, white)})
torch.manual_seed(0)
tr = PriorTrainer(cfg, device="cpu", threads=1)
tr.load_resume(ckpt, src)



photos = {k: [centre_square(read_image(f, max_size=256)) for f in sorted(glob.glob(p, recursive=True))]
          for k, p in SETS.items()}
# the trainer's validation materials (its seed for them), photographed by a linear camera and through a roll-off
held_out = {w: sample_batch(dataclasses.replace(cfg, crop_share=0.0, flat_share=0.0, camera={**cfg.camera, "white": (w, w)}),
                            torch.Generator().manual_seed(10_000_019 + cfg.seed), batch=32)[:2] for w in (1.0, 3.0)}


def evaluate(step: int) -> None:
    tr.model.eval()
    rec = {"tag": tag, "white": white, "at": step}
    with torch.no_grad():
        for k, ps in photos.items():
            scores = []
            for p in ps:
                y = tr.model(torch.from_numpy(p).permute(2, 0, 1)[None].float())[0]
                maps = Maps.unpack(y.permute(1, 2, 0).numpy())
                scores.append(burn_in_scores(maps, highlight_centre(p))["burn_in"])
            rec[f"burn_{k}"] = [round(float(np.mean(scores)), 4), round(float(np.median(scores)), 4)]
        e = map_errors(tr.model(held_out[1.0][0]), held_out[1.0][1])
        r = map_errors(tr.model(held_out[3.0][0]), held_out[3.0][1])
    rec.update({k: round(v, 4) for k, v in e.items()})
    rec.update({f"rolled_{k}": round(v, 4) for k, v in r.items()})
    print(json.dumps(rec), flush=True)
    with open(out, "a") as f:
        f.write(json.dumps(rec) + "\n")


evaluate(0)
t0 = time.time()
for i in range(1, n + 1):
    tr.iteration()
    if i % 50 == 0 or i == n:
        print(f"{i} steps, {time.time() - t0:.0f} s", flush=True)
        if i % 50 == 0:
            evaluate(i)
