"""Measure the refine's keep-the-preview check (issue 53, item 4) on one part of the shared data.

For every case: the instant preview (``estimate``, as ``svbrdf-bench --methods preview``), today's refine
(``svbrdf.trainer.refine.refine`` from the packaged stage one, the function ``svbrdf-preview --refine`` calls, without
a preview so no check) and the label-free quantities of ``svbrdf.runtime.quality.refine_check`` (both burn-ins, both
input-flash re-render errors, and the drift of the refined maps' renders from the preview's under the 3 x 3 novel
lights). Every map set is scored with the benchmark's own ``evaluate`` (same cases, same settings as
``svbrdf-bench --size 256``). The refine-with-check column is derived from these records (``table.py``), so any
threshold can be tried on the tune part without refitting.

    python measure.py --split tune --cases 'GLOB,...' --out tune.json [--iters 150] [--threads 1]
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def check_refine(preview, refined, photo, config, burn_margin=0.0, input_gain=0.0):
    """The rule measured (commit 30de15c's ``svbrdf.runtime.quality.refine_check.check_refine``): keep the preview
    when the refined maps' ``photo_burn_in`` exceeds the preview's by more than ``burn_margin`` or their sRGB input-flash
    re-render error is not lower than the preview's by at least ``input_gain``. Maps (H, W), photo (H, W, 3) linear."""
    from svbrdf.runtime.core.render import rerender_rmse
    from svbrdf.runtime.quality.burn_in import photo_burn_in

    pb, rb = (float(photo_burn_in(m, photo)["burn_in"]) for m in (preview, refined))
    pe, re = (rerender_rmse(m, photo, [None], config) for m in (preview, refined))
    reason = None
    if rb > pb + burn_margin:
        reason = f"the refine raised the burn-in ({pb:.2f} -> {rb:.2f})"
    elif re > pe - input_gain:
        reason = f"the refine did not lower the input re-render error enough ({pe:.3f} -> {re:.3f})"
    return {"kept_preview": reason, "preview_burn_in": pb, "refined_burn_in": rb, "preview_input_rmse": pe,
            "refined_input_rmse": re, "burn_in_margin": burn_margin, "input_gain": input_gain}


def main(argv=None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--split", choices=("tune", "check"), required=True)
    p.add_argument("--cases", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--iters", type=int, default=150)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--size", type=int, default=256)
    a = p.parse_args(argv)

    import torch

    torch.set_num_threads(a.threads)
    from svbrdf.runtime.core.render import ZHAO, novel_lights, rerender_rmse
    from svbrdf.runtime.inference.pipeline import estimate
    from svbrdf.runtime.inference.session import load_session
    from svbrdf.trainer.bench.cases import load_cases
    from svbrdf.trainer.bench.common import default_data
    from svbrdf.trainer.bench.metrics import evaluate
    from svbrdf.trainer.checkpoint import default_checkpoint, load_checkpoint
    from svbrdf.trainer.refine import refine

    config = ZHAO  # svbrdf-bench's evaluation settings
    cases = load_cases(default_data(), a.size, a.cases, a.split, realistic=True, renderer="auto", config=config)
    session = load_session(None, threads=a.threads)
    ckpt = load_checkpoint(default_checkpoint(None))
    out = []
    for case in cases:
        ev = dict(gt=case.gt, photo=case.photo if case.gt is None else None, config=config, centre=case.centre,
                  capture=case.capture)
        preview = estimate(case.photo, session)
        t = time.perf_counter()
        refined = refine(case.photo, ckpt, quality="fixed", iters=a.iters, threads=a.threads, name=case.name)
        secs = time.perf_counter() - t
        chk = check_refine(preview, refined, case.photo, session.render_config)
        chk["novel_drift"] = rerender_rmse(refined, preview, [tuple(map(float, l)) for l in novel_lights(config)],
                                           session.render_config)
        rec = {"case": case.name, "kind": case.kind, "capture": case.capture is not None, "refine_seconds": secs,
               "check": chk, "preview": evaluate(preview, **ev), "refine": evaluate(refined, **ev)}
        out.append(rec)
        pr, rf = rec["preview"], rec["refine"]
        print(f"{case.name} | {secs:.1f} s | burn {chk['preview_burn_in']:.3f}->{chk['refined_burn_in']:.3f} | "
              f"in {chk['preview_input_rmse']:.4f}->{chk['refined_input_rmse']:.4f} | drift {chk['novel_drift']:.4f}"
              f" | capture {pr.get('capture_rmse')} -> {rf.get('capture_rmse')}", flush=True)
        with open(a.out, "w") as f:
            json.dump({"argv": sys.argv, "split": a.split, "cases": a.cases, "iters": a.iters, "records": out}, f,
                      indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
