"""Probe (issue 27 item 4, the shipped v2's near-black specular): does the photo tell the specular level of the
shared sets' near-black materials, given the preview's other maps?

The lobe_level_probe.py grid (``../../refine-detail/scripts/lobe_level_probe.py``: roughness shifted by d, specular
set to one level s; per (d, s) the fine-tune's photo loss, `svbrdf.trainer.losses.render_loss`, at the best of a
few exposure gains) on the near-black synthetic cases of every shared set (``black_cases.py``'s 29), each
re-rendered by the project renderer under the co-located flash with the metrics' physical settings (the bench's
photo may be Mitsuba's). A diagnostic, not a tuning: nothing it finds is applied; it asks whether a level fit from
the photo could replace the preview's level at all.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/black_level_probe.py MODEL.onnx OUT.jsonl [GROUP]

GROUP: ``black`` (default, the 29), ``other`` (the 9 synthetic cases that are not near-black) or ``all``.
"""
import json
import sys
import warnings

import numpy as np
import torch

import svbrdf.runtime.session as S
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.render import ZHAO, physical_config, render
from svbrdf.trainer.bench.cases import prepare_case
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.losses import render_loss

from black_cases import darkness  # the same near-black split (this script's folder is on the path)

warnings.simplefilter("ignore")
model, out = sys.argv[1], sys.argv[2]
group = sys.argv[3] if len(sys.argv) > 3 else "black"
sess = S.load_session(model, threads=1)
cases = sorted((c for c, dark in darkness().items() if group == "all" or dark == (group == "black")),
               key=lambda c: c.name)
D = (-0.3, -0.15, -0.05, 0.0, 0.05, 0.15, 0.3)
SPEC = (0.02, 0.04, 0.06, 0.08, 0.12, 0.16, 0.24, 0.32, 0.48, 0.64)
GAINS = 2.0 ** np.arange(-0.75, 0.76, 0.25)
rc = physical_config(ZHAO)


def with_lobe(m: Maps, d: float, s: float) -> Maps:
    return m._with({**dict(m.items()), "roughness": np.clip(m.roughness + d, 0.03, 1.0),
                    "specular": np.full_like(m.specular, s)})


rows = []
with open(out, "w") as f:
    for found in cases:
        case = prepare_case(found, 256)
        pred = S.estimate(case.photo, sess)
        pt = torch.from_numpy(case.photo).permute(2, 0, 1)[None]
        best = None
        for d in D:
            for s in SPEC:
                rt = torch.from_numpy(render(with_lobe(pred, d, s), None, rc)).permute(2, 0, 1)[None]
                loss = min(float(render_loss(rt * float(g), pt)) for g in GAINS)
                if best is None or loss < best[0]:
                    best = (loss, d, s)
        rec = {"case": case.name, "truth_specular": round(float(case.gt.specular.mean()), 3),
               "pred_specular": round(float(pred.specular.mean()), 3), "fit_d": best[1], "fit_s": best[2]}
        for tag, m in (("preview", pred), ("fit", with_lobe(pred, best[1], best[2]))):
            e = evaluate(m, gt=case.gt, centre=case.centre)
            rec.update({f"{tag}_{k}": round(e[k], 4) for k in ("roughness_rmse", "specular_rmse", "rerender_rmse")})
        rows.append(rec)
        f.write(json.dumps(rec) + "\n")
        print(json.dumps(rec), flush=True)
for k in ("specular_rmse", "roughness_rmse", "rerender_rmse"):
    print(f"{k}: preview {np.mean([r['preview_' + k] for r in rows]):.4f}, fit {np.mean([r['fit_' + k] for r in rows]):.4f}")
