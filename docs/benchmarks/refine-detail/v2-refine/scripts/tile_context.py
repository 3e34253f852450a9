"""How much a stage one's maps of a 128 px tile differ from the same 128 px of its maps of the whole 256 px photo
(the fine-tune trains on such tiles and predicts the whole photo). 12 held-out procedural materials (seed 987654,
never the shared sets), five tiles each (the four corners and the centre); per packed channel (diffuse RGB,
specular, roughness, normal xyz) the mean |tile - crop of whole| beside the whole maps' mean |value - its mean|.
For a U-Net stage one, also the tile given the whole photo's context (``Generator.photo_context``), over the whole
tile and over its interior (16 px from its border).

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/v2-refine/scripts/tile_context.py CKPT [CKPT ...]
"""
import sys
import warnings

import torch

from svbrdf.trainer.checkpoint import load_generator
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

warnings.simplefilter("ignore")
torch.set_num_threads(1)
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(12, 256, rng)
photos, _, _ = simulate_photos(maps, PriorConfig(), rng)
for ck in sys.argv[1:]:
    gen, _ = load_generator(ck)
    with torch.no_grad():
        whole = gen(photos)
        diffs = [(gen(photos[:, :, y:y + 128, x:x + 128]) - whole[:, :, y:y + 128, x:x + 128]).abs().mean((0, 2, 3))
                 for y, x in [(0, 0), (0, 128), (128, 0), (128, 128), (64, 64)]]
        diff = torch.stack(diffs).mean(0)
        ctx_rows = None
        if gen.cfg.arch == "unet":
            ctx = gen.photo_context(photos)
            full, inner = [], []
            for y, x in [(0, 0), (0, 128), (128, 0), (128, 128), (64, 64)]:
                d = (gen(photos[:, :, y:y + 128, x:x + 128], ctx, torch.tensor([y, x]))
                     - whole[:, :, y:y + 128, x:x + 128]).abs()
                full.append(d.mean((0, 2, 3)))
                inner.append(d[..., 16:-16, 16:-16].mean((0, 2, 3)))
            ctx_rows = torch.stack(full).mean(0), torch.stack(inner).mean(0)
        spread = (whole - whole.mean((2, 3), keepdim=True)).abs().mean((0, 2, 3))
    print(ck)
    print("  tile vs crop of whole:", [round(float(v), 4) for v in diff])
    if ctx_rows is not None:
        print("  tile with the photo's context:", [round(float(v), 4) for v in ctx_rows[0]])
        print("  the same, 16 px inside:      ", [round(float(v), 4) for v in ctx_rows[1]])
    print("  spread of the whole:  ", [round(float(v), 4) for v in spread])
