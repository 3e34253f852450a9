"""`svbrdf-bench` with the preview's network run at SIDE px and its maps upsampled (`scale_probe.py`'s variants),
for the real capture at its own size (`--cases 'guo*' --size 1024`).

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/scale_bench.py SIDE bilinear|guided -- BENCH ARGS...

Photos whose long side is at most SIDE go through the runtime unchanged.
"""
import sys

import numpy as np

import svbrdf.runtime.session as S
from scale_probe import at_scale

side, mode = int(sys.argv[1]), sys.argv[2]
assert mode in ("bilinear", "guided") and sys.argv[3] == "--", __doc__
_estimate = S.estimate


def estimate(photo, session=None, **kw):
    if isinstance(photo, np.ndarray) and max(photo.shape[:2]) > side and not kw:
        return at_scale(photo, session, side, mode == "guided")
    return _estimate(photo, session, **kw)


S.estimate = estimate
from svbrdf.trainer.bench.cli import main  # noqa: E402

sys.argv = ["svbrdf-bench"] + sys.argv[4:]
sys.exit(main())
