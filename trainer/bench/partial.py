"""Maps on demand: time :func:`svbrdf.runtime.inference.pipeline.estimate` for subsets of the maps against all four.

::

    python -m svbrdf.trainer.bench.partial [--size 1024] [--repeats 5] [--threads N] [--model PATH]
                                           [--out DIR] [--force]

Cases (:data:`CASES`): all maps, ``normal``, ``roughness,normal``, ``diffuse``, ``diffuse,specular``. Each case
gets its own session, loaded for its maps (``load_session(maps=...)``, timed once: a subset loads only the part
graph it needs). The photo is the bundled ``runtime/examples/carved_wood.png`` resized to ``size`` x ``size``
(OpenImageIO, linear), passed as an array, so the time is inference plus post-processing (tiling as in
``svbrdf-preview``: one pass up to 1024 px). After one untimed warm-up run per case, each repeat times every case
once, in an order rotated by one per repeat (interleaved, so a load change on the machine hits every case);
the table gives medians and the ratio of each case's median to the median of all maps.

Outputs in ``--out`` (default ``docs/benchmarks/maps-on-demand/`` of the repository): ``results.md`` (command,
machine, table) and ``results.json`` (schema ``svbrdf-bench-partial/1``, every timing). Existing files are kept
unless ``--force``.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import shlex
import statistics
import sys
import time
from importlib import resources
from pathlib import Path
from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.files import atomic_write
from svbrdf.runtime.core.maps import MAP_NAMES

PROG = "python -m svbrdf.trainer.bench.partial"
SCHEMA = "svbrdf-bench-partial/1"
#: Requested maps per case (the first, all four, is the reference of the ratios).
CASES: Tuple[Tuple[str, ...], ...] = (MAP_NAMES, ("normal",), ("roughness", "normal"), ("diffuse",),
                                      ("diffuse", "specular"))
OUTPUT_NAMES = ("results.md", "results.json")


def example_photo(size: int) -> np.ndarray:
    """The bundled example photo resized to (size, size, 3), linear float32 (OpenImageIO resize)."""
    import OpenImageIO as oiio

    from svbrdf.runtime.io.images import read_image
    from svbrdf.runtime.io.images import RESIZE_FILTER

    photo = read_image(Path(str(resources.files("svbrdf.runtime") / "examples" / "carved_wood.png")))
    h, w, c = photo.shape
    src = oiio.ImageBuf(oiio.ImageSpec(w, h, c, oiio.FLOAT))
    src.set_pixels(oiio.ROI(), np.ascontiguousarray(photo))
    dst = oiio.ImageBufAlgo.resize(src, filtername=RESIZE_FILTER, roi=oiio.ROI(0, size, 0, size, 0, 1, 0, c))
    if dst.has_error:
        raise SvbrdfError(f"cannot resize the example photo to {size}x{size} ({dst.geterror()})")
    return np.clip(np.asarray(dst.get_pixels(oiio.FLOAT), np.float32).reshape(size, size, c), 0.0, None)


def run(size: int = 1024, repeats: int = 5, threads: Optional[int] = None, model: Optional[str] = None,
        progress=None) -> Dict[str, Any]:
    """Time every case of :data:`CASES`; returns the ``results.json`` document without command and machine."""
    from svbrdf.runtime.inference.pipeline import DEFAULT_MAX_SIZE, estimate
    from svbrdf.runtime.inference.session import load_session

    photo = example_photo(size)
    load_before = os.getloadavg()
    max_size = max(size, DEFAULT_MAX_SIZE)
    sessions, records = [], []
    for maps in CASES:
        t = time.perf_counter()
        session = load_session(model, threads=threads, maps=maps)
        load = time.perf_counter() - t
        estimate(photo, session, max_size=max_size)  # warm-up, untimed
        sessions.append(session)
        records.append({"maps": list(maps), "graph": session.graph_for(), "load_seconds": load,
                        "seconds": [], "infer_seconds": []})
    for r in range(repeats):
        order = list(range(len(CASES)))
        order = order[r % len(order):] + order[:r % len(order)]
        for i in order:
            t = time.perf_counter()
            maps = estimate(photo, sessions[i], max_size=max_size)
            records[i]["seconds"].append(time.perf_counter() - t)
            records[i]["infer_seconds"].append(maps.meta["timings"]["infer"])
        if progress:
            progress(f"repeat {r + 1}/{repeats}")
    for rec in records:
        rec["median"] = statistics.median(rec["seconds"])
        rec["median_infer"] = statistics.median(rec["infer_seconds"])
    for rec in records:
        rec["ratio"] = rec["median"] / records[0]["median"]
    info = sessions[0].info
    graphs = {"full": info.path, **{p: info.part_path(p) for p in info.parts}}
    return {
        "settings": {"size": size, "repeats": repeats, "threads": sessions[0].threads, "photo": "carved_wood.png",
                     "max_size": max_size, "providers": sessions[0].providers},
        # 1-minute load averages before and after: other processes compete for the cores on a shared machine
        "load_average": [round(load_before[0], 2), round(os.getloadavg()[0], 2)],
        "model": {"path": str(info.path), "sha256": info.sha256,
                  "graphs": {g: {"file": p.name, "bytes": p.stat().st_size} for g, p in graphs.items()}},
        "records": records,
    }


def markdown(doc: Dict[str, Any]) -> str:
    s, m = doc["settings"], doc["machine"]
    lines = [
        "# Maps on demand: `estimate()` time by requested maps",
        "",
        f"Written by `{PROG}` (module docstring: method). Command: `{doc['command']}`",
        "",
        f"- date: {doc['date']}",
        f"- machine: {m['cpu']}, {m['cores']} visible cores; onnxruntime {m['versions'].get('onnxruntime')}, "
        f"{s['threads']} intra-op thread(s), {', '.join(s['providers'])}; 1-min load average "
        f"{doc['load_average'][0]} before, {doc['load_average'][1]} after (other jobs share the cores)",
        f"- model: `{Path(doc['model']['path']).name}` (sha256 {doc['model']['sha256'][:12]}); graphs: "
        + ", ".join(f"{g} `{v['file']}` {v['bytes'] / 1e6:.2f} MB" for g, v in doc["model"]["graphs"].items()),
        f"- photo: {s['photo']} resized to {s['size']}x{s['size']}, as an array; {s['repeats']} repeats, interleaved "
        "(rotated order), median after one warm-up run per case",
        "",
        "| maps | graph run | load s | median s (estimate) | median s (inference) | min-max s | ratio to all |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in doc["records"]:
        name = "all" if tuple(r["maps"]) == MAP_NAMES else ",".join(r["maps"])
        lines.append(f"| {name} | {r['graph']} | {r['load_seconds']:.3f} | {r['median']:.3f} | "
                     f"{r['median_infer']:.3f} | {min(r['seconds']):.3f}-{max(r['seconds']):.3f} | "
                     f"{r['ratio']:.2f} |")
    lines += ["", "ratio = median estimate time of the case / median estimate time of all maps.", ""]
    return "\n".join(lines)


def _write(path: Path, text: str) -> None:
    with atomic_write(path, force=True) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Entry point; returns the exit code (0 ok, 1 failure, 2 usage error)."""
    from .common import repo_root

    p = argparse.ArgumentParser(prog=PROG, description="Time estimate() for subsets of the maps against all four.")
    p.add_argument("--size", type=_positive, default=1024, help="photo side in pixels (default: 1024)")
    p.add_argument("--repeats", type=_positive, default=5, help="timed runs per case (default: 5)")
    p.add_argument("--threads", type=_positive, default=None, help="onnxruntime threads (default: all cores)")
    p.add_argument("--model", metavar="PATH", help="ONNX model (default: $SVBRDF_MODEL, else the packaged model)")
    p.add_argument("--out", metavar="DIR", type=Path, default=None,
                   help="output folder (default: docs/benchmarks/maps-on-demand/ of the repository)")
    p.add_argument("--force", action="store_true", help="overwrite existing results")
    try:
        args = p.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    out = args.out if args.out is not None else repo_root() / "docs" / "benchmarks" / "maps-on-demand"
    targets = [out / n for n in OUTPUT_NAMES]
    existing = [t for t in targets if t.exists()]
    if existing and not args.force:
        print(f"{PROG}: error: {existing[0]}: exists (use --force to overwrite)", file=sys.stderr)
        return 1
    from .common import machine_info
    from .methods import BenchOptions

    try:
        doc = run(args.size, args.repeats, args.threads, args.model,
                  progress=lambda msg: print(msg, file=sys.stderr, flush=True))
    except SvbrdfError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 1
    argv_text = " ".join(shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv))
    doc = {"schema": SCHEMA, "command": f"{PROG} {argv_text}".strip(),
           "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
           "machine": machine_info(BenchOptions(threads=doc["settings"]["threads"])), **doc}
    text = markdown(doc)
    out.mkdir(parents=True, exist_ok=True)
    _write(targets[1], json.dumps(doc, indent=2) + "\n")
    _write(targets[0], text)
    print(text)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
