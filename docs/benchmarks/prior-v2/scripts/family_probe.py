"""Held-out normals of a v2 checkpoint per procedural family: slope correlation, tilt, the truth's tilt, the angle
error against the flat map's, the angle at the best uniform scale of the predicted height (what the
correlation could buy with the right tilt), and (over all photos) the correlation of the predicted tilt with the
truth's per photo (does the network know how bumpy a material is).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/family_probe.py CKPT TAG OUT.jsonl [PER_FAMILY]

PER_FAMILY (default 8) whole 256 px photos of every family, drawn from seed 31_337_001 (not a training or
validation seed of the run); one record per family and one for all, appended to OUT.jsonl.
"""
import dataclasses
import json
import sys

import torch

import svbrdf.trainer.losses as L
from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.trainer.procedural import FAMILIES
from svbrdf.trainer.prior import PriorConfig, PriorTrainer, sample_batch

from height_common import tilt

src, tag, out = sys.argv[1], sys.argv[2], sys.argv[3]
per = int(sys.argv[4]) if len(sys.argv) > 4 else 8
ckpt = load_checkpoint(src)
tr = PriorTrainer(PriorConfig.from_dict(ckpt["prior_config"]), device="cpu", threads=1)
tr.load_resume(ckpt, src)
tr.model.eval()


def angle(n_pred: torch.Tensor, n_true: torch.Tensor) -> float:
    """Mean angle, degrees, between (B, 3, H, W) unit normals."""
    return float(torch.rad2deg(torch.acos((n_pred * n_true).sum(1).clamp(-1, 1))).mean())


def scaled(n: torch.Tensor, k: float) -> torch.Tensor:
    """Normals whose slopes (-n_x / n_z, -n_y / n_z) are ``k`` times those of ``n``."""
    m = torch.cat([n[:, :2] * k, n[:, 2:].clamp_min(0.05)], 1)
    return m / m.norm(dim=1, keepdim=True)


def record(name: str, p: torch.Tensor, m: torch.Tensor) -> dict:
    n_p, n_t = p[:, SLICES["normal"]], m[:, SLICES["normal"]]
    flat = torch.zeros_like(n_t)
    flat[:, 2] = 1
    per_photo = torch.stack([torch.rad2deg(torch.acos(n[:, 2].clamp(-1, 1))).flatten(1).mean(1) for n in (n_p, n_t)])
    best = min((angle(scaled(n_p, k), n_t), k) for k in (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0))
    return {"tag": tag, "family": name, "n": int(p.shape[0]), "normal_deg": round(angle(n_p, n_t), 3),
            "flat_deg": round(angle(flat, n_t), 3), "tilt": round(tilt(n_p), 3), "truth_tilt": round(tilt(n_t), 3),
            "slope_corr": round(1.0 - float(L.slope_correlation_loss(p, m)), 4),
            "best_scale": best[1], "best_scale_deg": round(best[0], 3),
            "tilt_corr": round(float(torch.corrcoef(per_photo)[0, 1]), 3)}


preds, truths = [], []
with open(out, "a") as f:
    for i, fam in enumerate(FAMILIES):
        cfg = dataclasses.replace(tr.config, crop_share=0.0, families=(fam,), flat_share=0.0)
        photos, maps, _ = sample_batch(cfg, torch.Generator().manual_seed(31_337_001 + i), batch=per)
        with torch.no_grad():
            p = tr.model(photos)
        preds.append(p)
        truths.append(maps)
        rec = record(fam, p, maps)
        print(json.dumps(rec), flush=True)
        f.write(json.dumps(rec) + "\n")
    rec = record("all", torch.cat(preds), torch.cat(truths))
    print(json.dumps(rec), flush=True)
    f.write(json.dumps(rec) + "\n")
