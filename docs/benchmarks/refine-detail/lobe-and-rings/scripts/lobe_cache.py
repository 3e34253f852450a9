"""Maps to try the lobe fit on (issue 27, items 2 and 4): for each case, the preview (0 iterations) and the default
refine (``fast``, 150) of a stage one, saved with the photo and the truth so that post-processing variants are
cheap to compare (``lobe_probe.py``). Held-out procedural materials (seed 987654, the tuning set of this folder) or
shared cases (evaluation only: never tuned on).

    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/lobe-and-rings/scripts/lobe_cache.py procedural:N OUT_DIR [PART PARTS]
    OMP_NUM_THREADS=1 python docs/benchmarks/refine-detail/lobe-and-rings/scripts/lobe_cache.py 'shared:GLOB' OUT_DIR [PART PARTS]

Optional env: INIT (checkpoint), MODEL (ONNX), OVERRIDES (JSON TrainConfig overrides). Resumable.
"""
import json, os, pickle, sys, time, warnings
from pathlib import Path

from svbrdf.trainer.bench.methods import METHODS, BenchOptions

sys.path.insert(0, str(Path(__file__).parent))
from rings_lib import probe_cases  # noqa: E402

warnings.simplefilter("ignore")
src, out = sys.argv[1], Path(sys.argv[2])
part, parts = (int(sys.argv[3]), int(sys.argv[4])) if len(sys.argv) > 4 else (0, 1)
out.mkdir(parents=True, exist_ok=True)
cases = probe_cases(src)
ovr = json.loads(os.environ.get("OVERRIDES", "{}"))
for i in range(part, len(cases), parts):
    case = cases[i]
    f = out / (case.name.replace("/", "_").replace(";", "_") + ".pkl")
    if f.exists():
        continue
    t = time.time()
    pts = []
    METHODS["finetune"].run(case, BenchOptions(iters=[0, 150], threads=1, repeats=1, train_overrides=ovr,
                                               init=os.environ.get("INIT"), model=os.environ.get("MODEL")),
                            "fast", pts.append)
    pre, fin = (p.maps for p in sorted(pts, key=lambda p: p.iterations))
    tmp = f.with_suffix(".tmp")
    tmp.write_bytes(pickle.dumps({"case": case, "preview": pre, "fast": fin}))
    tmp.rename(f)
    print(f"{case.name} {time.time() - t:.0f}s", flush=True)
