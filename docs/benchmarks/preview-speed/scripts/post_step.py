"""The preview's post step at 1024 px with and without the flash-trend removal: `estimate` on one Henzler photo resized
by the benchmark's case loader, 5 runs interleaved, medians of the whole call and of `timings["post"]`.

    OMP_NUM_THREADS=2 python docs/benchmarks/preview-speed/scripts/post_step.py
"""
import time, numpy as np, warnings, statistics as st
import svbrdf.runtime.session as S
from svbrdf.runtime.imageio import read_image
warnings.simplefilter("ignore")
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.common import default_data
c = load_cases(default_data(), 1024, "henzler-flash/test/2003*")[0]
sess = S.load_session(threads=2)
S.estimate(c.photo, sess)
res = {True: [], False: []}
for i in range(5):
    for flag in (False, True):
        S.FLASH_TREND = flag
        t = time.perf_counter(); m = S.estimate(c.photo, sess); res[flag].append((time.perf_counter() - t, m.meta["timings"]["post"]))
for f, v in res.items():
    print("FLASH_TREND", f, "total median %.3f s, post median %.3f s" % (st.median(x[0] for x in v), st.median(x[1] for x in v)))
