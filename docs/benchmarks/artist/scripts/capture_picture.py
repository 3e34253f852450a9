"""The bath_tile picture of the artist measures: one view of the real multi-view capture as the input, the maps of
each method, and the maps relit at two other views beside the real photos of those views.

    OMP_NUM_THREADS=1 python docs/benchmarks/artist/scripts/capture_picture.py 07 01,04 docs/benchmarks/artist/bath_tile.jpg

Rows: baseline, preview, default refine (finetune, preset fast, 150 iterations). Columns: input photo, base
colour, normal, roughness, specular, then for each of the two views: the maps relit there (one exposure fitted,
as capture_rmse does: svbrdf.trainer.bench.metrics.relight_view) and the real photo, its clipped pixels tinted
magenta. A JSON beside the PNG gives each row's capture_rmse / capture_ssim over all other views.
"""
import json
import sys
from pathlib import Path

import numpy as np

from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.imageio import write_image
from svbrdf.runtime.maps import encode_normal
from svbrdf.trainer.bench.cases import load_cases
from svbrdf.trainer.bench.common import default_data
from svbrdf.trainer.bench.methods import METHODS, BenchOptions
from svbrdf.trainer.bench.metrics import capture_errors, relight_view

view, others, out = sys.argv[1], [int(v) for v in sys.argv[2].split(",")], Path(sys.argv[3])
case = load_cases(default_data(), 256, f"guo-svbrdf-diff-renderer/bath_tile/{view}")[0]
opts = BenchOptions(iters=[150], threads=1, repeats=1)
rows, doc = [], {"command": "python " + " ".join(sys.argv), "input_view": view, "relit_views": others, "rows": []}
for method, preset in (("baseline", None), ("preview", None), ("finetune", "fast")):
    pts = []
    METHODS[method].run(case, opts, preset, pts.append)
    m = pts[-1].maps.clipped()
    grey = lambda a: np.repeat(a, 3, axis=-1)  # noqa: E731
    parts = [linear_to_srgb(case.photo, clip=True), linear_to_srgb(m.diffuse, clip=True), encode_normal(m.normal),
             grey(m.roughness), grey(linear_to_srgb(m.specular, clip=True))]
    for j in others:
        relit, ref, ok = relight_view(m, case.capture, j)
        ref = ref.copy()
        ref[~ok] = 0.5 * ref[~ok] + 0.5 * np.array([1.0, 0.0, 1.0])
        parts += [relit, ref]
    rows.append(np.concatenate([np.asarray(p, np.float32) for p in parts], axis=1))
    errs = capture_errors(m, case.capture)
    doc["rows"].append({"method": method, "preset": preset, "iterations": pts[-1].iterations, **errs})
    print(method, errs, flush=True)
write_image(out, np.concatenate(rows, axis=0), bits=8, colour_space="sRGB", force=True)
out.with_suffix(".json").write_text(json.dumps(doc, indent=1))
