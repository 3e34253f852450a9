"""Whole photos (not the benchmark's centre crops) as the preview gives them, at a given size, with the network's
input evenly lit at each of several widths (``svbrdf.runtime.session.EVEN_LIGHTING``; ``none``: the photo as it
is; ``polyD``: ``flat_lib.flatten_poly``). Per photo and setting one row of the before/after grid's layout
(photo, base colour, normal, roughness, specular, relit by the flash and two lights; ``before_after.row_image``
cannot be used: the relit panel of a large photo is smaller than its maps), each panel strided to about ROW_H
pixels high. Prints each row's burn-in.

    python docs/benchmarks/refine-detail/flat-input/scripts/whole_sheet.py OUT.png SIZE none,0.25,poly4 PHOTO [PHOTO ...]

``MODEL=path.onnx`` in the environment: that model instead of the packaged one.
"""
import os, sys, warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from flat_lib import flatten_poly  # noqa: E402
from svbrdf.runtime import session as S
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.flash_trend import even_lighting
from svbrdf.runtime.imageio import write_image
from svbrdf.runtime.maps import encode_normal
from svbrdf.runtime.render import ZHAO
from svbrdf.runtime.texture_set import relit_panel

warnings.simplefilter("ignore")
ROW_H = 192
out, size, settings, photos = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(","), sys.argv[4:]
sess = S.load_session(os.environ.get("MODEL") or None)
rows = []
for f in photos:
    for setting in settings:
        if setting.startswith("poly"):  # a probe's lighting model (flat_lib.flatten_poly) in the runtime's place
            S.EVEN_LIGHTING, S.even_lighting = 1.0, lambda p, _s, d=int(setting[4:]): flatten_poly(p, d)
        else:
            S.EVEN_LIGHTING, S.even_lighting = None if setting == "none" else float(setting), even_lighting
        m = S.estimate(f, sess, max_size=size)
        photo = S.read_image(f, max_size=size)
        print(f"{f.split('/')[-1]} {size} px, even lighting {setting}: burn-in {m.meta['burn_in']['burn_in']:.3f} "
              f"(network {m.meta['burn_in_model']['burn_in']:.3f})", flush=True)
        grey = lambda a: np.repeat(a, 3, axis=-1)  # noqa: E731
        parts = [linear_to_srgb(np.clip(photo, 0, 1)), linear_to_srgb(m.diffuse), encode_normal(m.normal),
                 grey(m.roughness), grey(linear_to_srgb(m.specular)), relit_panel(m, ZHAO)]
        parts = [np.asarray(p, np.float32)[::max(1, p.shape[0] // ROW_H), ::max(1, p.shape[0] // ROW_H)] for p in parts]
        hh = min(p.shape[0] for p in parts)
        rows.append(np.concatenate([p[:hh] for p in parts], axis=1))
width = min(r.shape[1] for r in rows)
write_image(out, np.clip(np.concatenate([r[:, :width] for r in rows], axis=0), 0, 1), bits=8, force=True)
