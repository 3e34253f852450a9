"""The benchmark's measures (evaluate) of cached maps (``../../lobe-and-rings/scripts/lobe_cache.py``: each case's
preview and default refine), several caches side by side, averaged per variant (``NAME:source``).

    python docs/benchmarks/refine-detail/flat-input/scripts/cache_score.py OUT.json NAME=CACHE_DIR [NAME=CACHE_DIR ...]
"""
import pickle, sys, warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[2] / "lobe-and-rings" / "scripts"))
from rings_lib import write_means  # noqa: E402
from svbrdf.trainer.bench.metrics import evaluate

warnings.simplefilter("ignore")
KEYS = ["rerender_rmse", "input_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg",
        "grazing_rmse", "burn_in", "detail_diffuse", "detail_roughness", "capture_rmse", "capture_ssim"]
out = Path(sys.argv[1])
rows, per = {}, {}
for arg in sys.argv[2:]:
    name, cache = arg.split("=", 1)
    for f in sorted(Path(cache).glob("*.pkl")):
        d = pickle.loads(f.read_bytes())
        case = d["case"]
        for src in ("preview", "fast"):
            e = evaluate(d[src], gt=case.gt, photo=None if case.gt is not None else case.photo, centre=case.centre,
                         capture=case.capture)
            rows.setdefault(f"{name}:{src}", []).append(e)
            per.setdefault(case.name, {})[f"{name}:{src}"] = {k: e.get(k) for k in KEYS}
write_means(rows, per, KEYS, out)
