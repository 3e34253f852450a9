"""Probe (issue 27, item 1): how far can the stage one's normals go on the shared sets by their strength alone?

The criterion asks the default refine's normal angle to be at most 0.9x the flat map's. The refine keeps the stage
one's normals (the anchor), so this asks the stage one's relief. Here each synthetic case's preview normals (the
runtime's, as ``svbrdf-bench --methods preview`` makes them, 256 px) have their slopes scaled by k and the mean
normal angle is scored per k, with the best k per case (an oracle: it reads the truth) and the flat map (k = 0).
Evaluation only: nothing here is used by the package or tuned; the oracle is a bound, not a setting.

For slopes ``p`` that correlate ``rho`` with the true ``t``, the best scale leaves a slope RMS error of
``sqrt(1 - rho^2)`` of the flat map's (least squares), which would put 0.9x near ``rho`` 0.44; the mean angle is
not an RMS, so the script measures it instead: the truth's own slopes blended with independent noise of the same
spectrum at correlation ``rho``, the best scale per case (printed last; on 2026-11-27: 0.9x needs ``rho`` above
0.6).

    OMP_NUM_THREADS=1 python docs/lab/normal_bound.py MODEL.onnx OUT.json

``DATA=DIR`` (default ``../shared/data``) and ``SIZE=N`` (default 256 px) in the environment choose the shared sets
and the side of every photo (``tests/lab/test_lab_scripts.py`` runs it on a tiny input).
"""
import json
import os
import sys
from pathlib import Path

import numpy as np

from svbrdf.runtime.inference.pipeline import estimate
from svbrdf.runtime.inference.session import load_session
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.metrics import _corr, _slopes, angular_error_deg

KS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0)
RHOS = (0.15, 0.3, 0.44, 0.6)
DATA = Path(os.environ.get("DATA", "../shared/data"))
SIZE = int(os.environ.get("SIZE", "256"))


def from_slopes(s: np.ndarray) -> np.ndarray:
    """Unit normals (H, W, 3) whose slopes ``(-n_x/n_z, -n_y/n_z)`` are ``s`` (H, W, 2)."""
    n = np.concatenate([-s, np.ones(s.shape[:2] + (1,))], -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def main(model: str, out: str) -> None:
    session = load_session(model, threads=1)
    rows = []
    rng = np.random.default_rng(0)
    for case in load_cases(DATA, SIZE):
        if case.kind != "synthetic":
            continue
        pred = estimate(case.photo, session)
        p, t = _slopes(pred.normal), _slopes(case.gt.normal)
        row = {"case": case.name, "rho": _corr(p, t),
               "angle": {str(k): angular_error_deg(from_slopes(k * p), case.gt.normal) for k in KS}}
        # truth blended with noise at correlation rho (the noise: the truth's slopes shuffled in 2D frequency phase)
        f = np.fft.fft2(t, axes=(0, 1))
        noise = np.real(np.fft.ifft2(f * np.exp(2j * np.pi * rng.random(f.shape)), axes=(0, 1)))
        noise *= np.std(t) / max(np.std(noise), 1e-12)
        row["blend"] = {}
        for rho in RHOS:
            s = rho * t + np.sqrt(1 - rho ** 2) * noise  # correlation rho with t, the truth's variance
            best = min(angular_error_deg(from_slopes(k * s), case.gt.normal) for k in np.linspace(0, 1.5, 31))
            row["blend"][str(rho)] = best
        rows.append(row)
        print(f"{case.name[-45:]:45s} rho {row['rho']:.3f} flat {row['angle']['0.0']:.2f} k1 {row['angle']['1.0']:.2f} "
              f"best {min(row['angle'].values()):.2f}", flush=True)
    flat = np.mean([r["angle"]["0.0"] for r in rows])
    print(f"\n{len(rows)} synthetic cases, flat map {flat:.3f} deg")
    for k in KS:
        a = np.mean([r["angle"][str(k)] for r in rows])
        print(f"k {k:4.1f}: {a:.3f} deg ({a / flat:.3f}x flat)")
    oracle = np.mean([min(r["angle"].values()) for r in rows])
    print(f"oracle k per case: {oracle:.3f} deg ({oracle / flat:.3f}x flat); mean rho {np.mean([r['rho'] for r in rows]):.3f}")
    for rho in RHOS:
        a = np.mean([r["blend"][str(rho)] for r in rows])
        print(f"truth blended with noise at rho {rho}, best k per case: {a:.3f} deg ({a / flat:.3f}x flat)")
    Path(out).write_text(json.dumps({"model": model, "rows": rows}, indent=1))


if __name__ == "__main__":
    main(*sys.argv[1:3])
