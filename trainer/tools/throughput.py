"""Samples per second of the prior's training step with the host stream and the device stream, side by side (issue 64).

    python -m svbrdf.trainer.tools.throughput --device cpu --small --out throughput.json
    python -m svbrdf.trainer.tools.throughput --out gpu-throughput.json   # on a GPU; committed into docs/results/

Both paths time the same full training step of the v2 recipe's settings (``PRIOR_PRESETS["v2"]``: batch building,
the generator's forward under bf16 autocast where the device has fast bf16, the prior loss, backward and Adam),
with the same network and image size (and the same share of crop batches, ``--crop-share``: over a few steps on a
CPU give 1 or 0, so that both paths do the same work); only ``materials.stream`` differs: ``host`` (every random number drawn
on the CPU material by material, the shipped v2 stream: :mod:`svbrdf.trainer.procedural`) and ``device`` (families
vectorised over the batch, random numbers on the device: :mod:`svbrdf.trainer.prior.device_stream`). Each path first
runs ``--warmup`` untimed steps; then the paths are timed in ``--rounds`` alternating blocks (:func:`time_paths`) of at
least ``--steps`` steps (and ``--seconds`` / rounds seconds) each, so that a change of the machine's load slows both
alike; the clock stops after a device synchronisation.

On CUDA the networks are channels-last and, unless ``--batch`` is given, the batch is chosen for the card: the device
path is tried at 32, 64, 128, ... materials (a warm-up and two timed steps each) while the peak memory stays under
``--memory-cap`` of the card's and no step runs out of memory, and the batch with the best samples per second is
kept (``batch_search`` in the JSON); the host path runs at v2's batch (32, ``--host-batch``): the old stream as the
shipped run used it against the new one at the card's batch. On a CPU the networks are channels-last too (what the
trainer does there); ``--small`` is a few-second check (batch 4, 64 px crops of 128 px photos, 1 warm-up and 2
timed steps).

Writes ``--out`` (JSON): the device's name (the card, or the CPU's model name), torch's version, batch, size,
photo size, bf16, channels-last, per path its samples per second, seconds per step and per batch build, the shapes
and value ranges of one batch, the torch operations one batch dispatches (``ops_per_batch``: kernel launches on a
GPU) and on CUDA the host synchronisations it makes (``syncs_per_batch``); the host path's batch (``host_batch``)
and ``ratio`` = device / host samples per second. Prints one line per path and the ratio.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional

import torch

PATHS = ("host", "device")


def device_name(device: torch.device) -> str:
    """The card's name, or the CPU's model name (``/proc/cpuinfo``; else :func:`platform.processor`)."""
    if device.type == "cuda":
        return torch.cuda.get_device_name(device)
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


class Bench:
    """One path's training step: the v2 settings with ``materials.stream`` = ``path``, a fresh generator and Adam."""

    def __init__(self, path: str, device: torch.device, batch: int, size: int, photo_size: int, seed: int = 0,
                 crop_share: Optional[float] = None):
        from svbrdf.trainer.device import bf16_support
        from svbrdf.trainer.models import Generator
        from svbrdf.trainer.prior import prior_preset

        self.device = device
        from svbrdf.trainer.prior.config import override

        self.config = override(prior_preset("v2"), {"photos.size": size, "photos.photo_size": photo_size,
                                                    "optim.batch": batch, "materials.stream": path, "optim.seed": seed})
        if crop_share is not None:
            self.config = override(self.config, {"photos.crop_share": crop_share})
        torch.manual_seed(seed)
        self.fmt = torch.channels_last
        self.net = Generator(self.config.generator).to(device, memory_format=self.fmt)
        self.adam = torch.optim.Adam([p for p in self.net.parameters() if p.requires_grad], lr=self.config.optim.lr)
        self.bf16 = bf16_support(device)[0] if self.config.optim.bf16 else False
        self.rng = torch.Generator().manual_seed(seed)

    def batch(self):
        """``(photos, maps, info)`` of one batch on the device (:func:`~svbrdf.trainer.prior.photos.sample_batch`)."""
        from svbrdf.trainer.prior import sample_batch

        photos, maps, info = sample_batch(self.config, self.rng, device=self.device)
        return photos.to(self.device, memory_format=self.fmt), maps.to(self.device), info

    def step(self) -> float:
        """One full training step; returns the seconds its batch building took (host time, not synchronised)."""
        from svbrdf.trainer.prior import prior_loss

        t0 = time.perf_counter()
        photos, maps, _ = self.batch()
        t_data = time.perf_counter() - t0
        with torch.autocast(self.device.type, dtype=torch.bfloat16, enabled=self.bf16):
            pred = self.net(photos)
        terms = prior_loss(pred.float(), maps, self.config, self.rng)
        self.adam.zero_grad(set_to_none=True)
        terms["total"].backward()
        self.adam.step()
        return t_data

    def time(self, warmup: int, steps: int, seconds: float) -> Dict[str, Any]:
        """Samples per second over at least ``steps`` steps and ``seconds`` seconds, after ``warmup`` steps."""
        for _ in range(warmup):
            self.step()
        _sync(self.device)
        t0, n, data = time.perf_counter(), 0, 0.0
        while n < steps or time.perf_counter() - t0 < seconds:
            data += self.step()
            n += 1
        _sync(self.device)
        dt = time.perf_counter() - t0
        return {"samples_per_s": n * self.config.optim.batch / dt, "s_per_step": dt / n, "data_s_per_step": data / n,
                "steps": n}


def time_paths(benches: Dict[str, Bench], warmup: int, steps: int, seconds: float, rounds: int
               ) -> Dict[str, Dict[str, Any]]:
    """Each path's samples per second, timed in ``rounds`` alternating blocks (host, device; then device, host; ...)
    of at least ``steps`` steps and ``seconds`` / ``rounds`` seconds each, after ``warmup`` steps of each: a machine
    whose load changes (a shared CPU, a GPU's clocks) slows both paths alike. Steps within a block are not
    synchronised (the host runs ahead of a GPU as in training); each block ends with a synchronisation."""
    for bench in benches.values():
        for _ in range(warmup):
            bench.step()
        _sync(bench.device)
    sums = {k: {"seconds": 0.0, "steps": 0, "data": 0.0} for k in benches}
    order = list(benches)
    for r in range(rounds):
        for key in (order if r % 2 == 0 else order[::-1]):
            bench = benches[key]
            t0, n, data = time.perf_counter(), 0, 0.0
            while n < steps or time.perf_counter() - t0 < seconds / rounds:
                data += bench.step()
                n += 1
            _sync(bench.device)
            sums[key]["seconds"] += time.perf_counter() - t0
            sums[key]["steps"] += n
            sums[key]["data"] += data
    out = {}
    for key, t in sums.items():
        batch = benches[key].config.optim.batch
        out[key] = {"samples_per_s": t["steps"] * batch / t["seconds"], "s_per_step": t["seconds"] / t["steps"],
                    "data_s_per_step": t["data"] / t["steps"], "steps": t["steps"]}
    return out


def ops_per_batch(bench: Bench) -> int:
    """The torch operations one batch of ``bench`` dispatches (each a kernel launch on a GPU: the launch-bound
    part of a small-kernel stream), counted on the device it runs on."""
    from torch.utils._python_dispatch import TorchDispatchMode

    class Count(TorchDispatchMode):
        n = 0

        def __torch_dispatch__(self, func, types, args=(), kwargs=None):
            Count.n += 1
            return func(*args, **(kwargs or {}))

    with Count():
        bench.batch()
    return Count.n


def syncs_per_batch(bench: Bench) -> Optional[int]:
    """The host synchronisations one batch of ``bench`` makes on CUDA (torch's sync debug mode; None elsewhere)."""
    if bench.device.type != "cuda":
        return None
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        torch.cuda.set_sync_debug_mode("warn")
        try:
            bench.batch()
        finally:
            torch.cuda.set_sync_debug_mode("default")
    return sum("synchroniz" in str(w.message) for w in caught)


def describe(photos: torch.Tensor, maps: torch.Tensor) -> Dict[str, Any]:
    """Shapes and value ranges of one batch (what the test compares across paths)."""
    return {"photos_shape": list(photos.shape), "maps_shape": list(maps.shape),
            "photos_range": [float(photos.min()), float(photos.max())],
            "maps_range": [float(maps.min()), float(maps.max())]}


def choose_batch(device: torch.device, size: int, photo_size: int, cap: float, start: int = 32,
                 most: int = 1024, seconds: float = 60.0, say=print) -> Dict[str, Any]:
    """The device path's best batch on a CUDA card: ``start``, twice it, ... up to ``most``, while the peak memory
    stays under ``cap`` of the card's, nothing runs out of memory and the search has taken under ``seconds``.
    Returns ``{"batch", "tried": [{batch, samples_per_s, peak_gib} or {batch, error}]}``."""
    total = torch.cuda.get_device_properties(device).total_memory
    tried: List[Dict[str, Any]] = []
    batch, best, t0 = start, None, time.perf_counter()
    while batch <= most and time.perf_counter() - t0 < seconds:
        torch.cuda.empty_cache()
        torch.cuda.reset_peak_memory_stats(device)
        try:
            bench = Bench("device", device, batch, size, photo_size)
            got = bench.time(1, 2, 0.0)
            peak = torch.cuda.max_memory_allocated(device)
            tried.append({"batch": batch, "samples_per_s": got["samples_per_s"], "peak_gib": peak / 2 ** 30})
            say(f"throughput: batch {batch}: {got['samples_per_s']:.1f} samples/s, peak {peak / 2 ** 30:.1f} GiB")
            del bench
            if best is None or got["samples_per_s"] > best[1]:
                best = (batch, got["samples_per_s"])
            if peak > cap * total / 2:  # the next doubling would pass the cap
                break
        except torch.cuda.OutOfMemoryError:
            tried.append({"batch": batch, "error": "out of memory"})
            say(f"throughput: batch {batch}: out of memory")
            break
        batch *= 2
    torch.cuda.empty_cache()
    return {"batch": best[0] if best else start, "tried": tried}


def run(device: str, small: bool = False, batch: Optional[int] = None, size: Optional[int] = None,
        photo_size: Optional[int] = None, warmup: Optional[int] = None, steps: Optional[int] = None,
        seconds: float = 0.0, memory_cap: float = 0.8, out: Optional[Path] = None, rounds: Optional[int] = None,
        host_batch: Optional[int] = None, crop_share: Optional[float] = None, say=print) -> Dict[str, Any]:
    """Time both paths (see the module docstring); returns the JSON record (also written to ``out``)."""
    from svbrdf.trainer.device import pick_device

    dev = pick_device(device)
    size = size or (64 if small else 256)
    photo_size = photo_size or 2 * size
    warmup = 1 if warmup is None and small else (3 if warmup is None else warmup)
    steps = steps or (2 if small else 10)
    rounds = rounds or (1 if small else 2)
    search = None
    if batch is None:
        if dev.type == "cuda" and not small:
            search = choose_batch(dev, size, photo_size, memory_cap, say=say)
            batch = search["batch"]
        else:
            batch = 4 if small else 32
    record: Dict[str, Any] = {"device": device_name(dev), "device_type": dev.type, "torch": torch.__version__,
                              "threads": torch.get_num_threads() if dev.type == "cpu" else None,
                              "batch": batch, "size": size, "photo_size": photo_size, "channels_last": True,
                              "warmup": warmup, "min_steps": steps, "min_seconds": seconds, "paths": {}}
    if search is not None:
        record["batch_search"] = search
    if host_batch is None:  # on a card the old stream as v2 ran it (its batch), else both at one batch
        host_batch = 32 if dev.type == "cuda" and not small else batch
    record["host_batch"] = host_batch
    benches = {path: Bench(path, dev, host_batch if path == "host" else batch, size, photo_size,
                           crop_share=crop_share) for path in PATHS}
    record["crop_share"] = benches["host"].config.photos.crop_share
    record["bf16"] = bool(benches["device"].bf16)
    record["rounds"] = rounds
    shapes = {path: {**describe(*bench.batch()[:2]), "ops_per_batch": ops_per_batch(bench),
                     "syncs_per_batch": syncs_per_batch(bench)} for path, bench in benches.items()}
    for path, got in time_paths(benches, warmup, steps, seconds, rounds).items():
        got = record["paths"][path] = {**got, **shapes[path]}
        say(f"throughput: {path:6s} stream: {got['samples_per_s']:8.2f} samples/s ({got['s_per_step']:.3f} s a step of "
            f"{benches[path].config.optim.batch}, {got['data_s_per_step']:.3f} s of it building the batch on the host) on "
            f"{record['device']}")
    del benches
    if dev.type == "cuda":
        torch.cuda.empty_cache()
    record["ratio"] = record["paths"]["device"]["samples_per_s"] / record["paths"]["host"]["samples_per_s"]
    say(f"throughput: ratio device / host = {record['ratio']:.2f} (batch {batch} / {host_batch}, {size} px crops of "
        f"{photo_size} px)")
    if out is not None:
        out = Path(out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(record, indent=1) + "\n")
    return record


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--device", default=None, help="cuda, cpu, ... (default: CUDA when available)")
    ap.add_argument("--small", action="store_true", help="a few-second check (batch 4, 64 px)")
    ap.add_argument("--batch", type=int, default=None, help="materials per step (default: chosen on CUDA, 32 else)")
    ap.add_argument("--size", type=int, default=None, help="training crop side, px (default 256; --small 64)")
    ap.add_argument("--photo-size", type=int, default=None, help="photo side, px (default twice --size)")
    ap.add_argument("--warmup", type=int, default=None, help="untimed steps per path (default 3; --small 1)")
    ap.add_argument("--steps", type=int, default=None, help="timed steps per path, at least (default 10; --small 2)")
    ap.add_argument("--seconds", type=float, default=0.0, help="timed seconds per path, at least (default 0)")
    ap.add_argument("--host-batch", type=int, default=None, help="the host stream's batch (default: 32, v2's, on "
                    "CUDA; else --batch)")
    ap.add_argument("--crop-share", type=float, default=None, help="share of batches that are crops of photo-size "
                    "photos (default v2's 0.5; 1 or 0 give both paths the same work over few steps)")
    ap.add_argument("--rounds", type=int, default=None, help="alternating timed blocks per path (default 2; "
                    "--small 1)")
    ap.add_argument("--memory-cap", type=float, default=0.8, help="share of the card's memory the batch may use")
    ap.add_argument("--threads", type=int, default=None, help="CPU threads (default: torch's)")
    ap.add_argument("--out", type=Path, default=None, help="write the JSON record here")
    a = ap.parse_args(argv)
    if a.threads:
        torch.set_num_threads(a.threads)
    run(a.device, a.small, a.batch, a.size, a.photo_size, a.warmup, a.steps, a.seconds, a.memory_cap, a.out, a.rounds,
        a.host_batch, a.crop_share)
    return 0


if __name__ == "__main__":
    sys.exit(main())
