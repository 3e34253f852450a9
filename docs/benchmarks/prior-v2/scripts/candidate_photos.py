"""Stage-one candidates on real photos at the preview's default size (long side 2048, 1024 px tiles): the
label-free burn-in of the final maps (``meta["burn_in"]``) and of the network's own (``burn_in_model``), the
model's seconds, and a picture: per photo and model one row of base colour, roughness, normal and the maps relit
under the flash and a light from the upper left (each panel 384 px wide).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/candidate_photos.py OUT.json OUT.jpg 'PHOTO,...' v1=PATH cand=default
"""
import json
import sys

import numpy as np
import OpenImageIO as oiio

from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.render import ZHAO, render
from svbrdf.runtime.session import estimate, load_session
from svbrdf.runtime.tiling import block_mean

out_json, out_jpg, photos = sys.argv[1], sys.argv[2], sys.argv[3].split(",")
models = dict(a.split("=", 1) for a in sys.argv[4:])
sessions = {label: load_session(None if p == "default" else p, threads=1) for label, p in models.items()}
PICTURE = 2  # the first photos go into the picture


def small(a, width=384):
    return block_mean(a, max(1, a.shape[1] // width))


records, rows = [], []
for i, photo in enumerate(photos):
    row = {"photo": photo}
    for label, sess in sessions.items():
        m = estimate(photo, sess)
        row[label] = {"burn_in": m.meta["burn_in"]["burn_in"], "burn_in_model": m.meta["burn_in_model"]["burn_in"],
                      "infer_s": m.meta["timings"]["infer"], "tiles": m.meta["tiles"], "size": m.meta["size"]}
        if i < PICTURE:
            r = m.roughness[..., 0]
            panels = [np.clip(linear_to_srgb(m.diffuse), 0, 1), np.repeat(np.clip(r, 0, 1)[..., None], 3, -1),
                      np.clip(m.normal * 0.5 + 0.5, 0, 1)]
            for light in (None, (-1.2, 1.2, 1.0)):
                img = render(m, light_pos=light, config=ZHAO.replace(falloff=True))
                panels.append(np.clip(linear_to_srgb(img / max(np.percentile(img, 99), 1e-6) * 0.8), 0, 1))
            tiles = [small(p) for p in panels]
            gap = np.ones((tiles[0].shape[0], 4, 3))
            rows.append(np.concatenate(sum([[t, gap] for t in tiles], [])[:-1], 1))
            rows.append(np.ones((4, rows[-1].shape[1], 3)))
    records.append(row)
    print(photo.split("/")[-1], {lb: (round(row[lb]["burn_in"], 3), round(row[lb]["burn_in_model"], 3),
                                      round(row[lb]["infer_s"], 1)) for lb in sessions}, flush=True)
summary = {lb: {k: float(np.mean([r[lb][k] for r in records])) for k in ("burn_in", "burn_in_model", "infer_s")}
           for lb in sessions}
print(summary)
json.dump({"command": "python " + " ".join(sys.argv), "summary": summary, "records": records},
          open(out_json, "w"), indent=1)
oiio.ImageBuf(np.ascontiguousarray(np.concatenate(rows[:-1], 0).astype(np.float32))).write(out_jpg)
