"""The network's border frame (a probe): the preview's maps predicted on the photo padded by reflection (PAD px per
side) and cropped back, against the shipped preview; the benchmark's measures per variant, and the frame itself
(the roughness's mean gradient in the outer 4 px over its median).

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/lobe-and-rings/scripts/pad_probe.py CASES OUT.json PAD[,PAD...]

CASES: ``procedural:N`` (held-out, seed 987654) or ``shared:GLOB``.
"""
import sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime import session as S
from svbrdf.trainer.bench.metrics import evaluate

sys.path.insert(0, str(Path(__file__).parent))
from rings_lib import probe_cases, write_means  # noqa: E402

warnings.simplefilter("ignore")
src, out, pads = sys.argv[1], Path(sys.argv[2]), [int(p) for p in sys.argv[3].split(",")]
cases = probe_cases(src)
KEYS = ["rerender_rmse", "input_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg",
        "grazing_rmse", "burn_in", "capture_rmse", "capture_ssim", "frame"]
session = S.load_session(threads=1)
plain = S.tiled_apply


def padded(pad):
    def apply(fn, image, tile, overlap):
        big = np.pad(image, ((pad, pad), (pad, pad), (0, 0)), mode="reflect")
        return plain(fn, big, tile + 2 * pad, overlap)[pad:-pad, pad:-pad]
    return apply


def frame(m):
    r = m.roughness[..., 0]
    g = (np.abs(np.diff(r, axis=1)).mean(0) + np.abs(np.diff(r, axis=0)).mean(1)) / 2
    return float(np.concatenate([g[:4], g[-4:]]).mean() / max(np.median(g), 1e-9))


rows, per = {}, {}
for case in cases:
    for pad in [0] + pads:
        S.tiled_apply = padded(pad) if pad else plain
        m = S.estimate(case.photo, session)
        e = evaluate(m, gt=case.gt, photo=None if case.gt is not None else case.photo, centre=case.centre,
                     capture=case.capture)
        e["frame"] = frame(m)
        name = f"preview pad {pad}"
        rows.setdefault((case.kind, name), []).append(e)
        per.setdefault(case.name, {})[name] = {k: e.get(k) for k in KEYS}
    S.tiled_apply = plain
    print(case.name, flush=True)
write_means(rows, per, KEYS, out)
