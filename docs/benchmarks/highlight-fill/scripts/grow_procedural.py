"""The highlight fill's region size (svbrdf.runtime.highlight_fill.GROW) chosen on held-out procedural materials
(seed 987654, not a training seed of the stage one; never the shared sets): the preview of each realistic flash
photo (svbrdf.trainer.prior.simulate_photos) without the fill and with it at each GROW, scored against the truth
with the benchmark's metrics (svbrdf.trainer.bench.metrics.evaluate); means over the materials whose photo has a
clipped highlight that was filled.

    OMP_NUM_THREADS=1 python docs/benchmarks/highlight-fill/scripts/grow_procedural.py N OUT.json [grow|clip|patches]

With ``clip`` the variants are the clip level (svbrdf.runtime.highlight_fill.CLIP_LEVEL: 0.98, 0.9, 0.8, 0.6) at
the shipped GROW instead; with ``patches`` one copy against the patch-by-patch fill (PATCHES False / True).
Labels: ``grow<value>`` whatever the parameter.
"""
import json
import sys
import warnings

import numpy as np
import torch

import svbrdf.runtime.highlight_fill as F
import svbrdf.runtime.session as S
from svbrdf.runtime.maps import Maps
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

warnings.simplefilter("ignore")
n, out = int(sys.argv[1]), sys.argv[2]
MODES = {"grow": ("GROW", [0.25, 0.5, 1.0, 1.5]), "clip": ("CLIP_LEVEL", [0.98, 0.9, 0.8, 0.6]),
         "patches": ("PATCHES", [False, True])}
PARAM, VALUES = MODES[sys.argv[3] if len(sys.argv) > 3 else "grow"]
GROWS = VALUES
KEYS = ["rerender_rmse", "diffuse_rmse", "roughness_rmse", "grazing_hp_corr", "grazing_rmse", "burn_in",
        "ring_diffuse", "ring_roughness", "burn_diffuse", "burn_roughness", "detail_diffuse", "detail_roughness"]
rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, _ = simulate_photos(maps, PriorConfig(), rng)
sess = S.load_session()
records = []
for i in range(n):
    photo = photos[i].permute(1, 2, 0).numpy().copy()
    gt = Maps.unpack(gts[i].permute(1, 2, 0).numpy())
    row = {"material": f"proc{i}", "name": names[i]}
    for label, grow in [("none", None)] + [(f"grow{g}", g) for g in GROWS]:
        S.HIGHLIGHT_FILL = grow is not None
        if grow is not None:
            setattr(F, PARAM, grow)
        m = S.estimate(photo, sess)
        centre = tuple(m.meta["burn_in"]["centre"])
        e = evaluate(m, gt=gt, centre=centre)
        fill = m.meta.get("highlight_fill") or {}
        row[label] = {"filled": bool(fill.get("filled")), "share": fill.get("share"),
                      **{k: e.get(k) for k in KEYS}}
    records.append(row)
    print(row["material"], row["name"], {k: (v["filled"], round(v["burn_in"], 3), round(v["rerender_rmse"], 4))
                                          for k, v in row.items() if isinstance(v, dict)}, flush=True)
filled = [r for r in records if all(r[f"grow{g}"]["filled"] for g in GROWS)]
table = {}
for label in ["none"] + [f"grow{g}" for g in GROWS]:
    table[label] = {k: float(np.mean([r[label][k] for r in filled if r[label][k] is not None])) for k in KEYS}
print(f"{len(filled)} of {n} materials filled at every {PARAM} (labels grow<value>)")
for label, t in table.items():
    print(label, {k: round(v, 4) for k, v in t.items()})
with open(out, "w") as f:
    json.dump({"command": "python " + " ".join(sys.argv), "param": PARAM, "n_filled": len(filled), "table": table,
               "records": records}, f, indent=1)
