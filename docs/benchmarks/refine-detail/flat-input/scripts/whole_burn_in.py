"""The preview's label-free burn-in (``meta["burn_in"]``, rings included) on every whole Henzler photo (not the
benchmark's centre crops) at SIZE px, with the network's input as it is and evenly lit at each width given.

    python docs/benchmarks/refine-detail/flat-input/scripts/whole_burn_in.py SIZE none,0.25 [DATA_DIR]
"""
import glob, sys, warnings
from pathlib import Path

import numpy as np

from svbrdf.runtime import session as S

warnings.simplefilter("ignore")
size, settings = int(sys.argv[1]), sys.argv[2].split(",")
data = Path(sys.argv[3]) if len(sys.argv) > 3 else Path(__file__).resolve().parents[5].parent / "shared" / "data"
sess = S.load_session()
scores = {s: [] for s in settings}
print("| photo | " + " | ".join(settings) + " |")
print("|---" * (len(settings) + 1) + "|")
for f in sorted(glob.glob(str(data / "henzler-flash" / "test" / "*" / "*.JPG"))):
    row = []
    for s in settings:
        S.EVEN_LIGHTING = None if s == "none" else float(s)
        b = S.estimate(f, sess, max_size=size).meta["burn_in"]["burn_in"]
        scores[s].append(b)
        row.append(f"{b:.3f}")
    print(f"| {Path(f).name} | " + " | ".join(row) + " |", flush=True)
print("| mean | " + " | ".join(f"{np.mean(v):.3f}" for v in scores.values()) + " |")
