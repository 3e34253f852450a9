"""What a fine-tune variant does to real photos, to look at: per photo one row per variant (the stage one's own
maps first), each row the batch contact sheet's strip (:func:`svbrdf.runtime.contact_sheet.strip`: photo, base
colour, normals, roughness, specular, relit from the upper left) followed by the maps relit under the flash and
two lights (:func:`svbrdf.runtime.texture_set.relit_panel`). The photo is read at ``SIZE`` px (long side) and
fine-tuned with ``fast`` plus each variant's TrainConfig overrides; 8-bit PNG.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/refine_sheet.py OUT.png SIZE CKPT PHOTO[,PHOTO...] 'LABEL=JSON;...'
"""
import json
import sys
import warnings

import numpy as np

from svbrdf.runtime.contact_sheet import THUMB, strip
from svbrdf.runtime.imageio import read_image, write_image
from svbrdf.runtime.texture_set import relit_panel
from svbrdf.trainer import train
from svbrdf.trainer.config import resolve
from svbrdf.trainer.stage import make_trainer

warnings.simplefilter("ignore")
out, size, ckpt, photos, spec = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4].split(","), sys.argv[5]
variants = {}
for item in spec.split(";"):
    label, ovr = item.split("=", 1)
    variants[label] = json.loads(ovr)


def row(photo, maps, cfg):
    relit = relit_panel(maps, cfg.render_config, size=THUMB)
    panel = np.pad(relit, ((0, THUMB - relit.shape[0]), (0, 0), (0, 0)), constant_values=0.2)
    return np.concatenate([strip(photo, maps, relit), panel], axis=1)


rows = []
for path in photos:
    photo = read_image(path, max_size=size)
    tensor = train.photo_to_tensor(photo)
    first = True
    for label, ovr in variants.items():
        cfg = resolve("fast", **ovr)
        trainer = make_trainer(tensor, "finetune", cfg, init=ckpt, threads=1)
        if first:
            rows.append(row(photo, trainer.predict_maps(), cfg))
            first = False
        trainer.run()
        rows.append(row(photo, trainer.predict_maps(), cfg))
        print(path, label, "done", flush=True)
w = max(r.shape[1] for r in rows)
sheet = np.concatenate([np.pad(r, ((0, 0), (0, w - r.shape[1]), (0, 0))) for r in rows], axis=0)
write_image(out, sheet.astype(np.float32), bits=8, colour_space="sRGB", force=True)
