"""A stationary material with a broad highlight, rendered by the project's own renderer (no domain gap): what the
preview and the refine make of it. The truth is one roughness and one specular level everywhere; a disc in the
roughness or the base colour is the estimator's, not the photo's (issue 27, item 2).

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/broad_highlight_probe.py 'LABEL=JSON;...' [OUT.png]

Each variant is a set of TrainConfig overrides of the default refine (``default={}``). The material: smoothed-noise
base colour, flat normals, specular 0.04, roughness ROUGH (0.35: a broad lobe), rendered with the model's render
configuration and fall-off, exposed so the median is 0.25 (1.6 % of the pixels clip).
"""
import json
import sys
import warnings

import numpy as np

from svbrdf.runtime import session as S
from svbrdf.runtime.burn_in import burn_in_scores
from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.imageio import write_image
from svbrdf.runtime.manifest import find_checkpoint
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.render import render
from svbrdf.trainer import checkpoint as ckpt_io
from svbrdf.trainer import train
from svbrdf.trainer.config import TrainConfig
from svbrdf.trainer.refine import refine_config
from svbrdf.trainer.stage import make_trainer

warnings.simplefilter("ignore")
N, SPEC, ROUGH = 256, 0.04, 0.35
sess = S.load_session(threads=1)
rc = sess.render_config.replace(falloff=True)
rng = np.random.default_rng(0)
a = rng.uniform(0, 1, (N, N, 1))
for _ in range(4):
    a = (a + np.roll(a, 1, 0) + np.roll(a, 1, 1) + np.roll(a, -1, 0) + np.roll(a, -1, 1)) / 5
diffuse = (np.array([0.35, 0.2, 0.1]) * (0.7 + 0.18 * (a - a.mean()) / a.std())).astype(np.float32)
flat = np.zeros((N, N, 3), np.float32)
flat[..., 2] = 1
truth = Maps(diffuse=diffuse, specular=np.full((N, N, 1), SPEC, np.float32),
             roughness=np.full((N, N, 1), ROUGH, np.float32), normal=flat, render_config=rc)
img = render(truth)
photo = np.clip(img / np.quantile(img, 0.5) * 0.25, 0, 1).astype(np.float32)
print(f"truth: roughness {ROUGH}, specular {SPEC}; clipped {np.mean(photo.max(-1) >= 0.98):.3f}")


def describe(label, m):
    b = burn_in_scores(m, tuple(m.meta["burn_in"]["centre"]))
    r = m.roughness
    print(f"{label:14s} roughness median {np.median(r):.3f} (p10 {np.quantile(r, .1):.3f}, p90 {np.quantile(r, .9):.3f}) "
          f"specular {np.median(m.specular):.3f}  burn-in {b['burn_in']:.3f}  ring roughness {b['ring_roughness']:.3f} "
          f"ring base colour {b['ring_diffuse']:.3f}", flush=True)
    d = linear_to_srgb(m.diffuse)
    return np.concatenate([linear_to_srgb(photo), np.clip(d / max(np.quantile(d, .99), 1e-6), 0, 1),
                           np.repeat(m.roughness, 3, -1)], 1)


rows = [describe("preview", S.estimate(photo, sess))]
ckpt = ckpt_io.load_checkpoint(find_checkpoint(sess.info))
for item in (sys.argv[1] if len(sys.argv) > 1 else "default={}").split(";"):
    label, ovr = item.split("=", 1)
    cfg = refine_config(ckpt).to_dict()
    cfg.update(json.loads(ovr))
    tensor = train.photo_to_tensor(photo)
    trainer = make_trainer(tensor, "finetune", TrainConfig.from_dict(cfg), init=ckpt, threads=1,
                           photo_info=train.tensor_photo_info(tensor, "broad"))
    trainer.run()
    rows.append(describe(f"refine {label}", trainer.predict_maps()))
if len(sys.argv) > 2:
    write_image(sys.argv[2], np.concatenate(rows, 0).astype(np.float32), bits=8)
