"""Benchmark outputs: aggregated Markdown tables, the Pareto plot's series (drawn by :mod:`.plot`), the JSON
records and the headline summary (numpy + OpenImageIO, no torch).

Aggregation (:func:`aggregate`): records are grouped by (case kind, method, preset, iteration count); each
metric is reported as mean +- standard deviation over the cases of the group (population std, 0 for one case),
with min and max kept in the JSON rows. Points where a time budget stopped a run (``truncated``) form their own
group per (kind, method, preset), labelled ``budget`` (their iteration counts differ per case; the table shows
their mean and range).

Headline numbers (:func:`summarize`, ``summary.json``). The error ``E`` is the mean over synthetic cases of
``rerender_rmse`` (or, with no synthetic case, the mean ``input_rmse`` over the photos); time ``T`` is the mean
``seconds`` (training + one full prediction) over the same cases; only complete (non-truncated) groups count.
A *reference preset* is the first preset in ``--presets`` order for which the needed runs exist; every
per-preset value is kept under ``details``. A value is null when the runs it needs did not happen.

* ``speedup_vs_paper``: reference = ``finetune`` with preset ``paper`` at its largest evaluated iteration count
  (error ``E_ref``, mean burn-in ``B_ref``, time ``T_ref``). For every other ``finetune`` preset, ``T`` = the
  seconds of its first evaluation point with both ``E <= E_ref`` and ``B <= B_ref`` (no interpolation: the
  conservative, later point); speedup = ``T_ref / T``. The value is that of the first preset of ``--presets``
  other than ``paper`` (all kept under ``details``; null if it never reaches the reference).
* ``two_stage_speedup``: for a preset, target = the ``scratch`` run's error at its largest iteration count;
  ``T_scratch`` / ``T_finetune`` = the time at which each run's mean error curve first reaches the target,
  linearly interpolated in time between the two evaluation points around the crossing.
  ``details.two_stage_speedup[preset].levels`` gives the same ratio at looser targets (1.05x, 1.1x, ... the
  scratch run's final error, :data:`TWO_STAGE_LEVELS`): how the pretrained init's head start shrinks as both
  runs converge.
* ``preview_time_ratio`` / ``preview_error_ratio``: ``preview`` time (median of repeats) and error divided by
  those of ``finetune`` at its largest iteration count (reference preset).
* ``early_stop_saving``: for ``finetune`` runs (reference preset), the fraction of training time the trainer's
  label-free plateau rule (``quality="auto"``, :meth:`svbrdf.trainer.train.Trainer.plateaued`, evaluated in
  the same run) would have saved: mean over cases of ``1 - t_plateau / t_run`` (0 when the rule never fired).
  ``details.early_stop_error_ratio`` gives the price: mean over cases of ``E`` at the first evaluation point at
  or after the plateau step divided by ``E`` at the end of the run.
* ``artist`` (:func:`artist_table`): the table a user reads first, one row per method (``baseline``,
  ``preview``, and every ``finetune`` preset at its largest evaluated iteration count): the relighting of real
  multi-view captures (mean ``capture_rmse`` and ``capture_ssim`` over the capture views), the grazing-light
  error and high-pass correlation, the detail ratios (median over the cases: a ratio to a near-constant truth is
  unbounded) and normal slope correlation (synthetic cases), the burn-in
  with rings (synthetic cases, real photos without a capture, and the ground truth's chance level), the foreign
  colour of the base colour (synthetic cases and real photos without a capture) and the mean seconds; with each
  method's ratio to the baseline where lower or higher is better.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.files import atomic_write
from svbrdf.runtime.jsonutil import finite_json

from svbrdf.runtime.quality.burn_in import BURN_METRICS, RING_METRICS

from .metrics import ARTIST_METRICS, COLOUR_METRICS, MAP_METRICS, RELIEF_METRICS

SCHEMA = "svbrdf-bench/1"
#: Every numeric metric a record may carry, in table order.
METRICS = (("rerender_rmse", "input_rmse") + MAP_METRICS + ("burn_in",) + BURN_METRICS + RING_METRICS
           + COLOUR_METRICS + RELIEF_METRICS + ARTIST_METRICS)
#: Columns of :func:`artist_table`: (key, case group, metric); groups: ``capture`` (views of a real capture),
#: ``synthetic`` (ground truth), ``photo`` (other real photos).
ARTIST_COLUMNS = (
    ("capture_rmse", "capture", "capture_rmse"), ("capture_ssim", "capture", "capture_ssim"),
    ("grazing_rmse", "synthetic", "grazing_rmse"), ("grazing_hp_corr", "synthetic", "grazing_hp_corr"),
    ("detail_diffuse", "synthetic", "detail_diffuse"), ("detail_specular", "synthetic", "detail_specular"),
    ("detail_roughness", "synthetic", "detail_roughness"), ("detail_normal", "synthetic", "detail_normal"),
    ("normal_slope_corr", "synthetic", "normal_slope_corr"), ("normal_angle_deg", "synthetic", "normal_angle_deg"),
    ("burn_in_synthetic", "synthetic", "burn_in"), ("burn_in_photos", "photo", "burn_in"),
    ("burn_in_capture", "capture", "burn_in"), ("foreign_colour_synthetic", "synthetic", "foreign_colour"),
    ("foreign_colour_photos", "photo", "foreign_colour"), ("seconds", "synthetic", "seconds"),
)
#: Column headings of the artist table, by key of :data:`ARTIST_COLUMNS`.
ARTIST_HEADS = {
    "capture_rmse": "capture relit RMSE ↓", "capture_ssim": "capture SSIM ↑", "grazing_rmse": "grazing RMSE ↓",
    "grazing_hp_corr": "grazing detail corr ↑", "detail_diffuse": "detail diffuse",
    "detail_specular": "detail specular", "detail_roughness": "detail roughness", "detail_normal": "detail normal",
    "normal_slope_corr": "normal slope corr ↑", "normal_angle_deg": "normal °",
    "burn_in_synthetic": "burn-in synthetic ↓", "burn_in_photos": "burn-in photos ↓",
    "burn_in_capture": "burn-in capture ↓", "foreign_colour_synthetic": "foreign colour synthetic ↓",
    "foreign_colour_photos": "foreign colour photos ↓", "seconds": "seconds",
}
TIMES = ("seconds", "train_seconds", "eval_seconds")
METHOD_ORDER = ("baseline", "preview", "preview-full", "finetune", "scratch")
BUDGET = "budget"


# ----------------------------------------------------------------------------------------------- files
def write_text(path: Path, text: str, force: bool = False) -> Path:
    """Write a text file atomically (:func:`~svbrdf.runtime.io.files.atomic_write`); refuse to overwrite unless
    ``force``."""
    path = Path(path)
    try:
        with atomic_write(path, force=force) as tmp:
            tmp.write_text(text, encoding="utf-8")
    except OSError as e:
        raise SvbrdfError(f"{path}: cannot write ({e.strerror or e})") from None
    return path


def write_json(path: Path, obj: Any, force: bool = False) -> Path:
    """JSON (indented, no NaN: non-finite floats become null) written with :func:`write_text`."""
    return write_text(path, json.dumps(finite_json(obj), indent=1, allow_nan=False) + "\n", force)


# ----------------------------------------------------------------------------------------------- aggregation
def _stats(values: Sequence[float]) -> Optional[Dict[str, float]]:
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=np.float64)
    if v.size == 0:
        return None
    return {"mean": float(v.mean()), "std": float(v.std()), "min": float(v.min()), "max": float(v.max()),
            "n": int(v.size)}


def _label(rec: Mapping[str, Any]) -> str:
    if rec.get("truncated"):
        return BUDGET
    return "-" if rec.get("iterations") is None else str(rec["iterations"])


def _order(row: Mapping[str, Any]) -> tuple:
    m = row["method"]
    it = row["iterations"]
    return (METHOD_ORDER.index(m) if m in METHOD_ORDER else len(METHOD_ORDER), m, row["preset"] or "",
            math.inf if it == BUDGET else (-1 if it == "-" else int(it)))


def aggregate(records: Iterable[Mapping[str, Any]]) -> List[Dict[str, Any]]:
    """Group records by (kind, method, preset, iteration label) and summarise every time and metric.

    Returns:
        rows sorted by kind, method, preset and iterations, each ``{kind, method, preset, iterations (label),
        n, cases, truncated, iterations_stats, <time or metric>: {mean, std, min, max, n} or None}``.
    """
    groups: Dict[tuple, List[Mapping[str, Any]]] = {}
    for r in records:
        groups.setdefault((r["kind"], r["method"], r.get("preset"), _label(r)), []).append(r)
    rows = []
    for (kind, method, preset, label), recs in groups.items():
        row: Dict[str, Any] = {"kind": kind, "method": method, "preset": preset, "iterations": label,
                               "n": len(recs), "cases": [r["case"] for r in recs],
                               "truncated": sum(bool(r.get("truncated")) for r in recs),
                               "iterations_stats": _stats([r["iterations"] for r in recs
                                                           if r.get("iterations") is not None])}
        for key in TIMES + METRICS:
            row[key] = _stats([r.get(key) for r in recs])
        rows.append(row)
    return sorted(rows, key=lambda r: (r["kind"],) + _order(r))


# ----------------------------------------------------------------------------------------------- summary
def _error_key(rows: Sequence[Mapping[str, Any]]) -> Tuple[str, str]:
    """(kind, metric) of the headline error: synthetic re-render RMSE, else the photos' input RMSE."""
    if any(r["kind"] == "synthetic" and r.get("rerender_rmse") for r in rows):
        return "synthetic", "rerender_rmse"
    return "photo", "input_rmse"


def _curve(rows, kind, metric, method, preset) -> List[Tuple[int, float, float, Optional[float]]]:
    """Evaluation points (iterations, mean seconds, mean error, mean burn-in) of one run type, by iterations; a
    time-budget point counts at the largest iteration count its runs reached."""
    out = []
    for r in rows:
        if (r["kind"], r["method"], r["preset"]) != (kind, method, preset):
            continue
        if r.get(metric) is None or r.get("seconds") is None:
            continue
        if r["iterations"] == BUDGET:  # where the time budget stopped the runs: their last, best-trained point
            if not r["iterations_stats"]:
                continue
            it = r["iterations_stats"]["max"]
        else:
            it = -1 if r["iterations"] == "-" else int(r["iterations"])
        burn = r["burn_in"]["mean"] if r.get("burn_in") else None
        out.append((it, r["seconds"]["mean"], r[metric]["mean"], burn))
    return sorted(out)


def _first_reach(curve, target: float, burn: Optional[float] = None) -> Optional[float]:
    """Seconds at which ``curve`` first reaches error ``target``: interpolated linearly in time between the last
    point above it and the first at or below it; with ``burn``, the first evaluated point that also has a
    burn-in score <= ``burn`` (not interpolated)."""
    tol = 1 + 1e-9
    prev = None
    for point in curve:
        _, t, e, b = point
        if e <= target * tol and (burn is None or (b is not None and b <= burn * tol)):
            if burn is None and prev is not None and prev[2] > e:
                _, t0, e0, _ = prev
                return t0 + (t - t0) * (e0 - target) / (e0 - e)
            return t
        prev = point
    return None


#: Error levels of ``details.two_stage_speedup[preset].levels``, relative to the scratch run's final error; the
#: first (1.0) is the headline ``two_stage_speedup``.
TWO_STAGE_LEVELS = (1.0, 1.05, 1.1, 1.25, 1.5, 2.0)


def _two_stage_levels(ft, sc, target: float) -> List[Dict[str, Any]]:
    """The two-stage speed-up at looser targets (``target * level`` for :data:`TWO_STAGE_LEVELS`): how much
    sooner the pretrained init gets to each error than training from scratch (None where a run never gets
    there)."""
    out = []
    for level in TWO_STAGE_LEVELS:
        t_sc, t_ft = _first_reach(sc, target * level), _first_reach(ft, target * level)
        out.append({"level": level, "error": target * level, "scratch_seconds": t_sc, "finetune_seconds": t_ft,
                    "speedup": _ratio(t_sc, t_ft)})
    return out


def _ratio(a: Optional[float], b: Optional[float]) -> Optional[float]:
    if a is None or b is None or b <= 0:
        return None
    return a / b


def summarize(records: Sequence[Mapping[str, Any]], presets: Sequence[str],
              cases: Sequence[Mapping[str, Any]] = ()) -> Dict[str, Any]:
    """Headline numbers (see the module docstring); every value is a float or None, with ``details`` and the
    ``artist`` table (:func:`artist_table`; ``cases``, the document's case list, gives its ground-truth row)."""
    rows = aggregate(records)
    kind, metric = _error_key(rows)
    details: Dict[str, Any] = {"error_metric": metric, "case_kind": kind}
    curve = lambda m, p=None: _curve(rows, kind, metric, m, p)  # noqa: E731
    truncated = {(r["method"], r["preset"]) for r in rows if r["truncated"]}

    # speedup_vs_paper
    speedup = None
    paper = curve("finetune", "paper")
    if paper:
        _, t_ref, e_ref, b_ref = paper[-1]
        per = {}
        for p in presets:
            if p == "paper" or not curve("finetune", p):
                continue
            t = _first_reach(curve("finetune", p), e_ref, burn=b_ref if b_ref is not None else math.inf)
            per[p] = {"seconds": t, "speedup": _ratio(t_ref, t)}
        details["speedup_vs_paper"] = {"reference": {"iterations": paper[-1][0], "seconds": t_ref, "error": e_ref,
                                                     "burn_in": b_ref,
                                                     "truncated": ("finetune", "paper") in truncated},
                                       "per_preset": per}
        speedup = next((v["speedup"] for v in per.values()), None)

    # two_stage_speedup
    two = {}
    for p in presets:
        ft, sc = curve("finetune", p), curve("scratch", p)
        if ft and sc:
            target = sc[-1][2]
            levels = _two_stage_levels(ft, sc, target)  # levels[0] is the headline target itself (level 1.0)
            two[p] = {"target_error": target, **{k: levels[0][k] for k in ("scratch_seconds", "finetune_seconds",
                                                                          "speedup")}, "levels": levels}
    details["two_stage_speedup"] = two
    two_value = next((v["speedup"] for v in two.values()), None)

    # preview ratios
    prev, time_ratio, err_ratio = curve("preview"), None, None
    ref = next((p for p in presets if curve("finetune", p)), None)
    if prev and ref:
        _, t_ft, e_ft, _ = curve("finetune", ref)[-1]
        time_ratio, err_ratio = _ratio(prev[0][1], t_ft), _ratio(prev[0][2], e_ft)
        details["preview"] = {"reference_preset": ref, "preview_seconds": prev[0][1], "preview_error": prev[0][2],
                              "finetune_seconds": t_ft, "finetune_error": e_ft}

    # early_stop_saving
    saving = None
    es = {}
    for p in presets:
        runs = [r for r in records if r["method"] == "finetune" and r.get("preset") == p and r["kind"] == kind]
        by_case: Dict[str, List[Mapping[str, Any]]] = {}
        for r in runs:
            by_case.setdefault(r["case"], []).append(r)
        savings, prices = [], []
        for recs in by_case.values():
            recs = sorted(recs, key=lambda r: r["iterations"])
            run = recs[-1].get("run") or {}
            total = run.get("run_train_seconds")
            plateau = run.get("plateau")
            if not total:
                continue
            if plateau is None:
                savings.append(0.0)
                continue
            savings.append(max(0.0, 1.0 - plateau["train_seconds"] / total))
            at = next((r for r in recs if r["iterations"] >= plateau["step"]), None)
            if at is not None and at.get(metric) and recs[-1].get(metric):
                prices.append(at[metric] / recs[-1][metric])
        if savings:
            es[p] = {"saving": float(np.mean(savings)), "cases": len(savings),
                     "fired": sum(1 for s in by_case.values() if (s[-1].get("run") or {}).get("plateau")),
                     "early_stop_error_ratio": float(np.mean(prices)) if prices else None}
    details["early_stop"] = es
    ref_es = next((p for p in presets if p in es), None)
    if ref_es:
        saving = es[ref_es]["saving"]
        details["early_stop_reference_preset"] = ref_es
    return {"speedup_vs_paper": speedup, "two_stage_speedup": two_value, "preview_time_ratio": time_ratio,
            "preview_error_ratio": err_ratio, "early_stop_saving": saving, "artist": artist_table(records, cases),
            "details": details}


def _group(rec: Mapping[str, Any]) -> str:
    if rec["kind"] == "synthetic":
        return "synthetic"
    return "capture" if rec.get("capture_rmse") is not None else "photo"


def artist_table(records: Sequence[Mapping[str, Any]], cases: Sequence[Mapping[str, Any]] = ()) -> List[Dict[str, Any]]:
    """The artist measures per method (see the module docstring): rows ``{method, preset, iterations, <column>:
    mean or None, n_<group>: cases}``, plus a ``ground truth`` row with the chance-level burn-in of the synthetic
    cases' own maps (``cases``: the document's case list)."""
    runs: Dict[tuple, List[Mapping[str, Any]]] = {}
    for r in records:
        if r.get("truncated"):
            continue
        runs.setdefault((r["method"], r.get("preset")), []).append(r)
    rows = []
    for (method, preset), recs in runs.items():
        if method == "scratch":
            continue
        if method == "finetune":
            last = max(r["iterations"] for r in recs)
            recs = [r for r in recs if r["iterations"] == last]
        row: Dict[str, Any] = {"method": method, "preset": preset,
                               "iterations": recs[0].get("iterations")}
        for key, group, metric in ARTIST_COLUMNS:
            vals = [r.get(metric) for r in recs if _group(r) == group and r.get(metric) is not None]
            # A ratio to a near-constant truth is unbounded: the detail ratios are medians over the cases.
            row[key] = (float(np.median(vals)) if key.startswith("detail_") else float(np.mean(vals))) if vals else None
        for group in ("synthetic", "photo", "capture"):
            row[f"n_{group}"] = sum(_group(r) == group for r in recs)
        rows.append(row)
    rows.sort(key=lambda r: _order({**r, "iterations": "-" if r["iterations"] is None else r["iterations"]}))
    gt = [c["gt_burn_in"] for c in cases if c.get("gt_burn_in") is not None]
    if gt:
        rows.append({"method": "ground truth", "preset": None, "iterations": None,
                     **{k: None for k, _, _ in ARTIST_COLUMNS}, "burn_in_synthetic": float(np.mean(gt)),
                     "detail_diffuse": 1.0, "detail_specular": 1.0, "detail_roughness": 1.0, "detail_normal": 1.0,
                     "normal_slope_corr": 1.0, "n_synthetic": len(gt), "n_photo": 0, "n_capture": 0})
    return rows


def _artist_markdown(rows: Sequence[Mapping[str, Any]]) -> List[str]:
    if not rows:
        return []
    heads = [(k, h) for k, h in ARTIST_HEADS.items() if k != "normal_angle_deg"]
    out = ["## What an artist sees (read first)", "",
           "| method | " + " | ".join(h for _, h in heads) + " |", "|---" * (len(heads) + 1) + "|"]
    for r in rows:
        name = r["method"] + (f" {r['preset']}" if r.get("preset") else "") + \
            (f" @{r['iterations']}" if r.get("iterations") is not None else "")
        out.append(f"| {name} | " + " | ".join(_fmt(r.get(k)) for k, _ in heads) + " |")
    out += ["", "Capture: the maps estimated from each view of a real multi-view capture, relit at its other views "
            "(one exposure fitted per view) against the real photos. Grazing: 8 lights 60-75° from the normal, "
            "against renders of the ground truth. Detail: the map's spatial std over the truth's (0 = constant or "
            "flat, 1 = as varied as the truth; median over the cases). Burn-in: the worst map's disc or ring score "
            "(`svbrdf.runtime.quality.burn_in`); the ground truth row is its chance level. Foreign colour: the base "
            "colour's hue against the photo's, block by block (CIELAB a*b* at equal lightness; 0 = the photo's "
            "colours, `svbrdf.runtime.quality.colour_check`). Definitions: "
            "`svbrdf.trainer.bench.metrics`.", ""]
    return out


# ----------------------------------------------------------------------------------------------- Markdown
def _fmt(v: Optional[float]) -> str:
    """3 significant digits (whole numbers from 1000 on); an en dash for a missing value."""
    if v is None:
        return "–"
    return f"{v:.0f}" if abs(v) >= 1000 else f"{v:.3g}"


def _cell(s: Optional[Mapping[str, float]]) -> str:
    if s is None:
        return "–"
    return _fmt(s["mean"]) if s["n"] == 1 else f"{_fmt(s['mean'])} ± {_fmt(s['std'])}"


def _iters_cell(row: Mapping[str, Any]) -> str:
    if row["iterations"] != BUDGET:
        return row["iterations"]
    s = row["iterations_stats"]
    return f"{s['mean']:.0f} ({s['min']:.0f}–{s['max']:.0f}), budget" if s else BUDGET


def _table(rows: Sequence[Mapping[str, Any]], columns: Sequence[Tuple[str, str]]) -> str:
    head = ["method", "preset", "iterations", "n"] + [title for _, title in columns]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["method"], r["preset"] or "–", _iters_cell(r), str(r["n"])]
        cells += [_cell(r.get(key)) for key, _ in columns]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _early_stop_table(records: Sequence[Mapping[str, Any]]) -> List[str]:
    """Per fine-tune run: where the ``quality="auto"`` rule stopped, against the full run (time and error)."""
    runs: Dict[Tuple[str, str], List[Mapping[str, Any]]] = {}
    for r in records:
        if r["method"] == "finetune" and (r.get("run") or {}).get("evals"):
            runs.setdefault((r.get("preset") or "", r["case"]), []).append(r)
    if not runs:
        return []
    out = ["## Early stopping per run", "",
           "Where the label-free `quality=\"auto\"` rule fired in each fine-tune (the run itself went on to its last "
           "iteration count, so both are measured): training seconds and error with and without the early stop.", "",
           "| preset | case | stopped at (it) | seconds with / without | saving | error with / without |",
           "|---|---|---|---|---|---|"]
    for (preset, case), recs in sorted(runs.items()):
        recs = sorted(recs, key=lambda r: r["iterations"])
        run, last = recs[-1]["run"], recs[-1]
        metric = "rerender_rmse" if last.get("rerender_rmse") is not None else "input_rmse"
        total, plateau = run.get("run_train_seconds"), run.get("plateau")
        if plateau is None or not total:
            out.append(f"| {preset} | {case} | – | {_fmt(total)} / {_fmt(total)} | 0 | {_fmt(last.get(metric))} / "
                       f"{_fmt(last.get(metric))} |")
            continue
        at = next((r for r in recs if r["iterations"] >= plateau["step"]), last)
        out.append(f"| {preset} | {case} | {plateau['step']} | {_fmt(plateau['train_seconds'])} / {_fmt(total)} | "
                   f"{100 * (1 - plateau['train_seconds'] / total):.0f} % | {_fmt(at.get(metric))} / "
                   f"{_fmt(last.get(metric))} |")
    return out + [""]


def markdown(doc: Mapping[str, Any], plot_name: Optional[str], legend: Sequence[Mapping[str, str]],
             plot_note: str = "") -> str:
    """The ``results.md`` text of a benchmark document (:func:`svbrdf.trainer.bench.cli.run_benchmark`)."""
    rows = aggregate(doc["records"])
    m = doc["machine"]
    s = doc["settings"]
    out = [
        "# svbrdf-bench results",
        "",
        "Generated by `svbrdf-bench`; metric definitions: `svbrdf.trainer.bench.metrics`, schema: "
        "`docs/bench.md`.",
        "",
        "```",
        *([r["command"] for r in doc.get("merged_from", [])] or [doc["command"]]),  # every merged run's command
        "```",
        *([f"Report re-derived from the recorded runs by `{doc['report_command']}`.", ""]
          if doc.get("report_command") else []),
        "",
        f"- date: {doc['date']}",
        f"- machine: {m.get('cpu')} ({m.get('cores')} cores visible), {m.get('platform')}",
        f"- threads: torch {m.get('torch_threads')}, onnxruntime {m.get('ort_threads')}",
        f"- versions: " + ", ".join(f"{k} {v}" for k, v in (m.get("versions") or {}).items()),
        f"- cases: {len(doc['cases'])} ({sum(c['kind'] == 'synthetic' for c in doc['cases'])} synthetic, "
        f"{sum(c['kind'] == 'photo' for c in doc['cases'])} real photos) from `{s['data']}`, "
        f"{s['size']} px, {s.get('inputs', 'clean')} synthetic inputs (renderer `{s['renderer']}`"
        + (f", noise {s['noise']}, quantize {s['quantize']})" if s.get("inputs", "clean") == "clean" else
           "; a camera drawn per case: `cases[].simulation` in the JSON)"),
        f"- model: " + (f"`{s['model']['file']}` ({s['model']['source']}), sha256 `{s['model']['sha256']}`"
                        if isinstance(s.get("model"), Mapping) else "none recorded"),
        f"- render config of the metrics: {s['render_config']}",
        f"- iterations evaluated: {s['iters']}; time budget per run: {s['time_budget'] or 'none'}",
        "- cells: mean ± std over the cases (n); seconds = training + one full-photo prediction "
        "(train_seconds excludes evaluation; see `methods.py`)",
        "",
    ]
    out += _artist_markdown(doc["summary"].get("artist") or [])
    if doc.get("skipped"):
        out += ["## Skipped", ""] + [f"- `{k['method']}`" + (f" ({k['preset']})" if k.get("preset") else "")
                                      + f": {k['reason']}" for k in doc["skipped"]] + [""]
    if doc.get("errors"):
        out += ["## Errors", ""] + [f"- `{e['method']}` {e.get('preset') or ''} on `{e['case']}`: {e['error']}"
                                     for e in doc["errors"]] + [""]
    syn = [r for r in rows if r["kind"] == "synthetic"]
    pho = [r for r in rows if r["kind"] == "photo"]
    if syn:
        gt_burn = [c["gt_burn_in"] for c in doc["cases"] if c.get("gt_burn_in") is not None]
        out += ["## Synthetic cases (ground truth)", "",
                _table(syn, [("seconds", "seconds"), ("train_seconds", "train s"), ("eval_seconds", "eval s"),
                             ("rerender_rmse", "re-render RMSE (10 lights)"), ("input_rmse", "input-light RMSE"),
                             ("burn_in", "burn-in")]),
                "",
                f"Burn-in of the ground-truth maps themselves (chance level): {_fmt(float(np.mean(gt_burn)))} "
                f"(mean over cases)." if gt_burn else "",
                "",
                "### Per-map errors", "",
                _table(syn, [("diffuse_rmse", "diffuse"), ("diffuse_rmse_srgb", "diffuse sRGB"),
                             ("specular_rmse", "specular"), ("specular_rmse_srgb", "specular sRGB"),
                             ("roughness_rmse", "roughness"), ("normal_rmse", "normal (n+1)/2"),
                             ("normal_angle_deg", "normal °")]),
                "",
                "### Signed burn-in per map", "",
                _table(syn, [(k, k.replace("burn_", "")) for k in BURN_METRICS]), ""]
    if pho:
        out += ["## Real photos (no ground truth)", "",
                _table(pho, [("seconds", "seconds"), ("train_seconds", "train s"), ("eval_seconds", "eval s"),
                             ("input_rmse", "input-light RMSE"), ("burn_in", "burn-in")]
                       + [(k, k.replace("burn_", "")) for k in BURN_METRICS]), ""]
    if plot_name:
        out += ["## Pareto plot", "", f"![run time against error]({plot_name})", "",
                "Left: mean seconds (log scale) against the headline error "
                f"({doc['summary']['details']['error_metric']} on {doc['summary']['details']['case_kind']} cases); "
                "right: against the mean burn-in over all cases. Lines join the iteration counts of one run type.",
                ""]
        if plot_note:
            out += [plot_note, ""]
        out += ["| series | colour | marker |", "|---|---|---|"]
        out += [f"| {e['label']} | {e['colour']} | {e['marker']} |" for e in legend] + [""]
    out += _early_stop_table(doc["records"])
    summ = doc["summary"]
    out += ["## Summary", "", "| headline | value |", "|---|---|"]
    out += [f"| {k} | {_fmt(summ[k])} |" for k in ("speedup_vs_paper", "two_stage_speedup", "preview_time_ratio",
                                                       "preview_error_ratio", "early_stop_saving")]
    det = summ.get("details", {})
    es = det.get("early_stop", {}).get(det.get("early_stop_reference_preset"))
    if es:
        out.append(f"| early stop: runs stopped / error ratio at the stop | {es['fired']} of {es['cases']} / "
                   f"{_fmt(es['early_stop_error_ratio'])} |")
    for p, two in det.get("two_stage_speedup", {}).items():
        levels = [lv for lv in two.get("levels", []) if lv["speedup"] is not None]
        if levels:
            out.append(f"| two-stage speed-up of `{p}` at looser targets (error: speed-up) | "
                       + ", ".join(f"{lv['error']:.3f}: {lv['speedup']:.1f}x" for lv in levels) + " |")
    out += ["", "Definitions: `svbrdf.trainer.bench.report` (module docstring); details in `summary.json`.", ""]
    return "\n".join(out)


def pareto_series(records: Sequence[Mapping[str, Any]]) -> Tuple[List[Dict[str, Any]], Tuple[str, str]]:
    """Series of the Pareto plot: per (method, preset), mean seconds, headline error and burn-in at each
    evaluated iteration count (complete groups; budget-truncated points appended last)."""
    rows = aggregate(records)
    kind, metric = _error_key(rows)
    burn = aggregate([{**r, "kind": "all"} for r in records])
    series: Dict[tuple, Dict[str, Any]] = {}
    for r in rows:
        if r["kind"] != kind or r.get("seconds") is None:
            continue
        b = next(x for x in burn if (x["method"], x["preset"], x["iterations"]) ==
                 (r["method"], r["preset"], r["iterations"]))
        key = (r["method"], r["preset"])
        s = series.setdefault(key, {"label": r["method"] + (f" {r['preset']}" if r["preset"] else ""),
                                    "method": r["method"], "points": []})
        s["points"].append((r["seconds"]["mean"], (r.get(metric) or {}).get("mean"),
                            (b.get("burn_in") or {}).get("mean")))
    ylabel = "re-render RMSE (sRGB)" if metric == "rerender_rmse" else "input-light RMSE (sRGB)"
    return list(series.values()), (ylabel, "burn-in (worst of the 4 maps, rings included)")


__all__ = ["SCHEMA", "METRICS", "ARTIST_COLUMNS", "ARTIST_HEADS", "artist_table", "aggregate", "summarize", "markdown", "pareto_series",
           "write_text", "write_json"]
