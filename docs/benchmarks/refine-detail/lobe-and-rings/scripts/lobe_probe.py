"""The lobe fit (``lobe_fit.py`` beside this script) applied to cached maps (``lobe_cache.py``): each case's preview and
default refine, as they are and with the fit at 1 / 2 / 3 classes; the benchmark's measures (evaluate) averaged.

    python docs/benchmarks/refine-detail/lobe-and-rings/scripts/lobe_probe.py CACHE_DIR OUT.json [VARIANTS]

VARIANTS: comma-separated ``classes`` counts (default 1,2,3).
"""
import pickle, sys, warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from rings_lib import write_means  # noqa: E402
from lobe_fit import fit_lobes  # noqa: E402  (a probe, not part of the package)
from svbrdf.runtime.render import ZHAO
from svbrdf.trainer.bench.metrics import evaluate

warnings.simplefilter("ignore")
cache, out = Path(sys.argv[1]), Path(sys.argv[2])
ks = [int(k) for k in (sys.argv[3] if len(sys.argv) > 3 else "1,2,3").split(",")]
CONFIG = ZHAO.replace(falloff=True)  # the fine-tune's flash model (fast)
KEYS = ["rerender_rmse", "input_rmse", "diffuse_rmse", "specular_rmse", "roughness_rmse", "normal_angle_deg",
        "grazing_rmse", "burn_in", "detail_roughness", "capture_rmse", "capture_ssim"]
rows, per = {}, {}
for f in sorted(cache.glob("*.pkl")):
    d = pickle.loads(f.read_bytes())
    case = d["case"]
    for src in ("preview", "fast"):
        variants = {src: d[src]}
        from svbrdf.runtime.burn_in import photo_burn_in
        located = tuple(photo_burn_in(d[src], case.photo)["centre"] or (128, 128))
        for k in ks:
            variants[f"{src}+lobe{k}"] = fit_lobes(d[src], case.photo, CONFIG, classes=k)
            variants[f"{src}+lobe{k}@hl"] = fit_lobes(d[src], case.photo, CONFIG, classes=k, centre=located)
        for name, m in variants.items():
            e = evaluate(m, gt=case.gt, photo=None if case.gt is not None else case.photo, centre=case.centre,
                         capture=case.capture)
            rows.setdefault(name, []).append(e)
            per.setdefault(case.name, {})[name] = {**{k: e.get(k) for k in KEYS},
                                                  "lobes": m.meta.get("lobes")}
    print(case.name, flush=True)
write_means(rows, per, KEYS, out)
