"""The four Henzler photos of the before/after grid through two models' previews at SIZE px, one row per photo and
model (`svbrdf.trainer.tools.before_after.row_image`: photo, base colour, normal, roughness, specular, relit by the
flash and two lights), with each row's label-free burn-in and median specular and roughness printed.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/preview_sheet.py SIZE OUT.png LABEL=MODEL.onnx ...
    (MODEL "shipped": the packaged default model)
"""
import sys

import numpy as np

import svbrdf.runtime.session as S
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.imageio import write_image
from svbrdf.trainer.tools.before_after import row_image

D = "../shared/data/henzler-flash/test"
PHOTOS = [f"{D}/2003/IMG_9392.JPG", f"{D}/0281/IMG_0790.JPG", f"{D}/2008/IMG_9399.JPG", f"{D}/2058/IMG_9482.JPG"]
size, out = int(sys.argv[1]), sys.argv[2]
models = dict(a.split("=", 1) for a in sys.argv[3:])
sessions = {k: S.load_session(None if v == "shipped" else v, threads=1) for k, v in models.items()}
rows = []
for path in PHOTOS:
    _, photo, _ = S._as_image(path, size)
    for label, sess in sessions.items():
        m = S.estimate(photo, sess, max_size=size)
        print(path.split("/")[-1], label, "burn-in", round(float(photo_burn_in(m, photo)["burn_in"]), 3),
              "specular", round(float(np.median(m.specular)), 3), "roughness", round(float(np.median(m.roughness)), 3))
        rows.append(row_image(photo, m))
write_image(out, np.concatenate(rows, axis=0), bits=8, force=True)
