"""Probe: the preview's specular level fitted to the photo instead of taken from the network (the runtime's median).

For each photo, the preview's maps (the runtime's :func:`svbrdf.runtime.session.estimate` with MODEL) are rendered
under a co-located flash above the photo's centre (the fine-tune's renderer, ``fast``: ZHAO with fall-off) as the
diffuse part D and the specular part S1 at specular albedo 1 (F = F0 under a co-located flash, so the specular
part is linear in the level). Over the photo's unclipped pixels (max channel < 0.98) the level s is then chosen:

* ``fixed``: exposure 1 (the renderer's scale is the photo's): s = <S1, p - D> / <S1, S1>;
* ``free``: exposure e and s both fitted (least squares on (e, e s)); where the diffuse part cannot fix the
  exposure (e <= 0 or s outside [0, 1]) the ``fixed`` level is kept.

Levels are clipped to [0.01, 1]. Reports the means of the benchmark's measures (svbrdf.trainer.bench.metrics.evaluate)
for the network's level (the preview as shipped), the two fitted levels and the true median level (an oracle), on
held-out procedural materials (seed 987654, as refine_probe.py) and, with CASES, the shared synthetic cases.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/spec_level_probe.py MODEL.onnx N OUT.json [CASES]
"""
import json, sys, warnings
from pathlib import Path

import numpy as np, torch
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.render import render
from svbrdf.runtime.session import estimate, load_session
from svbrdf.trainer.bench.metrics import evaluate
from svbrdf.trainer.config import resolve
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

warnings.simplefilter("ignore")
model, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
spec_cases = sys.argv[4] if len(sys.argv) > 4 else None
session = load_session(model, threads=1)
RC = resolve("fast").render_config
K = ["rerender_rmse", "input_rmse", "specular_rmse", "grazing_rmse"]


def with_spec(m: Maps, level: float) -> Maps:
    return m._with({**dict(m.items()), "specular": np.full_like(m.specular, level)})


def fit_levels(m: Maps, photo: np.ndarray):
    d = render(with_spec(m, 0.0), config=RC).astype(np.float64)
    s1 = render(with_spec(m, 1.0), config=RC).astype(np.float64) - d
    keep = np.broadcast_to((photo.max(axis=-1) < 0.98)[..., None], photo.shape)
    p, d, s1 = photo[keep].astype(np.float64), d[keep], s1[keep]
    fixed = float(np.dot(s1, p - d) / max(np.dot(s1, s1), 1e-12))
    a = np.stack([d, s1], 1)
    (e, es), *_ = np.linalg.lstsq(a, p, rcond=None)
    free = es / e if e > 1e-6 else float("nan")
    if not (np.isfinite(free) and 0.0 <= free <= 1.0):
        free = fixed
    return float(np.clip(fixed, 0.01, 1.0)), float(np.clip(free, 0.01, 1.0)), float(e)


def run(photos, gts, label):
    res, rows = {}, []
    for photo, gt, name in zip(photos, gts, label):
        m = estimate(photo, session, max_size=4096)
        net = float(np.median(m.specular))
        fixed, free, e = fit_levels(m, photo)
        truth = float(np.median(gt.specular))
        rows.append({"case": name, "truth": truth, "network": net, "fixed": fixed, "free": free, "exposure": e})
        for v, lvl in (("network", net), ("fixed", fixed), ("free", free), ("oracle", truth)):
            r = evaluate(with_spec(m, lvl), gt=gt)
            res.setdefault(v, []).append({k: r[k] for k in K})
        print(name, {k: round(v, 3) for k, v in rows[-1].items() if k != "case"}, flush=True)
    table = {v: {k: float(np.mean([r[k] for r in rs])) for k in K} for v, rs in res.items()}
    for v, t in table.items():
        print(v, {k: round(x, 4) for k, x in t.items()}, flush=True)
    return {"table": table, "rows": rows}


rng = torch.Generator().manual_seed(987654)
maps, names = sample_materials(n, 256, rng)
photos, gts, draws = simulate_photos(maps, PriorConfig(), rng)
result = {"procedural": run([p.permute(1, 2, 0).numpy().copy() for p in photos],
                            [Maps.unpack(g.permute(1, 2, 0).numpy()) for g in gts], names)}
if spec_cases:
    from svbrdf.trainer.bench.cases import load_cases
    cs = [c for c in load_cases(Path("../shared/data"), 256, spec_cases) if c.gt is not None]
    result["shared"] = run([c.photo for c in cs], [c.gt for c in cs], [c.name for c in cs])
json.dump(result, open(out, "w"), indent=1)
