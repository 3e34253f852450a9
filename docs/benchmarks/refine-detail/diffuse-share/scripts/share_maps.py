"""What L_d's ``diffuse_weighting="diffuse_share"`` weighs on a few shared cases: the input photo (sRGB) beside the
share of its flash radiance that the stage one's own maps give to the diffuse term (black 0, white 1), and the
mean share per case. Evaluation only: reads the shared sets, trains nothing.

    python docs/benchmarks/refine-detail/diffuse-share/scripts/share_maps.py CKPT OUT.png 'CASES'
"""
import sys
from pathlib import Path

import numpy as np
import torch

from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.imageio import write_image
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.config import resolve
from svbrdf.trainer.stage import make_trainer

ckpt, out, spec = sys.argv[1], sys.argv[2], sys.argv[3]
rows = []
for case in load_cases(Path("../shared/data"), 256, spec):
    photo = torch.from_numpy(np.ascontiguousarray(case.photo)).permute(2, 0, 1)[None].float()
    trainer = make_trainer(photo, "finetune", resolve("fast", diffuse_weighting="diffuse_share"), init=ckpt,
                           iters=0, threads=1)
    share = trainer._diffuse_weight(0, 0, *photo.shape[-2:])[0, 0].numpy()
    print(f"{case.name}: mean share {share.mean():.3f}, at the centre {share[118:138, 118:138].mean():.3f}, "
          f"below 0.5 {np.mean(share < 0.5):.2f}")
    rows.append(np.concatenate([linear_to_srgb(np.clip(case.photo, 0, 1)), np.repeat(share[..., None], 3, -1)], 1))
write_image(out, np.concatenate(rows, 0).astype(np.float32), bits=8, force=True)
