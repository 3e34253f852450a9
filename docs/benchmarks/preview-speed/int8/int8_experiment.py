"""int8 variants of the preview model (issue 18): build them with onnxruntime's own tools, time them against the
float model at 1024 px (interleaved, medians) and compare their maps with the float model's.

Run from the repository root (2 cores; nothing else pinned)::

    OMP_NUM_THREADS=2 .venv/bin/python docs/benchmarks/preview-speed/int8/int8_experiment.py build
    OMP_NUM_THREADS=2 .venv/bin/python docs/benchmarks/preview-speed/int8/int8_experiment.py time --repeats 7
    OMP_NUM_THREADS=2 .venv/bin/python docs/benchmarks/preview-speed/int8/int8_experiment.py maps

``build`` writes the variants into ``--work`` (default ``/tmp/int8``); each one is the full graph plus its two
part graphs (``NAME.normal_roughness.onnx``, ``NAME.diffuse_specular.onnx``), quantised alike.

Calibration: realistic flash photos of procedural materials, made exactly like the prior's training photos
(:func:`svbrdf.trainer.procedural.sample_materials` + :func:`svbrdf.trainer.prior.simulate_photos`: the flash
renderer and the realistic camera), seed 1234, never the shared ground-truth data. The ``maps`` comparison uses
another seed (4321) and larger photos.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[4]
FLOAT = ROOT / "models" / "svbrdf_prior_v1.onnx"
PARTS = ("normal_roughness", "diffuse_specular")


def photos(n: int, size: int, seed: int) -> list:
    """``n`` (1, 3, size, size) float32 linear photos of procedural materials (the prior's photo simulation)."""
    import torch

    from svbrdf.trainer.prior import PriorConfig, simulate_photos
    from svbrdf.trainer.procedural import sample_materials

    g = torch.Generator().manual_seed(seed)
    config = PriorConfig()
    out = []
    for _ in range(n):
        maps, _ = sample_materials(1, size, g)
        x, _, _ = simulate_photos(maps, config, g)
        out.append(x.numpy().astype(np.float32))
    return out


class _Reader:
    def __init__(self, data):
        from onnxruntime.quantization import CalibrationDataReader  # noqa: F401  (interface only)

        self._it = iter([{"image": x} for x in data])

    def get_next(self):
        return next(self._it, None)


VARIANTS = {
    # name: (kind, options)
    "static_minmax": ("static", {"calibrate_method": "MinMax"}),
    "static_percentile": ("static", {"calibrate_method": "Percentile"}),
    "static_entropy": ("static", {"calibrate_method": "Entropy"}),
    "static_minmax_s8s8": ("static", {"calibrate_method": "MinMax", "activation_type": "QInt8"}),
    # the encoder's first two and the decoders' last convolutions in float (most sensitive, least work), the
    # others' output channels equalised before the InstanceNormalization
    "static_equalized_partial": ("static", {"calibrate_method": "MinMax", "equalize": True, "exclude": (
        "node_Conv_370", "node_Conv_371", "node_Conv_379", "node_Conv_387")}),
    # only the convolutions that move a map by < 0.005 alone (measured one at a time)
    "static_least_sensitive": ("static", {"calibrate_method": "MinMax", "nodes": (
        "node_Conv_374", "node_Conv_375", "node_Conv_376")}),
    "dynamic": ("dynamic", {}),
}


def conv_stats(model, calib: list) -> dict:
    """Per-channel mean and standard deviation (over pixels, averaged over photos) of every Conv output."""
    import onnx
    import onnxruntime as ort

    m = onnx.ModelProto()
    m.CopyFrom(model)
    convs = [n for n in m.graph.node if n.op_type == "Conv"]
    for n in convs:
        m.graph.output.append(onnx.helper.make_tensor_value_info(n.output[0], onnx.TensorProto.FLOAT, None))
    s = ort.InferenceSession(m.SerializeToString(), providers=["CPUExecutionProvider"])
    outs = [s.run([n.output[0] for n in convs], {"image": x}) for x in calib]
    stats = {}
    for i, n in enumerate(convs):
        a = np.stack([o[i][0] for o in outs]).astype(np.float64)
        stats[n.name] = (a.mean(axis=(2, 3)).mean(0), a.std(axis=(2, 3)).mean(0))
    return stats


def equalize(src: Path, dst: Path, calib: list, skip=()) -> None:
    """Rescale and re-centre the output channels of each Conv that feeds an InstanceNormalization (which removes
    per-channel scale and offset), so that every channel has mean 0 and standard deviation 1 on the calibration
    photos: one per-tensor activation scale then suits all channels. Exact up to the norm's epsilon, which acts
    as ``eps * std**2`` afterwards (negligible where the channel variance is far above eps)."""
    import onnx
    from onnx import numpy_helper

    m = onnx.load(str(src))
    stats = conv_stats(m, calib)
    consumers = {}
    for n in m.graph.node:
        for i in n.input:
            consumers.setdefault(i, []).append(n)
    inits = {t.name: t for t in m.graph.initializer}
    for n in m.graph.node:
        users = consumers.get(n.output[0], [])
        if n.op_type != "Conv" or n.name in skip or len(users) != 1 or users[0].op_type != "InstanceNormalization":
            continue
        mean, std = stats[n.name]
        scale = 1.0 / np.maximum(std, 1e-8)
        w = numpy_helper.to_array(inits[n.input[1]]).astype(np.float64)
        w = w * scale.reshape(-1, *([1] * (w.ndim - 1)))
        bias = numpy_helper.to_array(inits[n.input[2]]).astype(np.float64) if len(n.input) > 2 else 0 * scale
        bias = (bias - mean) * scale
        inits[n.input[1]].CopyFrom(numpy_helper.from_array(w.astype(np.float32), n.input[1]))
        if len(n.input) > 2:
            inits[n.input[2]].CopyFrom(numpy_helper.from_array(bias.astype(np.float32), n.input[2]))
        else:
            name = n.name + "_bias"
            m.graph.initializer.append(numpy_helper.from_array(bias.astype(np.float32), name))
            n.input.append(name)
    onnx.save(m, str(dst))


def build_one(src: Path, dst: Path, kind: str, options: dict, calib: list) -> None:
    from onnxruntime.quantization import CalibrationMethod, QuantFormat, QuantType, quantize_dynamic, quantize_static
    from onnxruntime.quantization.shape_inference import quant_pre_process

    pre = dst.with_suffix(".pre.onnx")
    quant_pre_process(str(src), str(pre), skip_symbolic_shape=True)
    if options.get("equalize"):
        equalize(pre, pre, calib, skip=options.get("exclude", ()))
    if kind == "static":
        quantize_static(
            str(pre), str(dst), _Reader(calib),
            quant_format=QuantFormat.QDQ, per_channel=True,
            activation_type=getattr(QuantType, options.get("activation_type", "QUInt8")),
            weight_type=QuantType.QInt8,
            calibrate_method=getattr(CalibrationMethod, options["calibrate_method"]),
            op_types_to_quantize=options.get("ops", ["Conv"]),
            nodes_to_exclude=list(options.get("exclude", ())),
            nodes_to_quantize=list(options["nodes"]) if "nodes" in options else None,
            extra_options={"CalibMovingAverage": False},
        )
    else:
        quantize_dynamic(str(pre), str(dst), per_channel=True, weight_type=QuantType.QInt8,
                         op_types_to_quantize=["Conv"])
    pre.unlink()
    copy_metadata(src, dst)


def copy_metadata(src: Path, dst: Path) -> None:
    """The quantiser drops ``metadata_props``: copy the svbrdf manifest keys over, so the runtime accepts the file."""
    import onnx

    m = onnx.load(str(dst))
    del m.metadata_props[:]
    m.metadata_props.extend(onnx.load(str(src)).metadata_props)
    onnx.save(m, str(dst))


def build(args) -> None:
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    calib = photos(args.calib, args.calib_size, 1234)
    names = args.variants.split(",") if args.variants else list(VARIANTS)
    for name in names:
        kind, options = VARIANTS[name]
        # node names differ in the part graphs: variants that name nodes are built for the full graph only
        named = "nodes" in options or "exclude" in options
        for part in (None,) + (() if named else PARTS):
            src = FLOAT if part is None else FLOAT.with_name(f"{FLOAT.stem}.{part}.onnx")
            dst = work / (f"{name}.onnx" if part is None else f"{name}.{part}.onnx")
            t = time.perf_counter()
            build_one(src, dst, kind, options, calib)
            print(f"{dst.name}: {dst.stat().st_size / 1e6:.2f} MB in {time.perf_counter() - t:.0f} s", flush=True)


def session(path: Path, threads: int):
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.intra_op_num_threads = threads
    so.inter_op_num_threads = 1
    so.log_severity_level = 3
    return ort.InferenceSession(str(path), so, providers=["CPUExecutionProvider"])


def models(work: Path, names: list) -> dict:
    out = {"float": FLOAT}
    for name in names:
        out[name] = work / f"{name}.onnx"
    return out


def time_all(args) -> None:
    work = Path(args.work)
    names = args.variants.split(",") if args.variants else [n for n in VARIANTS if (work / f"{n}.onnx").is_file()]
    x = photos(1, args.size, 99)[0]
    results = {}
    for graph in (None,) + PARTS:
        sessions = {}
        for key, path in models(work, names).items():
            p = path if graph is None else path.with_name(f"{path.stem}.{graph}.onnx")
            if not p.is_file():
                continue
            sessions[key] = session(p, args.threads)
            sessions[key].run(None, {"image": x})  # warm-up
        times = {k: [] for k in sessions}
        for _ in range(args.repeats):
            for key, s in sessions.items():  # interleaved: one run of each in turn
                t = time.perf_counter()
                s.run(None, {"image": x})
                times[key].append(time.perf_counter() - t)
        g = graph or "full"
        results[g] = {k: {"median_s": statistics.median(v), "min_s": min(v), "runs": v} for k, v in times.items()}
        for k, v in results[g].items():
            print(f"{g:17s} {k:22s} median {v['median_s']:.3f} s  min {v['min_s']:.3f} s", flush=True)
    out = Path(args.out) / f"time_{args.size}.json"
    out.write_text(json.dumps({"size": args.size, "threads": args.threads, "repeats": args.repeats,
                               "results": results}, indent=1))


def maps(args) -> None:
    """Per-map RMSE between the float model's maps and each variant's (maps clipped as the runtime does)."""
    from svbrdf.runtime.maps import Maps, SLICES

    work = Path(args.work)
    names = args.variants.split(",") if args.variants else [n for n in VARIANTS if (work / f"{n}.onnx").is_file()]
    xs = photos(args.n, args.size, 4321)
    paths = models(work, names)
    outs = {}
    for key, path in paths.items():
        s = session(path, args.threads)
        outs[key] = [Maps.unpack(s.run(None, {"image": x})[0][0].transpose(1, 2, 0), {}).clipped() for x in xs]
    doc = {}
    for key in names:
        per = {}
        for m in SLICES:
            d = [np.asarray(getattr(a, m)) - np.asarray(getattr(b, m)) for a, b in zip(outs["float"], outs[key])]
            per[m] = float(np.sqrt(np.mean(np.concatenate([e.ravel() for e in d]) ** 2)))
        doc[key] = per
        print(key, " ".join(f"{m} {v:.4f}" for m, v in per.items()), flush=True)
    (Path(args.out) / f"maps_vs_float_{args.size}.json").write_text(json.dumps(
        {"photos": args.n, "size": args.size, "seed": 4321, "rmse": doc}, indent=1))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("step", choices=("build", "time", "maps"))
    p.add_argument("--work", default="/tmp/int8", help="folder of the variants (default: /tmp/int8)")
    p.add_argument("--out", default=str(Path(__file__).parent), help="where the JSON results go")
    p.add_argument("--variants", default="", help=f"comma list of {', '.join(VARIANTS)} (default: all built)")
    p.add_argument("--calib", type=int, default=32, help="calibration photos (default 32)")
    p.add_argument("--calib-size", type=int, default=256, help="their side, px (default 256)")
    p.add_argument("--size", type=int, default=1024, help="photo side for time/maps (default 1024)")
    p.add_argument("--n", type=int, default=8, help="photos compared by 'maps' (default 8)")
    p.add_argument("--repeats", type=int, default=7, help="timed runs per model (default 7)")
    p.add_argument("--threads", type=int, default=2, help="intra-op threads (default 2)")
    args = p.parse_args(argv)
    {"build": build, "time": time_all, "maps": maps}[args.step](args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
