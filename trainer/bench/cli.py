"""``svbrdf-bench``: run time against error of every method on ground-truth sets and real photos.

Example::

    svbrdf-bench --quick                                   # pipeline check, 2 small cases, < 2 min
    svbrdf-bench --cases 4 --methods baseline,finetune --presets fast --iters 0,30 --time-budget 600

Outputs in ``--out`` (default ``runs/bench`` in the current folder): ``results.md``, ``pareto.png``,
``results.json`` (or ``--json PATH``) and ``summary.json``. Existing files are kept unless ``--force``.
Python API: :func:`run_benchmark` (returns the document) and :func:`write_outputs`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import datetime as _dt
import os
import shlex
import sys
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence

from svbrdf.runtime.quality.burn_in import burn_in_scores
from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.core.render import ZHAO, RenderConfig

from . import report
from .cases import RENDERERS, BenchCase, load_cases, mitsuba_available, prepare_case
from .common import default_data, machine_info
from .methods import METHODS, BenchOptions, Point, case_render_config, torch_available
from .metrics import evaluate
from .plot import plot_pareto

DEFAULT_PRESETS = ("paper", "zhao", "fast")
DEFAULT_ITERS = (0, 100, 300, 1000, 3000)
#: --quick: size, iteration counts, presets, cases, repeats.
QUICK = {"size": 64, "iters": (0, 2, 4), "presets": ("tiny",), "repeats": 1, "pretrain_iters": 2}
#: Output folder when --out is not given (relative to the current folder; ``runs/`` is ignored by git).
DEFAULT_OUT = Path("runs") / "bench"
OUTPUT_NAMES = {"markdown": "results.md", "plot": "pareto.png", "json": "results.json", "summary": "summary.json"}


def _quick_init(case: BenchCase, opts: BenchOptions) -> Optional[dict]:
    """--quick without --init: a throwaway stage-one checkpoint (tiny preset, a few iterations on one case)."""
    if not torch_available():
        return None
    from svbrdf.trainer.config import resolve
    from svbrdf.trainer.stage import make_trainer
    from svbrdf.trainer.train import photo_to_tensor

    cfg = resolve("tiny", render=opts.config, checkpoint_every=0, maps_every=0)
    trainer = make_trainer(photo_to_tensor(case.photo), "pretrain", cfg, iters=QUICK["pretrain_iters"],
                           threads=opts.threads)
    trainer.run()
    return trainer.checkpoint()


def _describe_init(init: Any) -> Any:
    if init is None or isinstance(init, (str, os.PathLike)):
        return None if init is None else str(init)
    if "format" in init:
        return "<in-memory checkpoint>"
    return {k: _describe_init(v) for k, v in init.items()}


def run_benchmark(
    data: Path,
    *,
    methods: Sequence[str] = tuple(METHODS),
    presets: Sequence[str] = DEFAULT_PRESETS,
    size: int = 256,
    cases: Optional[str] = None,
    split: Optional[str] = None,
    realistic: bool = True,
    renderer: str = "auto",
    noise: float = 0.0,
    quantize: bool = False,
    opts: Optional[BenchOptions] = None,
    quick: bool = False,
    command: str = "",
    progress: Optional[Callable[[str], None]] = None,
    runs_progress: Optional[Callable[[int], Any]] = None,
) -> Dict[str, Any]:
    """Run every selected method on every case and return the benchmark document (the JSON of ``--json``).

    Args:
        data: folder (or file) searched by :func:`svbrdf.trainer.bench.datasets.find_cases`.
        methods: names in :data:`svbrdf.trainer.bench.methods.METHODS`; a training method may name its own
            presets, ``"scratch:fast+zhao"`` (default: ``presets``), and a cap on its evaluated iteration
            counts, ``"finetune@600"``.
        presets: training presets for the training methods.
        size: side of every case, pixels.
        cases: selection (see :func:`svbrdf.trainer.bench.cases.select_cases`); with ``quick`` and no
            selection: the first ground-truth set and the first photo.
        split: ``"tune"`` or ``"check"``: only that part of the shared data (:mod:`svbrdf.trainer.bench.split`),
            before ``cases`` selects; ``None``: every case.
        realistic, renderer, noise, quantize: how synthetic photos are made
            (:func:`svbrdf.trainer.bench.cases.prepare_case`): realistic (Mitsuba where installed, fall-off, a
            camera per case) or clean (``renderer`` with the benchmark's configuration, ``noise``, ``quantize``).
        opts: method settings (default :class:`BenchOptions` with the ZHAO renderer).
        quick: pretrain a throwaway tiny stage-one checkpoint when ``opts.init`` is None.
        command: the command line, recorded.
        progress: called with one line per evaluation point.
        runs_progress: makes the progress of the runs (one method, preset and case each) from their number,
            e.g. ``functools.partial(svbrdf.runtime.progress.Progress, desc="svbrdf-bench", unit="run")``; its
            ``update(n, **postfix)`` is called after each run (or skipped run) and ``close()`` at the end.

    Returns:
        dict: ``schema, command, date, machine, settings, cases, skipped, errors, records, summary``
        (see ``docs/bench.md``).

    Raises:
        SvbrdfError: missing data folder, no case selected, unknown method/preset, bad option.
    """
    opts = opts or BenchOptions()
    say = progress or (lambda _msg: None)
    only, caps = {}, {}  # "scratch:fast+zhao@3000": only those presets, iterations up to 3000
    for spec in methods:
        spec, at, cap = spec.partition("@")
        name, sep, sub = spec.partition(":")
        if sep:
            only[name] = [p for p in sub.split("+") if p]
        if at:
            try:
                caps[name] = int(cap)
            except ValueError:
                raise SvbrdfError(f"method {spec}@{cap}: the iteration cap must be an integer") from None
    methods = [m.partition("@")[0].partition(":")[0] for m in methods]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise SvbrdfError(f"unknown method(s) {', '.join(unknown)}; expected some of {', '.join(METHODS)}")
    if size < 32:
        raise SvbrdfError(f"--size must be >= 32, got {size}")
    if renderer not in RENDERERS:
        raise SvbrdfError(f"--renderer must be one of {', '.join(RENDERERS)}, got {renderer!r}")
    if renderer == "mitsuba" and not mitsuba_available():
        raise SvbrdfError("--renderer mitsuba needs Mitsuba 3 (pip install mitsuba)")
    data = Path(data)
    if not data.exists():
        raise SvbrdfError(f"data folder {data} does not exist: pass --data DIR, a folder of ground-truth map sets "
                          f"(Des18, Des19, Xuejiao layouts: every measure) or of flash photos (e.g. --data "
                          f"runtime/examples: the label-free measures, burn-in and the re-render under the flash)")
    if torch_available() and any(METHODS[m].uses_presets for m in methods):
        from svbrdf.trainer.config import TRAIN_PRESETS

        bad = [p for p in list(presets) + [q for v in only.values() for q in v] if p not in TRAIN_PRESETS]
        if bad:
            raise SvbrdfError(f"unknown preset(s) {', '.join(bad)}; expected some of {', '.join(TRAIN_PRESETS)}")

    if realistic and (noise or quantize):
        raise SvbrdfError("--noise and --quantize apply to --clean inputs; realistic inputs draw their own camera")
    kw = dict(realistic=realistic, renderer=renderer, config=opts.config, noise=noise, quantize=quantize)
    if quick and cases is None:
        from svbrdf.trainer.bench.datasets import find_cases

        found = find_cases(data)
        if not found:
            raise SvbrdfError(f"{data}: no image found")
        pick = [c for c in found if c.kind == "gt"][:1] + [c for c in found if c.kind == "photo"][:1]
        if len(pick) < 2:
            pick = found[:2]
        bench_cases = [prepare_case(c, size, **kw) for c in pick]
    else:
        bench_cases = load_cases(data, size, cases, split, **kw)

    case_docs = []
    for c in bench_cases:
        d = {"name": c.name, "source": c.source, "kind": c.kind, "format": c.format,
             "centre": [float(v) for v in c.centre]}
        if c.gt is not None:
            d.update({f"gt_{k}": v for k, v in burn_in_scores(c.gt, c.centre).items()})
        if c.simulation is not None:
            d["simulation"] = c.simulation
        case_docs.append(d)

    init_note = None
    if quick and opts.init is None and "finetune" in methods:
        opts = dataclasses.replace(opts, init=_quick_init(bench_cases[0], opts))
        init_note = f"--quick: throwaway tiny stage-one checkpoint ({QUICK['pretrain_iters']} iterations on " \
                    f"{bench_cases[0].name})"

    records: List[Dict[str, Any]] = []
    skipped: List[Dict[str, Any]] = []
    errors: List[Dict[str, Any]] = []
    method_presets = {m: list(only.get(m, presets)) if METHODS[m].uses_presets else [None] for m in methods}
    tracker = runs_progress(sum(map(len, method_presets.values())) * len(bench_cases)) if runs_progress else None
    done = 0
    for name in methods:
        method = METHODS[name]
        for preset in method_presets[name]:
            reason = method.unavailable(opts, preset)
            if reason:
                skipped.append({"method": name, "preset": preset, "reason": reason})
                say(f"skip {name}{' ' + preset if preset else ''}: {reason}")
                done += len(bench_cases)
                if tracker is not None:
                    tracker.update(done)
                continue
            run_opts = opts if name not in caps else \
                dataclasses.replace(opts, iters=[i for i in opts.iters if i <= caps[name]] or [0])
            for case in bench_cases:
                run_recs: List[Dict[str, Any]] = []
                camera = case_render_config(case, opts.config)  # a real photo's own camera (its re-render)

                def on_point(p: Point, case: BenchCase = case, camera: RenderConfig = camera) -> None:
                    metrics = evaluate(p.maps, gt=case.gt, photo=case.photo if case.gt is None else None,
                                       config=camera, centre=case.centre, capture=case.capture)
                    rec = {"case": case.name, "source": case.source, "kind": case.kind, "method": name,
                           "preset": preset, "iterations": p.iterations, "seconds": p.train_seconds + p.eval_seconds,
                           "train_seconds": p.train_seconds, "eval_seconds": p.eval_seconds,
                           "truncated": p.truncated, **metrics}
                    if "burn_in_model" in p.maps.meta:  # the network's maps, before the runtime's post-processing
                        rec["burn_in_model"] = p.maps.meta["burn_in_model"]["burn_in"]
                    run_recs.append(rec)
                    err = metrics.get("rerender_rmse", metrics.get("input_rmse"))
                    say(f"{case.name} | {name}{' ' + preset if preset else ''} | it {p.iterations} | "
                        f"{rec['seconds']:.2f} s | err {err:.4f} | burn {metrics['burn_in']:.3f}"
                        + (" | truncated" if p.truncated else ""))

                try:
                    run = method.run(case, run_opts, preset, on_point)
                except Exception as e:  # one failing run must not lose the others; it is reported
                    msg = f"{type(e).__name__}: {str(e).strip().splitlines()[0] if str(e).strip() else ''}"
                    errors.append({"case": case.name, "method": name, "preset": preset, "error": msg})
                    say(f"ERROR {case.name} | {name} {preset or ''}: {msg}")
                    run = {"failed": msg}
                if init_note and name == "finetune":
                    run = {**run, "init_note": init_note}
                for rec in run_recs:
                    rec["run"] = run
                records.extend(run_recs)
                done += 1
                if tracker is not None:
                    tracker.update(done, failed=len(errors)) if errors else tracker.update(done)
    if tracker is not None:
        tracker.close()

    doc = {
        "schema": report.SCHEMA,
        "command": command,
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "machine": machine_info(opts),
        "settings": {"data": str(data), "size": size, "cases": cases, "split": split, "quick": quick,
                     "inputs": "realistic" if realistic else "clean", "renderer": renderer,
                     "noise": noise, "quantize": quantize, "methods": list(methods), "presets": list(presets),
                     "iters": sorted(set(opts.iters)), "time_budget": opts.time_budget, "threads": opts.threads,
                     "repeats": opts.repeats, "bf16": opts.bf16, "model": _describe_model(opts.model),
                     "train_overrides": dict(opts.train_overrides),
                     "init": _describe_init(opts.init),
                     "render_config": opts.config.to_dict()},
        "cases": case_docs,
        "skipped": skipped,
        "errors": errors,
        "records": records,
    }
    doc["summary"] = report.summarize(records, presets, case_docs)
    return doc


def merge_runs(docs: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """One benchmark document from several (e.g. the presets of one comparison run on two cores): records, errors
    and skips concatenated, cases united by name, presets united in order; the first run's settings and machine
    are kept and every run's command is listed under ``merged_from``. One document is returned unchanged."""
    if len(docs) == 1:
        return docs[0]
    doc = json.loads(json.dumps(docs[0]))
    names = {c["name"] for c in doc["cases"]}
    presets = list(doc["settings"]["presets"])
    for other in docs[1:]:
        for key in ("records", "errors", "skipped"):
            doc[key] = doc[key] + other.get(key, [])
        doc["cases"] += [c for c in other["cases"] if c["name"] not in names]
        names |= {c["name"] for c in other["cases"]}
        presets += [p for p in other["settings"]["presets"] if p not in presets]
    doc["settings"]["presets"] = presets
    doc["merged_from"] = [{"command": d["command"], "date": d["date"]} for d in docs]
    return doc


def output_paths(out: Path, json_path: Optional[Path] = None) -> Dict[str, Path]:
    """Where :func:`write_outputs` writes each file."""
    paths = {k: Path(out) / v for k, v in OUTPUT_NAMES.items()}
    if json_path is not None:
        paths["json"] = Path(json_path)
    return paths


def write_outputs(doc: Dict[str, Any], out: Path, json_path: Optional[Path] = None,
                  force: bool = False) -> Dict[str, Path]:
    """Write ``results.md``, ``pareto.png``, the records JSON and ``summary.json``; returns their paths."""
    paths = output_paths(out, json_path)
    for p in paths.values():
        p.parent.mkdir(parents=True, exist_ok=True)
    series, titles = report.pareto_series(doc["records"])
    legend, note = plot_pareto(series, paths["plot"], titles=titles, force=force)
    report.write_json(paths["json"], doc, force)
    report.write_json(paths["summary"], {"schema": report.SCHEMA, "command": doc["command"], "date": doc["date"],
                                         **doc["summary"]}, force)
    report.write_text(paths["markdown"], report.markdown(doc, paths["plot"].name, legend, note), force)
    return paths


def _describe_model(model) -> Optional[dict]:
    """The preview model a run measures: ``{"file", "source", "sha256"}`` (the packaged one when ``model`` is
    None), or None when none can be found (the preview methods then skip)."""
    from svbrdf.runtime.errors import SvbrdfError as _Error
    from svbrdf.runtime.inference.manifest import find_model

    try:
        info = find_model(model)
    except _Error:
        return None
    return {"file": info.path.name, "path": str(info.path), "source": info.source, "sha256": info.sha256}


def _int_list(text: str) -> List[int]:
    try:
        vals = sorted({int(v) for v in text.split(",") if v.strip()})
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None
    if not vals or vals[0] < 0:
        raise argparse.ArgumentTypeError(f"expected non-negative integers, got {text!r}")
    return vals


def _names(text: str) -> List[str]:
    return [v.strip() for v in text.split(",") if v.strip()]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="svbrdf-bench", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", type=Path, default=None,
                   help="folder of ground-truth sets and/or photos (default: shared/data beside the source "
                        "checkout, i.e. <checkout>/../shared/data; see the README's 'Tests and data')")
    p.add_argument("--out", type=Path, default=None, help="output folder (default: runs/bench in the current folder)")
    p.add_argument("--json", type=Path, default=None, help="records JSON (default: OUT/results.json)")
    p.add_argument("--methods", type=_names, default=None, help=f"comma list of {', '.join(METHODS)} (default: all); "
                   "METHOD:P1+P2 restricts a training method to those presets, METHOD@N caps its iterations, "
                   "e.g. finetune@600,scratch:fast")
    p.add_argument("--presets", type=_names, default=None,
                   help=f"training presets (default: {','.join(DEFAULT_PRESETS)}; --quick: tiny)")
    p.add_argument("--size", type=int, default=None, help="case side in pixels (default 256; --quick: 64)")
    p.add_argument("--cases", default=None, help="first N cases, or comma-separated globs on the case or file name")
    p.add_argument("--split", choices=("tune", "check"), default=None,
                   help="only the part of the shared data tuned on, or only the part checked (docs/data-split.md; "
                        "default: all)")
    p.add_argument("--iters", type=_int_list, default=None,
                   help=f"evaluated iteration counts of one training run (default {','.join(map(str, DEFAULT_ITERS))})")
    p.add_argument("--time-budget", type=float, default=None, help="training seconds per run (default: none)")
    p.add_argument("--clean", action="store_true",
                   help="clean synthetic photos (the renderer's radiance clipped to [0, 1]; with --renderer ours, the "
                        "inverse-crime setting) instead of the default realistic ones (fall-off, exposure, "
                        "vignetting, noise, 8-bit sRGB; one camera drawn per case)")
    p.add_argument("--renderer", choices=RENDERERS, default="auto",
                   help="renderer of the synthetic photos (default auto: Mitsuba 3 where installed, else ours)")
    p.add_argument("--noise", type=float, default=0.0, help="with --clean: Gaussian sensor noise sigma (linear units)")
    p.add_argument("--quantize", action="store_true", help="with --clean: 8-bit sRGB quantisation")
    p.add_argument("--model", default=None, help="ONNX model for 'preview' (default: the packaged model)")
    p.add_argument("--init", action="append", default=None, metavar="[PRESET=]CKPT",
                   help="stage-one checkpoint for 'finetune' (repeatable per preset; default: the checkpoint of the preview model, named in its manifest)")
    p.add_argument("--threads", type=int, default=None, help="CPU threads for torch and onnxruntime")
    p.add_argument("--repeats", type=int, default=None, help="timed repeats of baseline/preview (default 3)")
    p.add_argument("--bf16", action="store_true", help="bfloat16 autocast in training")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="training setting for every training run by its dotted name (value parsed as JSON, else "
                        "text), e.g. --set losses.perceptual_min_clipped=0 or --set post.even_lighting=0; the flat "
                        "names of earlier records (perceptual_min_clipped=0) are read too; repeatable")
    p.add_argument("--quick", action="store_true",
                   help="pipeline check: 2 small cases at 64 px, tiny preset, iterations 0,2,4")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress (bar or lines)")
    p.add_argument("--report", metavar="RESULTS_JSON", action="append",  # or the run's folder
                   help="rewrite results.md, pareto.png and summary.json of an earlier run from its records "
                        "(after a change of the report code; nothing is re-run; output beside the JSON or --out); "
                        "repeated: merge the records of several runs (e.g. one per core) into one report in --out")
    return p


def _settings(values: List[str]) -> Dict[str, Any]:
    from svbrdf.trainer.config import parse_settings, setting_name

    try:
        out = {setting_name(k): v for k, v in parse_settings(values).items()}
    except ValueError as e:
        raise SvbrdfError(f"--set {e}") from None
    if out and torch_available():
        from svbrdf.trainer.config import resolve

        try:
            resolve("tiny", **out)
        except (ValueError, TypeError) as e:
            raise SvbrdfError(f"--set: {str(e).splitlines()[0]}") from None
    return out


def _parse_init(values: Optional[List[str]]):
    if not values:
        return None
    if len(values) == 1 and "=" not in values[0]:
        return values[0]
    out = {}
    for v in values:
        preset, sep, path = v.partition("=")
        if not sep or not preset or not path:
            raise SvbrdfError(f"--init {v!r}: give one CKPT, or PRESET=CKPT for each preset")
        out[preset] = path
    return out


def _report_folder(path: str) -> Path:
    p = Path(path)
    return p if p.is_dir() else p.parent


def _read_report(path: str) -> dict:
    """An earlier run's results.json (or the folder that holds it), or a one-line :class:`SvbrdfError`. A gzipped
    one (``results.json.gz``: how the repository keeps large raw records) reads the same."""
    p = Path(path)
    if p.is_dir():
        p = p / "results.json" if (p / "results.json").exists() or not (p / "results.json.gz").exists() \
            else p / "results.json.gz"
    try:
        if p.suffix == ".gz":
            import gzip

            with gzip.open(p, "rt", encoding="utf-8") as f:
                return json.load(f)
        return json.loads(p.read_text(encoding="utf-8"))
    except OSError as e:
        raise SvbrdfError(f"{p}: cannot read the run's results ({e.strerror or e})") from None
    except ValueError as e:
        raise SvbrdfError(f"{p}: not a results.json of svbrdf-bench ({str(e).splitlines()[0][:80]})") from None


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Command-line entry point; returns the exit code (0 ok, 1 some runs failed, 2 bad input)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    from svbrdf.runtime.progress import Progress, write

    say = (lambda _m: None) if args.quiet else write  # write: the lines do not break the bar on a terminal
    try:
        if args.threads is not None and args.threads < 1:
            raise SvbrdfError(f"--threads must be >= 1, got {args.threads}")
        if args.time_budget is not None and args.time_budget <= 0:
            raise SvbrdfError(f"--time-budget must be > 0, got {args.time_budget}")
        if args.noise < 0:
            raise SvbrdfError(f"--noise must be >= 0, got {args.noise}")
        if args.report is not None:  # re-derive the report of earlier runs from their records, no re-run
            if len(args.report) > 1 and args.out is None:
                raise SvbrdfError("merging several --report runs needs --out")
            doc = merge_runs([_read_report(p) for p in args.report])
            doc["summary"] = report.summarize(doc["records"], doc["settings"]["presets"], doc["cases"])
            doc["report_command"] = shlex.join(["svbrdf-bench"] + argv)
            written = write_outputs(doc, args.out or _report_folder(args.report[0]), None, force=True)
            for p in written.values():
                say(f"wrote {p}")
            return 0
        quick = args.quick
        data = args.data or default_data()
        out = args.out or DEFAULT_OUT
        paths = output_paths(out, args.json)
        existing = [str(p) for p in paths.values() if p.exists()]
        if existing and not args.force:
            raise SvbrdfError(f"{existing[0]}: exists (use --force to overwrite)")
        opts = BenchOptions(
            config=ZHAO,
            iters=list(args.iters or (QUICK["iters"] if quick else DEFAULT_ITERS)),
            time_budget=args.time_budget,
            model=args.model,
            init=_parse_init(args.init),
            threads=args.threads,
            repeats=args.repeats if args.repeats is not None else (QUICK["repeats"] if quick else 3),
            bf16=args.bf16,
            train_overrides=_settings(args.set),
        )
        if opts.repeats < 1:
            raise SvbrdfError(f"--repeats must be >= 1, got {opts.repeats}")
        doc = run_benchmark(
            data,
            methods=args.methods or tuple(METHODS),
            presets=args.presets or (QUICK["presets"] if quick else DEFAULT_PRESETS),
            size=args.size or (QUICK["size"] if quick else 256),
            cases=args.cases,
            split=args.split,
            realistic=not args.clean,
            renderer=args.renderer,
            noise=args.noise,
            quantize=args.quantize,
            opts=opts,
            quick=quick,
            command=shlex.join(["svbrdf-bench"] + argv),
            progress=say,
            runs_progress=lambda total: Progress(total, "svbrdf-bench", quiet=args.quiet, unit="run"),
        )
        written = write_outputs(doc, out, args.json, force=args.force)
    except SvbrdfError as e:
        print(f"svbrdf-bench: error: {e}", file=sys.stderr)
        return 2
    for p in written.values():
        say(f"wrote {p}")
    if doc["errors"]:
        print(f"svbrdf-bench: {len(doc['errors'])} run(s) failed (see {written['markdown']})", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
