"""Copy the artist table of a benchmark run into the headline summary (docs/benchmarks/summary.json, key
``artist``, with the run it came from) and print it as the README's Markdown table.

    python docs/benchmarks/artist/scripts/publish.py docs/benchmarks/artist/summary.json docs/benchmarks/summary.json
"""
import json
import sys

from svbrdf.trainer.bench.report import _fmt

src, dst = sys.argv[1], sys.argv[2]
run = json.load(open(src))
doc = json.load(open(dst))
doc["artist"] = run["artist"]
doc["artist_source"] = {"summary": src, "command": run["command"], "date": run["date"]}
with open(dst, "w") as f:
    json.dump(doc, f, indent=1)
    f.write("\n")
base = next(r for r in run["artist"] if r["method"] == "baseline")
cols = [("capture_rmse", "real capture relit (sRGB RMSE)"), ("capture_ssim", "real capture SSIM"),
        ("grazing_rmse", "grazing lights RMSE"), ("grazing_hp_corr", "grazing detail corr"),
        ("detail_normal", "normal detail"), ("normal_slope_corr", "normal slope corr"),
        ("detail_diffuse", "base colour detail"), ("detail_roughness", "roughness detail"), ("detail_specular", "specular detail"),
        ("burn_in_synthetic", "burn-in (synthetic)"), ("burn_in_photos", "burn-in (real photos)"),
        ("seconds", "seconds")]
print("| method | " + " | ".join(h for _, h in cols) + " |")
print("|---" * (len(cols) + 1) + "|")
for r in run["artist"]:
    name = {"baseline": "trivial baseline", "preview": "preview", "ground truth": "ground truth (chance level)"}.get(
        r["method"], f"refine ({r['preset']}, {r['iterations']} it)")
    print(f"| {name} | " + " | ".join(_fmt(r.get(k)) for k, _ in cols) + " |")
