"""Held-out procedural photos (seed 987654: knit, plaster, cells, cells), their true normals and two checkpoints' normals,
every tilt exaggerated 3x: python docs/benchmarks/prior-v2/scripts/height_normals_sheet.py CKPT_A CKPT_B OUT.png"""
import dataclasses, sys, torch, numpy as np, OpenImageIO as oiio
from svbrdf.trainer.checkpoint import load_checkpoint, generator_from_checkpoint
from svbrdf.trainer.prior import PriorConfig, sample_batch
from svbrdf.runtime.maps import SLICES
torch.set_num_threads(1)
cfg = dataclasses.replace(PriorConfig.from_dict(load_checkpoint(sys.argv[1])["prior_config"]), crop_share=0.0, flat_share=0.0)
photos, maps, info = sample_batch(cfg, torch.Generator().manual_seed(987654), batch=6)
rows = []
for path in sys.argv[1:3]:
    g = generator_from_checkpoint(load_checkpoint(path)).eval()
    with torch.no_grad(): p = g(photos)
    rows.append(p)
def n2img(n, gain=3.0):  # tilt exaggerated x3 to see it
    n = n.clone(); n[:2] *= gain; n = n / n.norm(dim=0, keepdim=True)
    return ((n + 1) / 2).permute(1, 2, 0).numpy()
out = []
for i in (0, 2, 3, 5):
    out.append(np.concatenate([np.clip(photos[i].permute(1, 2, 0).numpy(), 0, 1) ** (1 / 2.2), n2img(maps[i, SLICES["normal"]]),
                               n2img(rows[0][i, SLICES["normal"]]), n2img(rows[1][i, SLICES["normal"]])], 1))
img = np.ascontiguousarray(np.concatenate(out, 0)[::2, ::2].astype(np.float32))
o = oiio.ImageBuf(oiio.ImageSpec(img.shape[1], img.shape[0], 3, "uint8")); o.set_pixels(oiio.ROI(), img); o.write(sys.argv[3])
print([info["families"][i] for i in (0, 2, 3, 5)])
