"""Peak RSS of one preview of a 2048 x 1536 array (tiled in 1024 px windows) with onnxruntime's CPU arena off,
on and kept between passes, or on and shrunk after every pass (the default since the large-photos change).

    OMP_NUM_THREADS=2 python docs/benchmarks/large-photos/arena_probe.py off|keep|shrink
"""

import resource
import sys

import numpy as np

from svbrdf.runtime import session as S

mode = sys.argv[1]
S.CPU_MEM_ARENA = mode != "off"
if mode == "keep":
    S.PreviewSession._run_options = lambda self: None  # no arena shrinkage
sess = S.load_session(None, threads=2)
img = np.random.default_rng(0).random((1536, 2048, 3), dtype=np.float32) * 0.5
S.estimate(img, sess)
print(mode, f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")
