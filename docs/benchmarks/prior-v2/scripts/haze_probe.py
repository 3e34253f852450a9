"""Does a highlight with a broad shoulder (a second, wider specular lobe: the haze of a varnish or a lacquer, or
a phone's rolled-off highlight) make the v2 stage one draw its ring around the flash?

Held-out glossy procedural materials (seed 31_337_777, every family, roughness pulled to a glossy 0.1-0.3,
dielectric), photographed whole at SIZE px by the trainer's own photo model (`simulate_photos`, a co-located
flash at the project's field of view, our camera), once as they are and once with a haze lobe added: the same
maps' specular term again at roughness + DR (no diffuse), times W. The network (an ONNX export) sees each photo
through the runtime (as it is, `EVEN_LIGHTING` None, or evenly lit, the runtime's default); scored with the label-free
ring score of its raw roughness and base colour (`svbrdf.runtime.burn_in`, the network's maps, no post-processing),
and the roughness's radial profile.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/haze_probe.py MODEL N SIZE [even|photo] [W DR ...]
"""
import sys

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.burn_in import burn_in_scores
from svbrdf.runtime.maps import SLICES
from svbrdf.runtime.render import physical_config
from svbrdf.runtime.camera import Camera, expose
from svbrdf.trainer.config import resolve
from svbrdf.trainer.prior import _geometry, prior_preset
from svbrdf.trainer.procedural import sample_materials
from svbrdf.trainer.render import render_maps

model, n, size = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
mode = sys.argv[4] if len(sys.argv) > 4 else "photo"
pairs = [(float(a), float(b)) for a, b in zip(sys.argv[5::2], sys.argv[6::2])] or [(0.5, 0.4)]
if mode == "photo":
    S.EVEN_LIGHTING = None
S.FLASH_TREND = S.UNIFORM_SPECULAR = S.HIGHLIGHT_FILL = False
sess = S.load_session(model, threads=1)
g = torch.Generator().manual_seed(31_337_777)
maps, fams = sample_materials(n, size, g)
maps[:, SLICES["roughness"]] = 0.1 + 0.2 * torch.rand(n, 1, 1, 1, generator=g)
maps[:, SLICES["specular"]] = 0.04
rc = resolve(prior_preset("v2").finetune_preset).render_config.replace(falloff=True)
v, l, d2 = _geometry(size, size, (0.0, 0.0, rc.camera_distance), rc)
cam = Camera(ev=0.0, vignetting=0.1, shot=5e-4, read=2e-3, quantize=True)
r = np.hypot(np.arange(size)[:, None] + .5 - size / 2, np.arange(size)[None] + .5 - size / 2) / size


def scores(photo):
    m = S.estimate(photo, sess, max_size=size)
    b = burn_in_scores(m, (size / 2.0, size / 2.0))
    rough = m.roughness[..., 0]
    prof = [float(rough[(r >= a) & (r < a + 0.05)].mean()) for a in np.arange(0, 0.5, 0.05)]
    return b["ring_roughness"], b["ring_diffuse"], prof


rows = {}
for i in range(n):
    with torch.no_grad():
        spec = render_maps(maps[i:i + 1], v, l, rc, d2)[0]
        dull = maps[i:i + 1].clone()
        dull[:, SLICES["diffuse"]] = 0
        hazes = {}
        for w, dr in pairs:
            dull[:, SLICES["roughness"]] = (maps[i:i + 1, SLICES["roughness"]] + dr).clamp(max=1.0)
            hazes[(w, dr)] = spec + w * render_maps(dull, v, l, rc, d2)[0]
    for key, rad in [((0.0, 0.0), spec), *hazes.items()]:
        photo = expose(rad.permute(1, 2, 0).numpy(), cam, seed=i)
        rows.setdefault(key, []).append(scores(photo))
    print(fams[i], {k: round(v[-1][0], 3) for k, v in rows.items()}, flush=True)
for key, v in rows.items():
    rr = np.array([x[0] for x in v]); rd = np.array([x[1] for x in v]); prof = np.mean([x[2] for x in v], 0)
    print(f"haze W {key[0]} DR {key[1]}: ring roughness {rr.mean():.4f}, ring diffuse {rd.mean():.4f}, "
          f"roughness by 0.05 W annulus {np.round(prof, 3).tolist()}", flush=True)
