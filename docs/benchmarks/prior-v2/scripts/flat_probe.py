"""Does a v2 checkpoint give a flat material a relief? Held-out materials of every family photographed twice, as
drawn and with their normals made flat (:func:`svbrdf.trainer.prior.flatten_normals`; the same base colour,
specular and roughness, the same flash, field of view and camera draws): the predicted normals' mean tilt on
each (degrees from the vertical; on the flat photos that is the normal angle error itself) and the truth's.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/flat_probe.py CKPT TAG OUT.jsonl [PER_FAMILY]

PER_FAMILY (default 4) whole 256 px photos per family, seed 31_337_001 + family index (not a training or
validation seed of the run; the family probe's); one record per family and one for all, appended to OUT.jsonl.
"""
import dataclasses
import json
import sys

import torch

from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.checkpoint import load_generator
from svbrdf.trainer.procedural import FAMILIES
from svbrdf.trainer.prior import PriorConfig, draw_materials, flatten_normals, photograph

from height_common import tilt

src, tag, out = sys.argv[1], sys.argv[2], sys.argv[3]
per = int(sys.argv[4]) if len(sys.argv) > 4 else 4
model, meta = load_generator(src)  # the moving average where the run keeps one
config = PriorConfig.from_dict(meta["prior_config"])
sl = SLICES["normal"]
acc = {"relief": [], "flat": [], "truth": []}
with open(out, "a") as f:
    for i, fam in enumerate(FAMILIES):
        cfg = dataclasses.replace(config, crop_share=0.0, families=(fam,), flat_share=0.0)
        rec = {"tag": tag, "family": fam, "n": per}
        for kind in ("relief", "flat"):
            rng = torch.Generator().manual_seed(31_337_001 + i)
            maps, fams, crop = draw_materials(cfg, rng, batch=per)
            if kind == "flat":
                maps = flatten_normals(maps, torch.ones(per, dtype=torch.bool))
            photos, maps, _ = photograph(cfg, rng, maps, fams, crop)
            with torch.no_grad():
                p = model(photos)
            rec[f"tilt_{kind}"] = round(tilt(p[:, sl]), 3)
            acc[kind].append(rec[f"tilt_{kind}"])
            if kind == "relief":
                rec["truth_tilt"] = round(tilt(maps[:, sl]), 3)
                acc["truth"].append(rec["truth_tilt"])
        print(json.dumps(rec), flush=True)
        f.write(json.dumps(rec) + "\n")
    rec = {"tag": tag, "family": "all", "n": per * len(FAMILIES),
           **{("truth_tilt" if k == "truth" else f"tilt_{k}"): round(sum(v) / len(v), 3) for k, v in acc.items()}}
    print(json.dumps(rec), flush=True)
    f.write(json.dumps(rec) + "\n")
