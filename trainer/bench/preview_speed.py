"""Where the time of an instant preview goes, before and after the preview-speed changes, side by side.

Run as ``python -m svbrdf.trainer.bench.preview_speed [--sizes 512,1024,2048,4096] [--repeats 3] [--threads 2]
[--process-repeats 5] [--out DIR] [--force]`` (default ``--out docs/benchmarks/preview-speed``). Four parts:

* **steps**, in one process: the pipeline of ``svbrdf-preview`` on the bundled photo resized to each size with
  the CLI's defaults (``--max-size 2048``, ``--tile 1024``): ``read`` (decode + sRGB to linear), ``model``
  (onnxruntime), ``post`` (downsizing, clipping, burn-in), ``relit`` (:func:`~svbrdf.runtime.outputs.texture_set.relit_panel`)
  and ``write`` (:func:`~svbrdf.runtime.outputs.texture_set.write_texture_set` with the panel). ``before`` and ``after``
  take turns (A/B/A/B, ``--repeats`` times per size) so that the load of a shared machine hits both alike;
  medians are reported. ``before`` is the code as it was, reproduced by its settings: no onnxruntime memory
  arena (``load_session(..., cpu_mem_arena=False)``), libpng's default compression (``PNG_OPTIONS = {}``), one
  writing thread (``WRITE_WORKERS = 1``) and a full-size panel (``size=None``). The model file is the same in
  both (no variant of it was adopted; see the README). The sessions are warm here (one preview each first),
  so the arena's gain shows in the **process** part, where each pass is a process's first.
* **process**: the wall time of a whole ``svbrdf-preview`` process on the 1024 px photo (interpreter start,
  imports, model load, the pipeline, exit) and the time the CLI reports, ``before`` and ``after`` alternating;
  ``before`` runs the CLI through a driver that sets the three settings above, ``after`` through the same driver
  without them, and ``entry`` is the installed ``svbrdf-preview`` script as shipped.
* **import**: ``python -X importtime`` of what a preview imports (CLI, session, texture-set writer,
  onnxruntime, OpenImageIO), per top-level package, median of ``--process-repeats`` fresh interpreters.
* **conv**: the machine's conv throughput, four 3x3 convolutions 128 -> 128 channels on 256 x 256 in a row
  (38.7 GMAC; the model's largest layer is 128 -> 256 on 256 x 256) in onnxruntime with ``--threads`` threads
  and the preview session's settings, taking turns with the model at 1024 px,
  whose multiply-adds are counted from an onnxruntime profile of the unoptimised graph; the ratio of the two
  rates is the fraction of the conv throughput the model reaches.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from svbrdf.runtime.errors import SvbrdfError

from .common import repo_root, results_paths, write_results

STEPS = ("read", "model", "post", "relit", "write")
VARIANTS = ("before", "after")
IMPORTS = ("svbrdf", "onnxruntime", "OpenImageIO", "numpy")
# Run by a fresh interpreter: svbrdf-preview with the 'before' settings or without them.
DRIVER = """
import functools, sys
from svbrdf.runtime.io import images as imageio
from svbrdf.runtime.inference import session
from svbrdf.runtime.outputs import texture_set
if sys.argv[1] == "before":
    session.load_session = functools.partial(session.load_session, cpu_mem_arena=False)
    imageio.PNG_OPTIONS = {}
    texture_set.WRITE_WORKERS = 1
    texture_set.relit_panel = functools.partial(texture_set.relit_panel, size=None)
from svbrdf.runtime.cli.preview import main
sys.exit(main(sys.argv[2:]))
"""


def _settings(variant: str):
    """Set the module settings of ``variant``; returns the relit-panel function to call."""
    from svbrdf.runtime.io import images as imageio
    from svbrdf.runtime.outputs import texture_set

    if variant == "before":
        imageio.PNG_OPTIONS = {}
        texture_set.WRITE_WORKERS = 1
        return functools.partial(texture_set.relit_panel, size=None)
    imageio.PNG_OPTIONS = dict(AFTER_PNG_OPTIONS)
    texture_set.WRITE_WORKERS = AFTER_WORKERS
    return texture_set.relit_panel


def _shipped():
    from svbrdf.runtime.io import images as imageio
    from svbrdf.runtime.outputs import texture_set

    return dict(imageio.PNG_OPTIONS), texture_set.WRITE_WORKERS


AFTER_PNG_OPTIONS, AFTER_WORKERS = _shipped()


def make_photos(sizes: Sequence[int], folder: Path) -> Dict[int, Path]:
    """The bundled 256 px photo resized (OpenImageIO, default filter) to ``size`` x ``size``, 8-bit PNG."""
    import OpenImageIO as oiio

    src = oiio.ImageBuf(str(repo_root() / "runtime" / "examples" / "carved_wood.png"))
    out = {}
    for size in sizes:
        dst = oiio.ImageBufAlgo.resize(src, roi=oiio.ROI(0, size, 0, size, 0, 1, 0, src.spec().nchannels))
        path = folder / f"wood{size}.png"
        if dst.has_error or not dst.write(str(path)):
            raise SvbrdfError(f"{path}: cannot make the test photo ({dst.geterror()})")
        out[size] = path
    return out


def one_preview(photo: Path, session, variant: str, out: Path) -> Dict[str, float]:
    """Seconds per step of one preview of ``photo`` (the CLI's pipeline and defaults) with ``variant``'s settings."""
    from svbrdf.runtime.inference.pipeline import estimate
    from svbrdf.runtime.outputs.texture_set import write_texture_set

    panel = _settings(variant)
    t0 = time.perf_counter()
    maps = estimate(photo, session, max_size=2048, tile=1024, overlap=64)
    t1 = time.perf_counter()
    relit = panel(maps, session.render_config)
    t2 = time.perf_counter()
    write_texture_set(maps, out, photo.stem, force=True, relit=relit)
    t3 = time.perf_counter()
    tm = maps.meta["timings"]
    times = {"read": tm["read"], "model": tm["infer"], "post": (t1 - t0) - tm["read"] - tm["infer"],
             "relit": t2 - t1, "write": t3 - t2}
    times["total"] = t3 - t0
    return times


def steps(photos: Dict[int, Path], threads: int, repeats: int, work: Path) -> Dict[str, Any]:
    from svbrdf.runtime.inference.session import load_session

    sessions = {}
    for variant in VARIANTS:
        sessions[variant] = load_session(threads=threads, cpu_mem_arena=variant == "after")
        one_preview(photos[min(photos)], sessions[variant], variant, work / "warm")  # first-call costs out of the way
    out: Dict[str, Any] = {}
    for size, photo in photos.items():
        runs: Dict[str, List[Dict[str, float]]] = {v: [] for v in VARIANTS}
        for _ in range(repeats):
            for variant in VARIANTS:
                runs[variant].append(one_preview(photo, sessions[variant], variant, work / variant))
        out[str(size)] = {v: {k: statistics.median(r[k] for r in rs) for k in (*STEPS, "total")}
                          for v, rs in runs.items()}
        print(f"steps {size}: " + "  ".join(f"{v} {out[str(size)][v]['total']:.2f} s" for v in VARIANTS),
              file=sys.stderr)
    _settings("after")
    return out


_REPORTED = re.compile(r"\s(\d+\.\d+) s \(model (\d+\.\d+) s")


def process(photo: Path, threads: int, repeats: int, work: Path) -> Dict[str, Any]:
    """Whole-process wall time and CLI-reported time of ``svbrdf-preview`` on ``photo``."""
    env = {**os.environ, "OMP_NUM_THREADS": str(threads)}
    entry = Path(sys.executable).with_name("svbrdf-preview")
    commands = {v: [sys.executable, "-c", DRIVER, v] for v in VARIANTS}
    if entry.is_file():
        commands["entry"] = [str(entry)]
    runs: Dict[str, Dict[str, List[float]]] = {v: {"wall": [], "reported": [], "model": []} for v in commands}
    for _ in range(repeats):
        for variant, cmd in commands.items():
            argv = [*cmd, str(photo), "-o", str(work / f"proc-{variant}"), "--force", "--threads", str(threads)]
            t = time.perf_counter()
            done = subprocess.run(argv, env=env, capture_output=True, text=True)
            wall = time.perf_counter() - t
            found = _REPORTED.search(done.stdout)
            if done.returncode != 0 or not found:
                raise SvbrdfError(f"svbrdf-preview ({variant}) failed: {done.stderr.strip()[-300:]}")
            runs[variant]["wall"].append(wall)
            runs[variant]["reported"].append(float(found.group(1)))
            runs[variant]["model"].append(float(found.group(2)))
    return {v: {k: statistics.median(x) for k, x in r.items()} | {"runs": r["wall"]} for v, r in runs.items()}


def import_times(repeats: int) -> Dict[str, float]:
    """Median cumulative import seconds of what a preview imports, per top-level package in import order (a
    package first imported by another counts in that one's time: numpy in ``svbrdf``), with the wall time of
    the interpreter importing it all and of a bare ``python -c pass``."""
    code = ("import svbrdf.runtime.cli.preview, svbrdf.runtime.inference.session, svbrdf.runtime.outputs.texture_set, onnxruntime, "
            "OpenImageIO")
    runs: Dict[str, List[float]] = {}
    for _ in range(repeats):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "pass"], check=True)
        bare = time.perf_counter() - t
        t = time.perf_counter()
        done = subprocess.run([sys.executable, "-X", "importtime", "-c", code], capture_output=True, text=True)
        wall = time.perf_counter() - t
        cumulative: Dict[str, float] = {"other": 0.0}
        for line in done.stderr.splitlines():
            parts = line.split("|")
            if len(parts) != 3 or not parts[1].strip().isdigit():
                continue
            name = parts[2].rstrip()
            if len(name) - len(name.lstrip()) != 1:  # nested import: counted in its top-level importer
                continue
            key = name.strip().split(".")[0]
            key = key if key in IMPORTS else "other"
            cumulative[key] = cumulative.get(key, 0.0) + int(parts[1]) / 1e6
        cumulative.update(python_bare_wall=bare, python_with_imports_wall=wall)
        for k, v in cumulative.items():
            runs.setdefault(k, []).append(v)
    return {k: statistics.median(v) for k, v in runs.items()}


CONV_LAYERS = 4


def _conv_model(path: Path) -> None:
    """:data:`CONV_LAYERS` 3x3 convolutions 128 -> 128 channels on 256 x 256 in a row (the NCHWc layout
    conversions at its ends amortised, as in the model)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(0)
    weights = [numpy_helper.from_array((rng.standard_normal((128, 128, 3, 3)) * 0.03).astype(np.float32), f"w{i}")
               for i in range(CONV_LAYERS)]
    names = ["x", *(f"h{i}" for i in range(1, CONV_LAYERS)), "y"]
    nodes = [helper.make_node("Conv", [names[i], f"w{i}"], [names[i + 1]], pads=[1, 1, 1, 1])
             for i in range(CONV_LAYERS)]
    graph = helper.make_graph(nodes, "conv", [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 128, 256, 256])],
                              [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, 128, 256, 256])], weights)
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)]), str(path))


def _ort_session(path, threads: int, optimize: bool = True, profile: Optional[str] = None):
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.intra_op_num_threads = threads
    so.inter_op_num_threads = 1
    so.enable_cpu_mem_arena = False  # as the preview session
    so.log_severity_level = 3
    if not optimize:
        so.graph_optimization_level = ort.GraphOptimizationLevel.ORT_DISABLE_ALL
    if profile:
        so.enable_profiling = True
        so.profile_file_prefix = profile
    return ort.InferenceSession(str(path), so, providers=["CPUExecutionProvider"])


def model_macs(model: Path, size: int, work: Path) -> float:
    """Multiply-adds of the model's Conv nodes on a ``size`` px input (onnxruntime profile, unoptimised graph)."""
    s = _ort_session(model, 1, optimize=False, profile=str(work / "macs"))
    s.run(None, {"image": np.zeros((1, 3, size, size), np.float32)})
    events = json.loads(Path(s.end_profiling()).read_text())
    macs = 0.0
    for e in events:
        args = e.get("args", {})
        if e.get("cat") == "Node" and args.get("op_name") == "Conv" and e["name"].endswith("_kernel_time"):
            w = list(args["input_type_shape"][1].values())[0]
            y = list(args["output_type_shape"][0].values())[0]
            macs += float(np.prod(y)) * float(np.prod(w[1:]))
    return macs


def conv_throughput(model: Path, threads: int, repeats: int, work: Path, size: int = 1024) -> Dict[str, Any]:
    conv_path = work / "conv.onnx"
    _conv_model(conv_path)
    conv = _ort_session(conv_path, threads)
    net = _ort_session(model, threads)
    x_conv = np.random.default_rng(1).random((1, 128, 256, 256), dtype=np.float32)
    x_net = np.random.default_rng(2).random((1, 3, size, size), dtype=np.float32)
    conv.run(None, {"x": x_conv})
    net.run(None, {"image": x_net})
    t_conv, t_net = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        conv.run(None, {"x": x_conv})
        t_conv.append(time.perf_counter() - t)
        t = time.perf_counter()
        net.run(None, {"image": x_net})
        t_net.append(time.perf_counter() - t)
    conv_macs = CONV_LAYERS * 256 * 256 * 128 * 128 * 9
    net_macs = model_macs(model, size, work)
    conv_rate = 2 * conv_macs / statistics.median(t_conv) / 1e9
    net_rate = 2 * net_macs / statistics.median(t_net) / 1e9
    return {"conv": {"shape": f"{CONV_LAYERS} x (1x128x256x256 -> 128, 3x3)", "gflop": 2 * conv_macs / 1e9,
                     "seconds": statistics.median(t_conv), "gflops": conv_rate},
            "model": {"size": size, "gflop": 2 * net_macs / 1e9, "seconds": statistics.median(t_net),
                      "gflops": net_rate},
            "fraction": net_rate / conv_rate, "threads": threads}


#: PNG settings compared by the ``png`` part: name -> OpenImageIO attributes ({}: libpng's defaults).
PNG_CHOICES = {
    "default (level 6, adaptive)": {},
    "level 1, adaptive": {"png:compressionLevel": 1},
    "level 1, none": {"png:compressionLevel": 1, "png:filter": 0x08},
    "level 1, sub": {"png:compressionLevel": 1, "png:filter": 0x10},
    "level 1, up": {"png:compressionLevel": 1, "png:filter": 0x20},
    "level 1, paeth": {"png:compressionLevel": 1, "png:filter": 0x80},
    "level 2, up": {"png:compressionLevel": 2, "png:filter": 0x20},
    "level 3, up": {"png:compressionLevel": 3, "png:filter": 0x20},
    "level 6, up": {"png:compressionLevel": 6, "png:filter": 0x20},
}


def png_choices(photo: Path, threads: int, repeats: int, work: Path) -> Dict[str, Any]:
    """Seconds (one thread, median) and bytes of the five PNG files of a preview of ``photo`` per
    :data:`PNG_CHOICES` entry, the entries taking turns; pixels checked equal to the default's."""
    from svbrdf.runtime.io import images as imageio
    from svbrdf.runtime.outputs import texture_set
    from svbrdf.runtime.inference.pipeline import estimate
    from svbrdf.runtime.inference.session import load_session

    session = load_session(threads=threads)
    maps = estimate(photo, session)
    relit = texture_set.relit_panel(maps, session.render_config)
    texture_set.WRITE_WORKERS = 1
    runs: Dict[str, List[float]] = {k: [] for k in PNG_CHOICES}
    files: Dict[str, Dict[str, Path]] = {}
    for _ in range(repeats):
        for i, (name, options) in enumerate(PNG_CHOICES.items()):
            imageio.PNG_OPTIONS = options
            t = time.perf_counter()
            files[name] = texture_set.write_texture_set(maps, work / f"png-{i}", "m", relit=relit, force=True)
            runs[name].append(time.perf_counter() - t)
    imageio.PNG_OPTIONS, texture_set.WRITE_WORKERS = dict(AFTER_PNG_OPTIONS), AFTER_WORKERS
    ref = files[next(iter(PNG_CHOICES))]
    out = {}
    for name, paths in files.items():
        same = all(np.array_equal(imageio.read_image(paths[r], raw=True), imageio.read_image(ref[r], raw=True))
                   for r in paths if r != "sidecar")
        if not same:
            raise SvbrdfError(f"PNG settings {name!r} changed pixels")
        out[name] = {"seconds": statistics.median(runs[name]), "options": PNG_CHOICES[name],
                     "bytes": {r: p.stat().st_size for r, p in paths.items() if r != "sidecar"}}
    return out


def _machine(threads: int) -> Dict[str, Any]:
    from .common import machine_info
    from .methods import BenchOptions

    return machine_info(BenchOptions(threads=threads))


def markdown(doc: Dict[str, Any]) -> str:
    lines = [f"# Preview speed: before and after, side by side", "", f"`{doc['command']}` ({doc['date']})", "",
             f"Machine: {doc['machine']['cpu']}, {doc['machine']['cores']} cores; {doc['threads']} threads. "
             f"Medians of {doc['repeats']} alternating runs (seconds).", "",
             "| size | variant | " + " | ".join(STEPS) + " | total |", "|---|---|" + "---|" * (len(STEPS) + 1)]
    for size, by in doc.get("steps", {}).items():
        for v in VARIANTS:
            r = by[v]
            lines.append(f"| {size} | {v} | " + " | ".join(f"{r[k]:.3f}" for k in STEPS) + f" | {r['total']:.3f} |")
    p = doc.get("process")
    if p:
        lines += ["", f"Whole `svbrdf-preview` process at 1024 px, medians of {doc['process_repeats']}:", "",
                  "| variant | wall | CLI reported | model |", "|---|---|---|---|"]
        for v, r in p.items():
            lines.append(f"| {v} | {r['wall']:.2f} | {r['reported']:.2f} | {r['model']:.2f} |")
    imp = doc.get("imports")
    if imp:
        lines += ["", "Import (cumulative, `python -X importtime`): "
                  + ", ".join(f"{k} {v:.3f} s" for k, v in imp.items())]
    png = doc.get("png")
    if png:
        base = png[next(iter(png))]
        lines += ["", "PNG settings, the five PNG files of the 1024 px preview (one thread; same pixels checked):", "",
                  "| settings | seconds | MB | vs default: time | size |", "|---|---|---|---|---|"]
        for name, r in png.items():
            mb, base_mb = sum(r["bytes"].values()) / 1e6, sum(base["bytes"].values()) / 1e6
            lines.append(f"| {name} | {r['seconds']:.3f} | {mb:.2f} | {r['seconds'] / base['seconds']:.2f}x | "
                         f"{mb / base_mb:.2f}x |")
    c = doc.get("conv")
    if c:
        lines += ["", f"Conv throughput ({c['conv']['shape']}): {c['conv']['gflops']:.0f} GFLOP/s; the model at "
                      f"{c['model']['size']} px: {c['model']['gflop']:.0f} GFLOP in {c['model']['seconds']:.3f} s = "
                      f"{c['model']['gflops']:.0f} GFLOP/s, **{100 * c['fraction']:.0f} %** of it."]
    return "\n".join(lines) + "\n"


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.bench.preview_speed", description=__doc__.split("\n")[0])
    p.add_argument("--sizes", default="512,1024,2048,4096", help="photo sizes (default: 512,1024,2048,4096)")
    p.add_argument("--repeats", type=int, default=3, help="alternating runs per size (default: 3)")
    p.add_argument("--process-repeats", type=int, default=5, help="whole-process and import runs (default: 5)")
    p.add_argument("--threads", type=int, default=2, help="onnxruntime intra-op threads (default: 2)")
    p.add_argument("--parts", default="steps,process,imports,conv",
                   help="parts to run, of steps, process, imports, conv, png (default: the first four)")
    p.add_argument("--out", type=Path, default=repo_root() / "docs" / "benchmarks" / "preview-speed")
    p.add_argument("--force", action="store_true", help="overwrite existing results")
    args = p.parse_args(argv)
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        paths = results_paths(args.out, args.force)
        sizes = [int(s) for s in args.sizes.split(",")]
        parts = set(args.parts.split(","))
        from svbrdf.runtime.inference.manifest import find_model

        model = find_model(None).path
        doc: Dict[str, Any] = {"threads": args.threads, "repeats": args.repeats,
                               "process_repeats": args.process_repeats, "machine": _machine(args.threads),
                               "after_settings": {"PNG_OPTIONS": AFTER_PNG_OPTIONS, "WRITE_WORKERS": AFTER_WORKERS}}
        with tempfile.TemporaryDirectory(prefix="preview-speed-") as tmp:
            work = Path(tmp)
            photos = make_photos(sorted(set(sizes) | {1024}), work)
            if "conv" in parts:
                doc["conv"] = conv_throughput(model, args.threads, max(5, args.repeats), work)
            if "steps" in parts:
                doc["steps"] = steps({s: photos[s] for s in sizes}, args.threads, args.repeats, work)
            if "process" in parts:
                doc["process"] = process(photos[1024], args.threads, args.process_repeats, work)
            if "png" in parts:
                doc["png"] = png_choices(photos[1024], args.threads, args.repeats, work)
            if "imports" in parts:
                doc["imports"] = import_times(args.process_repeats)
        write_results(paths, "svbrdf.trainer.bench.preview_speed", argv, doc, markdown)
    except SvbrdfError as exc:
        print(f"preview_speed: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
