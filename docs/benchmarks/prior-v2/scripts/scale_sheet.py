"""Whole real photos at SIZE px through the stage one's preview, the network at the photo's size (``full``) and at
SIDE px with the maps upsampled by `scale_probe.py`'s guided filter (``guided``): one row per photo and variant
(`svbrdf.trainer.tools.before_after.row_image`: photo, base colour, normal, roughness, specular, relit by the
flash and two lights) and each row's label-free burn-in (`svbrdf.runtime.burn_in.photo_burn_in`).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/scale_sheet.py MODEL.onnx SIZE SIDE OUT.png PHOTO...
"""
import json
import sys
import time

import numpy as np

import svbrdf.runtime.session as S
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.imageio import write_image
from svbrdf.trainer.tools.before_after import row_image
from scale_probe import at_scale

model, size, side, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
sess = S.load_session(model, threads=1)
rows, record = [], []
for path in sys.argv[5:]:
    _, photo, _ = S._as_image(path, size)  # linear, downsized as `svbrdf-preview --max-size SIZE` does
    for variant in ("full", "guided"):
        t = time.perf_counter()
        maps = S.estimate(photo, sess, max_size=size) if variant == "full" else at_scale(photo, sess, side, True)
        seconds = time.perf_counter() - t
        burn = photo_burn_in(maps, photo)
        rec = {"photo": path, "variant": variant, "seconds": round(seconds, 2),
               **{k: round(float(v), 4) for k, v in burn.items() if k != "centre"}}
        record.append(rec)
        print(json.dumps(rec), flush=True)
        rows.append(row_image(photo, maps))
write_image(out, np.concatenate(rows, axis=0), bits=8, force=True)
with open(out.rsplit(".", 1)[0] + ".json", "w") as f:
    json.dump(record, f, indent=1)
