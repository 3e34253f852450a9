"""Probe (issue 27, item 1): can the photo itself say how strong a stage one's relief should be?

The v2 stage one's held-out normals correlate with the truth (slope correlation ~0.39) but their strength does not
follow the material's (a tilt of ~3 degrees on every family, `../../prior-v2/height/family_probe.jsonl`), so on
materials it reads poorly its relief costs more angle than it buys. Here each photo's predicted slopes are scaled by
k in a fixed set, the predicted maps re-rendered under the photo's own flash, and the k whose render is closest to
the photo (label-free: log-luminance L1 after a per-channel gain, clipped pixels left out) is chosen per photo.
Scored: the normal angle at the chosen k against k = 1, the flat map, the best single k for all photos and the
oracle k per photo. Only held-out procedural photos (seed 31_337_001, not a training or validation seed), so
nothing is tuned on the shared sets.

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/scripts/normal_strength_probe.py CKPT TAG OUT.jsonl [PER_FAMILY]
"""
import dataclasses
import json
import sys

import numpy as np
import torch

from svbrdf.runtime.maps import SLICES
from svbrdf.runtime.render import physical_config
from svbrdf.trainer.checkpoint import load_generator
from svbrdf.trainer.config import resolve
from svbrdf.trainer.procedural import FAMILIES
from svbrdf.trainer.prior import PriorConfig, _geometry, sample_batch
from svbrdf.trainer.render import render_maps

KS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0)


def angle(n_pred: torch.Tensor, n_true: torch.Tensor) -> torch.Tensor:
    """Per-photo mean angle, degrees, between (B, 3, H, W) unit normals: (B,)."""
    return torch.rad2deg(torch.acos((n_pred * n_true).sum(1).clamp(-1, 1))).flatten(1).mean(1)


def scaled(n: torch.Tensor, k: float) -> torch.Tensor:
    """Normals whose slopes are ``k`` times those of ``n`` (B, 3, H, W)."""
    m = torch.cat([n[:, :2] * k, n[:, 2:].clamp_min(0.05)], 1)
    return m / m.norm(dim=1, keepdim=True)


def photo_error(render: torch.Tensor, photo: torch.Tensor) -> float:
    """Label-free: L1 of log luminance-ish values after a per-channel median gain, unclipped lit pixels (3, H, W)."""
    ok = (photo.max(0).values < 0.97) & (photo.min(0).values > 2e-3) & (render.min(0).values > 1e-5)
    if ok.sum() < 100:
        return float("nan")
    d = torch.log(photo.clamp_min(1e-4)) - torch.log(render.clamp_min(1e-5))
    d = d[:, ok]
    d = d - d.median(1, keepdim=True).values
    return float(d.abs().mean())


def main() -> None:
    src, tag, out = sys.argv[1], sys.argv[2], sys.argv[3]
    per = int(sys.argv[4]) if len(sys.argv) > 4 else 8
    model, meta = load_generator(src)  # the moving average where the run keeps one
    config = PriorConfig.from_dict(meta["prior_config"])
    base = resolve(config.finetune_preset).render_config.replace(falloff=True)
    rows = []
    for i, fam in enumerate(FAMILIES):
        cfg = dataclasses.replace(config, crop_share=0.0, families=(fam,), flat_share=0.0)
        photos, maps, info = sample_batch(cfg, torch.Generator().manual_seed(31_337_001 + i), batch=per)
        with torch.no_grad():
            p = model(photos)
        n_p, n_t = p[:, SLICES["normal"]], maps[:, SLICES["normal"]]
        for j, d in enumerate(info["draws"]):
            rc = base.replace(fov_deg=d["fov_deg"])
            rc = physical_config(rc) if d["physical"] else rc
            h, w = photos.shape[-2:]
            v, l, d2 = _geometry(h, w, d["light"], rc)
            errs, angs = [], []
            for k in KS:
                q = p[j:j + 1].clone()
                q[:, SLICES["normal"]] = scaled(n_p[j:j + 1], k)
                with torch.no_grad():
                    r = render_maps(q, v, l, rc, d2)[0]
                errs.append(photo_error(r, photos[j]))
                angs.append(float(angle(q[:, SLICES["normal"]], n_t[j:j + 1])[0]))
            flat = torch.zeros_like(n_t[j:j + 1])
            flat[:, 2] = 1
            rows.append({"tag": tag, "family": fam, "photo": j, "photo_err": [round(e, 5) for e in errs],
                         "angle": [round(a, 3) for a in angs], "flat": round(float(angle(flat, n_t[j:j + 1])[0]), 3)})
        print(fam, flush=True)
    with open(out, "a") as f:
        for r in rows:
            f.write(json.dumps(r) + "\n")
    A = np.array([r["angle"] for r in rows])
    E = np.array([r["photo_err"] for r in rows])
    E = np.where(np.isnan(E), np.inf, E)
    chosen = A[np.arange(len(rows)), E.argmin(1)]
    summary = {"tag": tag, "n": len(rows), "flat": round(float(np.mean([r["flat"] for r in rows])), 3),
               "per_k": {str(k): round(float(A[:, i].mean()), 3) for i, k in enumerate(KS)},
               "chosen_by_photo": round(float(chosen.mean()), 3), "oracle_per_photo": round(float(A.min(1).mean()), 3),
               "chosen_k_hist": {str(k): int((E.argmin(1) == i).sum()) for i, k in enumerate(KS)},
               "corr_chosen_oracle_k": round(float(np.corrcoef(np.array(KS)[E.argmin(1)],
                                                               np.array(KS)[A.argmin(1)])[0, 1]), 3)}
    print(json.dumps(summary), flush=True)
    with open(out, "a") as f:
        f.write(json.dumps(summary) + "\n")


if __name__ == "__main__":
    main()
