"""Markdown tables of the highlight-free accuracy benchmark (docs/benchmarks/accuracy/tables.md).

::

    python -m svbrdf.trainer.tools.accuracy_tables docs/benchmarks/accuracy/results.json \\
        --tuning '*10_brick*,*36_leather*,*0000026;*,*28_metal*' \\
        --henzler-falloff docs/benchmarks/accuracy/henzler-fast-v1/results.json \\
        --henzler-falloff docs/benchmarks/accuracy/henzler-fast/results.json \\
        --ablation 'LABEL=RESULTS_JSON:METHOD:PRESET:ITERATIONS' ... --out docs/benchmarks/accuracy/tables.md

Tables: the mean per-map errors, re-render RMSE and burn-in over the synthetic cases (all, and without the tuning
cases) per method, preset and iteration count, with the ground truth's own burn-in; the label-free scores of the
real photos; optionally the real photos' input-flash RMSE with fall-off from runs that recorded it; and an
ablation table with one row per ``--ablation`` (mean over the synthetic cases of that run at that iteration count;
``-`` for methods without iterations or presets).
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import sys
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

COLUMNS = (("rerender_rmse", "re-render"), ("burn_in", "burn-in"), ("diffuse_rmse", "diffuse"),
           ("specular_rmse", "specular"), ("roughness_rmse", "roughness"), ("normal_angle_deg", "normal °"))
BURNS = ("burn_diffuse", "burn_specular", "burn_roughness", "burn_normal")


def _fmt(key: str, v: float) -> str:
    return f"{v:.1f}" if key == "normal_angle_deg" else f"{v:.3f}"


def _runs(records: Sequence[Dict[str, Any]]) -> List[tuple]:
    seen = []
    for r in records:
        k = (r["method"], r["preset"], r["iterations"])
        if k not in seen:
            seen.append(k)
    order = {"baseline": 0, "preview": 1, "finetune": 2, "scratch": 3}
    return sorted(seen, key=lambda k: (order.get(k[0], 9), str(k[1]), k[2] or 0))


def _label(k: tuple) -> str:
    method, preset, it = k
    return method if preset is None else f"{method} {preset}, {it} it"


def synthetic_table(doc: Dict[str, Any], skip: Sequence[str] = ()) -> str:
    """Mean errors over the synthetic cases (minus those matching ``skip``), one row per run and iteration count."""
    keep = lambda name: not any(fnmatch.fnmatchcase(name, g) for g in skip)  # noqa: E731
    recs = [r for r in doc["records"] if r["kind"] == "synthetic" and keep(r["case"])]
    lines = ["| run | n | " + " | ".join(n for _, n in COLUMNS) + " | burn-in median | "
             + " | ".join(b.replace("burn_", "b.") for b in BURNS) + " |",
             "|---|---|" + "---|" * (len(COLUMNS) + 1 + len(BURNS))]
    for k in _runs(recs):
        rs = [r for r in recs if (r["method"], r["preset"], r["iterations"]) == k]
        cells = [_fmt(key, float(np.mean([r[key] for r in rs]))) for key, _ in COLUMNS]
        cells.append(f"{np.median([r['burn_in'] for r in rs]):.3f}")
        cells += [f"{np.mean([r[b] for r in rs]):.3f}" for b in BURNS]
        lines.append(f"| {_label(k)} | {len(rs)} | " + " | ".join(cells) + " |")
    gt = [c["gt_burn_in"] for c in doc["cases"] if c.get("gt_burn_in") is not None and keep(c["name"])]
    if gt:
        lines.append(f"| ground truth | {len(gt)} | 0 | {np.mean(gt):.3f} | 0 | 0 | 0 | 0.0 | {np.median(gt):.3f} | "
                     + " | ".join("" for _ in BURNS) + " |")
    return "\n".join(lines)


def photo_table(doc: Dict[str, Any], falloff_docs: Sequence[Dict[str, Any]] = ()) -> str:
    """Label-free scores of the real photos per run (input-flash RMSE with the metrics' renderer, burn-in)."""
    recs = [r for r in doc["records"] if r["kind"] == "photo"]
    extra = [r for d in falloff_docs for r in d["records"] if r["kind"] == "photo" and "input_rmse_falloff" in r]
    lines = ["| run | n | input-flash RMSE | input-flash RMSE, fall-off | burn-in | burn-in median | "
             + " | ".join(b.replace("burn_", "b.") for b in BURNS) + " |", "|---|---|---|---|---|---|" + "---|" * len(BURNS)]
    for k in _runs(recs):
        rs = [r for r in recs if (r["method"], r["preset"], r["iterations"]) == k]
        fo = [r["input_rmse_falloff"] for r in extra if (r["method"], r["preset"], r["iterations"]) == k]
        lines.append(f"| {_label(k)} | {len(rs)} | {np.mean([r['input_rmse'] for r in rs]):.3f} | "
                     + (f"{np.mean(fo):.3f} (n {len(fo)})" if fo else "-")
                     + f" | {np.mean([r['burn_in'] for r in rs]):.3f} | {np.median([r['burn_in'] for r in rs]):.3f} | "
                     + " | ".join(f"{np.mean([r[b] for r in rs]):.3f}" for b in BURNS) + " |")
    return "\n".join(lines)


def ablation_table(specs: Sequence[str]) -> str:
    """One row per ``LABEL=RESULTS_JSON:METHOD:PRESET:ITERATIONS[:CASE_GLOBS]`` (``-`` for no preset / no
    iterations; the optional comma-separated globs keep only those cases)."""
    lines = ["| variant | n | " + " | ".join(n for _, n in COLUMNS) + " | "
             + " | ".join(b.replace("burn_", "b.") for b in BURNS) + " |", "|---|---|" + "---|" * (len(COLUMNS) + len(BURNS))]
    cache: Dict[str, Dict[str, Any]] = {}
    for spec in specs:
        label, _, rest = spec.rpartition("=")  # a label may contain "=", a path does not
        path, method, preset, it, *globs = rest.split(":")
        doc = cache.setdefault(path, json.loads(Path(path).read_text()))
        want = (method, None if preset == "-" else preset, None if it == "-" else int(it))
        keep = [g for g in (globs[0].split(",") if globs else []) if g]
        rs = [r for r in doc["records"] if r["kind"] == "synthetic" and (r["method"], r["preset"], r["iterations"]) == want
              and (not keep or any(fnmatch.fnmatchcase(r["case"], g) for g in keep))]
        if not rs:
            raise SystemExit(f"accuracy_tables: no synthetic record for {want} in {path}")
        cells = [_fmt(key, float(np.mean([r[key] for r in rs]))) for key, _ in COLUMNS]
        cells += [f"{np.mean([r[b] for r in rs]):.3f}" for b in BURNS]
        lines.append(f"| {label} | {len(rs)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.tools.accuracy_tables", description=__doc__.split("\n\n")[0])
    p.add_argument("results", type=Path, help="merged results.json of the accuracy run")
    p.add_argument("--tuning", default="", help="comma-separated globs of the cases the settings were tuned on")
    p.add_argument("--henzler-falloff", action="append", default=[], type=Path,
                   help="results.json of a real-photo run that recorded input_rmse_falloff (repeatable)")
    p.add_argument("--ablation", action="append", default=[],
                   help="LABEL=RESULTS_JSON:METHOD:PRESET:ITERATIONS[:CASE_GLOBS]")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    doc = json.loads(args.results.read_text())
    tuning = [g for g in args.tuning.split(",") if g]
    parts = [f"<!-- written by: python -m svbrdf.trainer.tools.accuracy_tables {' '.join(sys.argv[1:] if argv is None else argv)} -->",
             "", "## Synthetic cases, all", "", synthetic_table(doc)]
    if tuning:
        parts += ["", f"## Synthetic cases without the {len(tuning)} tuning globs ({', '.join(tuning)})", "",
                  synthetic_table(doc, tuning)]
    parts += ["", "## Real photos (label-free)", "",
              photo_table(doc, [json.loads(f.read_text()) for f in args.henzler_falloff])]
    if args.ablation:
        parts += ["", "## Ablation", "", ablation_table(args.ablation)]
    args.out.write_text("\n".join(parts) + "\n")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
