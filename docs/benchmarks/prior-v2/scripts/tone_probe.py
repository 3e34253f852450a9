"""Does a stage one read a phone photo's highlight as our camera model would have made it? The label-free burn-in of
a preview when the photo's bright values are first expanded (the inverse of a highlight roll-off) or compressed.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/tone_probe.py MODEL.onnx henzler SIZE [raw]
    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/tone_probe.py MODEL.onnx real [raw]
    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/tone_probe.py MODEL.onnx sim [raw]

``henzler``: the four photos of the before/after grid at SIZE (long side), whole; ``real``: every real photo set at
256 px centre squares, mean / median per set; ``sim``: 24 procedural photos of the prior's own camera model (seed
4242), where a transform can only move the input away from what the network learned. ``raw``: the network is shown
the photo as it is (what the stage one was trained on), not evenly lit (the runtime's default). Scores:
:func:`svbrdf.runtime.burn_in.photo_burn_in` of the preview's maps (the worst map's disc or ring score; r / d: the
roughness's and the base colour's ring scores).

Transforms of the linear photo x in [0, 1] (all keep 0 and 1): ``expand a`` = x (1 - a) / (1 - a x) (bright values
pushed up relative to the mid-tones), ``compress a`` = x (1 + a) / (1 + a x), ``gamma g`` = x ** g.
"""
import glob
import sys
import warnings

import numpy as np

import svbrdf.runtime.session as session
from svbrdf.runtime.burn_in import photo_burn_in
from svbrdf.runtime.imageio import read_image
from svbrdf.trainer.bench.cases import centre_square

warnings.filterwarnings("ignore")
model, mode = sys.argv[1], sys.argv[2]
size = int(sys.argv[3]) if mode == "henzler" else 256
if sys.argv[-1] == "raw":
    session.EVEN_LIGHTING = None
S = session.load_session(model, threads=1)
D = "../shared/data"
TRANSFORMS = {"as is": lambda x: x, "expand .5": lambda x: x * 0.5 / (1 - 0.5 * x),
              "expand .8": lambda x: x * 0.2 / (1 - 0.8 * x), "compress 1": lambda x: 2 * x / (1 + x),
              "gamma 1.5": lambda x: x ** 1.5, "gamma .7": lambda x: x ** 0.7}


def scores(photo: np.ndarray, names=TRANSFORMS) -> dict:
    out = {}
    for k in names:
        m = session.estimate(np.clip(TRANSFORMS[k](photo), 0, 1).astype(np.float32), S, max_size=size)
        out[k] = photo_burn_in(m, photo)
    return out



if mode == "henzler":
    for p in ["2003/IMG_9392", "2008/IMG_9399", "0281/IMG_0790", "2058/IMG_9482"]:
        s = scores(read_image(f"{D}/henzler-flash/test/{p}.JPG", max_size=size))
        cells = [f"{k}: {v['burn_in']:.2f} (r{v['ring_roughness']:.2f} d{v['ring_diffuse']:.2f})" for k, v in s.items()]
        print(p.split("/")[1], " | ".join(cells), flush=True)
else:
    names = ("as is", "expand .5", "expand .8")
    if mode == "real":
        sets = {"henzler": f"{D}/henzler-flash/test/*/*.JPG", "des18": f"{D}/deschaintre18-real/*.png",
                "weiyi": f"{D}/weiyi-auxrender/test_data/real/*.png", "xuejiao": f"{D}/xuejiao-lgd/dataset/**/*.png"}
        photo_sets = {k: [centre_square(read_image(f, max_size=256))
                          for f in sorted(glob.glob(p, recursive=True))]
                      for k, p in sets.items()}
    else:
        import dataclasses

        import torch

        from svbrdf.trainer.checkpoint import load_checkpoint
        from svbrdf.trainer.prior import PriorConfig, sample_batch

        cfg = dataclasses.replace(PriorConfig.from_dict(load_checkpoint("docs/benchmarks/prior-v2/resume.pt")
                                                        ["prior_config"]), crop_share=0.0, flat_share=0.0)
        photos = sample_batch(cfg, torch.Generator().manual_seed(4242), batch=24)[0]
        photo_sets = {"sim": [p.permute(1, 2, 0).numpy().astype(np.float32) for p in photos]}
    for k, ps in photo_sets.items():
        got = [scores(p, names) for p in ps]
        print(k, len(ps), " ".join(f"{n}: {np.mean([g[n]['burn_in'] for g in got]):.3f}/"
                                   f"{np.median([g[n]['burn_in'] for g in got]):.3f}" for n in names), flush=True)
