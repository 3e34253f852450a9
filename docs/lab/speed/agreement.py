"""The guided path's maps against today's at a large size (issue 54): the network at the photo's size (in tiles,
``Upsampling(network_size=None)``, the reference) against the network at 1024 px with the guided upsampling (the
default above 2048 px) and against the same 1024 px maps upsampled bilinearly (no detail from the photo).

::

    OMP_WAIT_POLICY=PASSIVE python docs/lab/speed/agreement.py PHOTO [PHOTO ...] --max-size 4096 --json out.json

Per map: mean and max absolute difference to the reference, and the mean absolute difference of the maps'
gradients (the fine detail: how much of the reference's detail is there); the label-free burn-in of each.
"""

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    from svbrdf.runtime.inference.guided import Upsampling, bilinear_rows
    from svbrdf.runtime.inference.pipeline import estimate
    from svbrdf.runtime.inference.session import load_session

    p = argparse.ArgumentParser()
    p.add_argument("photos", nargs="+")
    p.add_argument("--max-size", type=int, default=4096)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--json", type=Path)
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")
    session = load_session(threads=args.threads)
    out = {}
    for photo in args.photos:
        t = time.perf_counter()
        ref = estimate(photo, session, max_size=args.max_size, upsampling=Upsampling(network_size=None))
        t_ref = time.perf_counter() - t
        t = time.perf_counter()
        guided = estimate(photo, session, max_size=args.max_size)
        t_guided = time.perf_counter() - t
        h, w = ref.shape
        low = estimate(photo, session, max_size=1024)
        row = {"size": [h, w], "seconds": {"reference": t_ref, "guided": t_guided},
               "burn_in": {"reference": ref.meta["burn_in"]["burn_in"], "guided": guided.meta["burn_in"]["burn_in"]}}
        for name in ref.names:
            r = getattr(ref, name)
            plain = np.clip(bilinear_rows(getattr(low, name), slice(0, h), (h, w)), 0, 1) if name != "normal" else None
            if name == "normal":
                from svbrdf.runtime.core.maps import normalize_normals
                plain = normalize_normals(bilinear_rows(low.normal, slice(0, h), (h, w)))
            entry = {}
            for label, m in (("guided", getattr(guided, name)), ("bilinear", plain)):
                d = np.abs(m - r)
                gr = np.abs(np.diff(m, axis=1) - np.diff(r, axis=1)).mean()
                entry[label] = {"mean": float(d.mean()), "max": float(d.max()), "gradient_mean": float(gr)}
            entry["reference_gradient_mean"] = float(np.abs(np.diff(r, axis=1)).mean())
            row[name] = entry
        out[Path(photo).name] = row
        print(json.dumps({Path(photo).name: row}, indent=1), flush=True)
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
