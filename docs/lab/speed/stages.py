"""Where the time of one ``svbrdf-preview`` goes, stage by stage, at several photo sizes (issue 54).

::

    OMP_WAIT_POLICY=PASSIVE python docs/lab/speed/stages.py PHOTO [PHOTO ...] --threads 2 --repeats 3 \
        [--max-size 8192] [--label after] [--json out.json]

Each photo runs :func:`svbrdf.runtime.workflow.photo.process_photo` then ``write_maps`` in this process (as the
CLI does; the session is loaded once and warmed on the photo first), ``--repeats`` times, with every stage timed by
wrapping the function that does it (wall seconds and this process's CPU seconds; the medians over the repeats).
Stages that run inside others are indented in the table; the files are written by two threads, so their
times add up to more than ``write``. ``decoder nr`` / ``decoder ds``: one extra pass of each part graph on the
network's input, after the timed runs (what each decoder alone costs). The load average is printed with the table:
the machine is shared, compare only numbers of one run.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

TIMES: dict = defaultdict(list)  # stage -> [(wall, cpu)] of the current run


def _wrap(owner, attr: str, stage: str) -> None:
    fn = getattr(owner, attr)
    if getattr(fn, "_stage", None):
        return

    @functools.wraps(fn)
    def timed(*args, **kwargs):
        t, c = time.perf_counter(), time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            TIMES[stage].append((time.perf_counter() - t, time.process_time() - c))

    timed._stage = stage
    setattr(owner, attr, timed)


def instrument() -> list:
    """Wrap the runtime's stage functions; returns the stage names in table order (indent = nesting)."""
    from svbrdf.runtime.core import maps as maps_mod
    from svbrdf.runtime.inference import pipeline, session
    from svbrdf.runtime.outputs import texture_set
    from svbrdf.runtime.post import flash_trend, photo_colour, highlight_fill
    from svbrdf.runtime.quality import burn_in
    from svbrdf.runtime.workflow import photo, write

    order = []

    def add(owner, attr, stage):
        _wrap(owner, attr, stage)
        order.append(stage)

    add(pipeline, "estimate", "estimate")
    _wrap(photo, "estimate", "estimate")  # process_photo's own name of it
    add(pipeline, "read_photo", "  read (+ resize)")
    add(pipeline, "even_lighting", "  even lighting")
    add(session.PreviewSession, "run", "  network")
    add(pipeline, "apply_post", "  post")
    add(photo_colour, "photo_colour", "    photo colour")
    add(flash_trend, "photo_burn_in", "    burn-in scores (x2)")
    add(flash_trend, "fill_highlight", "    highlight fill")
    add(highlight_fill, "highlight_mask", "      fill: region")
    add(highlight_fill, "_best_offset", "      fill: one-copy search")
    add(highlight_fill, "_patch_offsets", "      fill: patch search")
    add(highlight_fill, "_paste", "      fill: paste + Poisson")
    add(flash_trend, "remove_flash_trend", "    flash-trend removal")
    add(flash_trend, "uniform_specular", "    uniform specular")
    add(maps_mod.Maps, "clipped", "  Maps.clipped (all calls)")
    add(texture_set, "relit_panel", "relit panel")
    add(texture_set, "_downsized", "  relit: downsize maps")
    add(texture_set, "render", "  relit: renders")
    add(write, "write_maps", "write files")
    add(texture_set, "generic_layout", "  layout (clip, encode)")
    add(texture_set, "commit", "  commit (threads)")
    for name in ("basecolor", "normal", "roughness", "specular", "relit"):
        order.append(f"    {name}.png")
    order.append("    sidecar .json")
    _wrap_writes(texture_set)
    return order


def _wrap_writes(texture_set) -> None:
    from svbrdf.runtime.io import images

    fn = images.write_image

    def timed(path, *args, **kwargs):
        t, c = time.perf_counter(), time.process_time()
        try:
            return fn(path, *args, **kwargs)
        finally:
            role = Path(path).name.rsplit("_", 1)[-1]
            TIMES[f"    {role}"].append((time.perf_counter() - t, time.process_time() - c))

    texture_set.write_image = timed


def run(photos, threads: int, repeats: int, max_size: int) -> dict:
    from svbrdf.runtime.workflow.options import PhotoOptions
    from svbrdf.runtime.workflow.photo import process_photo
    from svbrdf.runtime.workflow.write import write_maps
    from svbrdf.runtime.inference.session import load_session

    order = instrument()
    session = load_session(threads=threads)
    options = PhotoOptions(threads=threads, force=True, max_size=max_size)
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for photo in photos:
            photo = Path(photo)
            maps, relit, _ = process_photo(photo, options, session)  # warm-up
            size = maps.shape
            runs = defaultdict(list)
            for _ in range(repeats):
                TIMES.clear()
                t = time.perf_counter()
                maps, relit, _ = process_photo(photo, options, session)
                write_maps(maps, relit, Path(tmp), photo.stem, options, {})
                total = time.perf_counter() - t
                for stage, vals in TIMES.items():
                    runs[stage].append((sum(v[0] for v in vals), sum(v[1] for v in vals)))
                runs["total (as the CLI reports it)"].append((total, 0.0))
            table = {s: {"wall": statistics.median(v[0] for v in runs[s]), "min": min(v[0] for v in runs[s]),
                         "cpu": statistics.median(v[1] for v in runs[s])}
                     for s in ["total (as the CLI reports it)"] + order + sorted(set(runs) - set(order)) if s in runs}
            # Each decoder alone (its part graph) on the network's input.
            decoders = {}
            from svbrdf.runtime.post.flash_trend import even_lighting
            from svbrdf.runtime.io.images import read_image
            image = read_image(photo, max_size=max_size)
            width = session.input_lighting(options.post.even_lighting)
            x = even_lighting(image, width) if width else image
            if max(x.shape[:2]) <= options.tile:
                for part, names in (("nr", ["normal", "roughness"]), ("ds", ["diffuse", "specular"])):
                    t = time.perf_counter()
                    session.run(x, names)
                    decoders[f"  decoder {part} alone"] = {"wall": time.perf_counter() - t, "cpu": None}
            table.update(decoders)
            out[f"{photo.name} ({size[1]}x{size[0]})"] = table
    return out


def markdown(result: dict, load: str) -> str:
    cols = list(result)
    stages = []
    for table in result.values():
        stages += [s for s in table if s not in stages]
    lines = [f"load average at the end: {load}", "",
             "| stage | " + " | ".join(cols) + " |", "|---|" + "---|" * len(cols)]
    for s in stages:
        cells = []
        for c in cols:
            v = result[c].get(s)
            cells.append("" if v is None else f"{v['wall']:.3f}" + ("" if v.get("min") is None else f" ({v['min']:.3f})"))
        lines.append(f"| {s.replace('  ', '&nbsp;&nbsp;')} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append("Seconds of wall time: median over the repeats (the fastest in brackets: the least disturbed by the "
                 "other jobs on the machine; the process's CPU time is in the JSON, but on this shared VM it grows with "
                 "the load as the wall time does).")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("photos", nargs="+")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--max-size", type=int, default=2048)
    p.add_argument("--json", type=Path)
    args = p.parse_args(argv)
    result = run(args.photos, args.threads, args.repeats, args.max_size)
    load = open("/proc/loadavg").read().split()[:3] if os.path.exists("/proc/loadavg") else ["?"]
    print(markdown(result, " ".join(load)))
    if args.json:
        args.json.write_text(json.dumps({"load": load, "result": result}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
