"""Probe (issues 26/27): why the v2 stage one reads relief on its own procedural materials and not on the shared
sets' (slope correlation ~0.4-0.6 held out against 0.14 on the 38 synthetic cases): the photo or the material?

Four crossings, each scored by the runtime's preview (the exported model, 256 px) with the bench's slope correlation
and normal angle against the flat map's:
  A. the shared sets' ground-truth maps photographed by the prior's training stream (``simulate_photos`` with the
     v2 preset's field of view, flash offset, renderer mix and camera ranges);
  B. the same maps as the bench photographs them (``prepare_case``: what every bench figure uses);
  C. held-out procedural materials (seed 31_337_001, not a training or validation seed) photographed by the prior;
  D. the same procedural materials photographed as the bench does (``simulate_photo``, ``sample_camera``, the
     physical renderer config).
A ~ B and C ~ D with A << C: the materials (their relief is not what the prior learned); A >> B or C >> D: the photo.
Each correlation is also given per band: the slopes blurred by a Gaussian of sigma 4 px (coarse) and the rest
(fine), with the share of the truth's slope variance in the fine band.
Evaluation only: nothing is tuned or trained on the shared sets here.

    OMP_NUM_THREADS=1 python docs/lab/relief_gap_probe.py MODEL.onnx OUT.json [N_PROCEDURAL [COARSE]]

With COARSE (a share in [0, 1], default 0) the procedural materials of C and D get the prior's coarse relief
(:func:`svbrdf.trainer.prior.add_coarse_relief`) at that share, drawn from its own generator (seed 31_337_002), so
the materials are otherwise the same; ``COARSE_ONLY=1`` in the environment skips A and B, and
``COARSE_STONES_P=p`` sets ``PARAMS["coarse_stones_p"]`` (the share of uneven stones among the coarse reliefs;
0: smooth warps only). ``DATA=DIR`` (default ``../shared/data``) and ``SIZE=N`` (default 256 px) in the environment
choose the shared sets and the side of every photo (``tests/lab/test_lab_scripts.py`` runs it on a tiny input).
"""
import json
import os
import sys
from pathlib import Path

import numpy as np
import torch

from svbrdf.trainer.camera_model import sample_camera
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, physical_config
from svbrdf.runtime.inference.pipeline import estimate
from svbrdf.runtime.inference.session import load_session
from svbrdf.trainer.bench.cases import load_cases, simulate_photo
from svbrdf.trainer.bench.metrics import _corr, _slopes, angular_error_deg, gaussian_blur
from svbrdf.trainer.prior import add_coarse_relief, prior_preset, simulate_photos
from svbrdf.trainer.procedural import PARAMS, sample_materials

DATA = Path(os.environ.get("DATA", "../shared/data"))
SIZE = int(os.environ.get("SIZE", "256"))
HELD_OUT_SEED = 31_337_001
#: The slopes are split into a coarse band (Gaussian blur of this sigma, pixels at 256 px) and the fine rest.
BAND_SIGMA = 4.0


def score(session, photo: np.ndarray, gt: Maps) -> dict:
    """Slope correlation and normal angle (preview, flat map) of one (H, W, 3) linear photo of ``gt``."""
    pred = estimate(np.ascontiguousarray(photo, dtype=np.float32), session)
    flat = np.zeros_like(gt.normal)
    flat[..., 2] = 1.0
    p, t = _slopes(pred.normal), _slopes(gt.normal)
    coarse = [np.stack([gaussian_blur(s[..., c], BAND_SIGMA) for c in (0, 1)], -1) for s in (p, t)]
    return {"rho": _corr(p, t), "rho_coarse": _corr(*coarse), "rho_fine": _corr(p - coarse[0], t - coarse[1]),
            "fine_share": float(np.var(t - coarse[1]) / max(np.var(t), 1e-12)),
            "angle": angular_error_deg(pred.normal, gt.normal), "flat": angular_error_deg(flat, gt.normal)}


def prior_photo(maps: Maps, cfg, rng: torch.Generator) -> np.ndarray:
    packed = torch.from_numpy(maps.pack()).permute(2, 0, 1)[None].float()
    photos, _, _ = simulate_photos(packed, cfg, rng)
    return photos[0].permute(1, 2, 0).numpy()


def summary(rows, label):
    r = np.mean([x["rho"] for x in rows])
    a, f = np.mean([x["angle"] for x in rows]), np.mean([x["flat"] for x in rows])
    rc, rf = np.mean([x["rho_coarse"] for x in rows]), np.mean([x["rho_fine"] for x in rows])
    share = np.mean([x["fine_share"] for x in rows])
    line = (f"{label}: n {len(rows)}, slope corr {r:.3f} (coarse {rc:.3f}, fine {rf:.3f}; the truth's fine share "
            f"{share:.2f}), angle {a:.3f} deg, flat {f:.3f} ({a / f:.3f}x)")
    print(line, flush=True)
    return line


def main(model: str, out: str, n_proc: int = 24, coarse: float = 0.0) -> None:
    if os.environ.get("COARSE_STONES_P"):
        PARAMS["coarse_stones_p"] = float(os.environ["COARSE_STONES_P"])
    session = load_session(model, threads=1)
    cfg = prior_preset("v2")
    rng = torch.Generator().manual_seed(HELD_OUT_SEED)
    a_rows, b_rows = [], []
    for case in ([] if os.environ.get("COARSE_ONLY") == "1" else load_cases(DATA, SIZE)):
        if case.kind != "synthetic":
            continue
        b_rows.append({"case": case.name, **score(session, case.photo, case.gt)})
        a_rows.append({"case": case.name, **score(session, prior_photo(case.gt, cfg, rng), case.gt)})
        print(f"{case.name[-40:]:40s} bench {b_rows[-1]['rho']:.3f} prior {a_rows[-1]['rho']:.3f}", flush=True)
    maps, families = sample_materials(n_proc, SIZE, torch.Generator().manual_seed(HELD_OUT_SEED))
    if coarse > 0:
        g = torch.Generator().manual_seed(HELD_OUT_SEED + 1)
        maps = add_coarse_relief(maps, torch.rand(n_proc, generator=g) < coarse, g)
    c_rows, d_rows = [], []
    for i in range(n_proc):
        gt = Maps.unpack(maps[i].permute(1, 2, 0).numpy())
        c_rows.append({"family": families[i], **score(session, prior_photo(gt, cfg, rng), gt)})
        seed = HELD_OUT_SEED + i
        photo = simulate_photo(gt, renderer="ours", config=physical_config(ZHAO), camera=sample_camera(seed), seed=seed)
        d_rows.append({"family": families[i], **score(session, photo, gt)})
        print(f"{families[i]:20s} prior {c_rows[-1]['rho']:.3f} bench {d_rows[-1]['rho']:.3f}", flush=True)
    print()
    lines = ([summary(a_rows, "A shared maps, prior's photos"), summary(b_rows, "B shared maps, bench's photos")]
             if a_rows else [])
    lines += [summary(c_rows, f"C procedural (coarse share {coarse:g}), prior's photos"),
              summary(d_rows, f"D procedural (coarse share {coarse:g}), bench's photos")]
    Path(out).write_text(json.dumps({"model": model, "summary": lines, "A": a_rows, "B": b_rows, "C": c_rows,
                                     "D": d_rows}, indent=1))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], *(int(a) for a in sys.argv[3:4]), *(float(a) for a in sys.argv[4:5]))
