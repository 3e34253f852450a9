"""onnxruntime time of ONNX generators on one photo size, interleaved (the graph alone, no pre/post-processing).

    python docs/benchmarks/prior-v2/scripts/onnx_speed.py A.onnx B.onnx --size 1024 --threads 1,2 --repeats 5

Per model and thread count: one session (CPU provider, memory arena on as in svbrdf.runtime.session), one warm-up
pass, then ``repeats`` passes interleaved across the models (A, B, A, B, ...) on the same random (1, 3, S, S) linear
photo; prints the median and the minimum in seconds as JSON lines.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np
import onnxruntime as ort


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    x = np.random.default_rng(0).random((1, 3, a.size, a.size), dtype=np.float32)
    for threads in (int(t) for t in a.threads.split(",")):
        sessions = {}
        for m in a.models:
            so = ort.SessionOptions()
            so.intra_op_num_threads = threads
            so.inter_op_num_threads = 1
            sessions[m] = ort.InferenceSession(m, so, providers=["CPUExecutionProvider"])
            sessions[m].run(None, {"image": x})
        times = {m: [] for m in a.models}
        for _ in range(a.repeats):
            for m, s in sessions.items():
                t0 = time.perf_counter()
                s.run(None, {"image": x})
                times[m].append(time.perf_counter() - t0)
        for m, t in times.items():
            print(json.dumps({"model": m, "size": a.size, "threads": threads, "median_s": round(statistics.median(t), 4),
                              "min_s": round(min(t), 4), "repeats": a.repeats}))


if __name__ == "__main__":
    main()
