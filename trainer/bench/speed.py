"""Seconds per training iteration of one preset under execution variants, measured side by side.

Run as ``python -m svbrdf.trainer.bench.speed [--preset fast] [--size 256] [--iters 20] [--repeats 3]
[--variants base,channels_last,compile,fp32] [--threads 1] [--out DIR] [--force]``. Each variant builds a
:class:`~svbrdf.trainer.train.Trainer` on the same random photo (fine-tune stage, no checkpoints, no evaluation
tiles), runs warm-up iterations (``torch.compile`` compiles there; its compile time is reported separately) and
then ``--iters`` timed iterations; the variants take turns ``--repeats`` times so that machine load affects them
alike, and the median is reported with its ratio to ``base``.

Variants: ``base`` (the preset as shipped), ``fp32`` (bf16 autocast off), ``channels_last`` (networks and photo
in channels-last memory format), ``compile`` (``torch.compile`` of the encoder, both decoders and the
discriminator, default inductor backend), ``alternating`` / ``joint`` (the preset with that
``schedule``, see :class:`~svbrdf.trainer.config.TrainConfig`), ``preset:NAME`` (another preset, e.g.
``preset:fast-v1`` to time a change of the losses against the version before it), ``set:KEY=VALUE[+KEY=VALUE]``
(the preset with those training settings, :func:`~svbrdf.trainer.config.parse_settings`, e.g.
``set:lambda_anchor=0``). Where the preset pulls the fine-tune to its starting maps (``lambda_anchor``), the bare
trainer takes its own first prediction as the anchor, as a fine-tune from a checkpoint does, so the pull is timed.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

import torch

from svbrdf.runtime.errors import SvbrdfError

from .common import repo_root, results_paths, write_results

VARIANTS = ("base", "fp32", "channels_last", "compile", "alternating", "joint")


def _settings(variant: str) -> Dict[str, Any]:
    """The training settings of a ``set:`` variant (empty for the others)."""
    from svbrdf.trainer.config import parse_settings

    return parse_settings(variant.partition(":")[2].split("+")) if variant.startswith("set:") else {}


def _known(variant: str, preset: str = "fast") -> bool:
    if variant.startswith("set:"):
        from svbrdf.trainer.config import resolve

        try:
            resolve(preset, **_settings(variant))
        except (TypeError, ValueError):
            return False
        return True
    if variant.startswith("preset:"):
        from svbrdf.trainer.config import TRAIN_PRESETS

        return variant.partition(":")[2] in TRAIN_PRESETS
    return variant in VARIANTS


def _trainer(preset: str, size: int, variant: str, threads: Optional[int]):
    from svbrdf.trainer.config import resolve
    from svbrdf.trainer.train import Trainer  # a bare finetune-stage trainer (random weights): cost per iteration only

    if variant.startswith("preset:"):
        preset = variant.partition(":")[2]

    cfg = resolve(preset, checkpoint_every=0, maps_every=0, eval_every=0, bf16=False if variant == "fp32" else None,
                  schedule=variant if variant in ("alternating", "joint") else None, **_settings(variant))
    photo = torch.rand(1, 3, size, size, generator=torch.Generator().manual_seed(0)) * 0.8
    photo[..., size // 2 - 4:size // 2 + 4, size // 2 - 4:size // 2 + 4] = 1.0  # a clipped highlight
    trainer = Trainer(photo, cfg, stage="finetune", iters=10 ** 9, threads=threads)
    if cfg.lambda_anchor > 0:  # as svbrdf.trainer.checkpoint.load_init does for a fine-tune
        with torch.no_grad():
            trainer.anchor = trainer.predict().float()
    if variant == "channels_last":
        for m in (trainer.generator, trainer.discriminator):
            m.to(memory_format=torch.channels_last)
        trainer.photo = trainer.photo.contiguous(memory_format=torch.channels_last)
    elif variant == "compile":
        g = trainer.generator
        g.encoder, g.decoder_nr, g.decoder_ds = (torch.compile(m) for m in (g.encoder, g.decoder_nr, g.decoder_ds))
        trainer.discriminator = torch.compile(trainer.discriminator)
    return trainer


def measure(preset: str, size: int, iters: int, repeats: int, variants: Sequence[str], threads: Optional[int],
            warmup: int = 3, say=lambda _m: None) -> Dict[str, Any]:
    """Median seconds per iteration of every variant (and the warm-up time, where compilation happens)."""
    trainers, setup = {}, {}
    for v in variants:
        t0 = time.perf_counter()
        trainers[v] = _trainer(preset, size, v, threads)
        for _ in range(warmup):
            trainers[v].iteration()
        setup[v] = time.perf_counter() - t0
        say(f"{v}: set-up and {warmup} warm-up iterations {setup[v]:.1f} s")
    times: Dict[str, List[float]] = {v: [] for v in variants}
    for r in range(repeats):
        for v in variants:
            t0 = time.perf_counter()
            for _ in range(iters):
                trainers[v].iteration()
            times[v].append((time.perf_counter() - t0) / iters)
            say(f"repeat {r + 1}: {v} {times[v][-1]:.3f} s/it")
    base = statistics.median(times[variants[0]])
    rows = [{"variant": v, "seconds_per_iteration": statistics.median(times[v]),
             "ratio_to_first": statistics.median(times[v]) / base, "warmup_seconds": setup[v],
             "all": times[v]} for v in variants]
    return {"preset": preset, "size": size, "iters": iters, "repeats": repeats, "threads": torch.get_num_threads(),
            "rows": rows}


def markdown(doc: Dict[str, Any]) -> str:
    out = [f"# Training speed variants: preset `{doc['preset']}`, {doc['size']} px photo", "", "```", doc["command"],
           "```", "", f"- date: {doc['date']}; torch threads: {doc['threads']}; {doc['iters']} iterations x "
           f"{doc['repeats']} interleaved repeats, median", "",
           f"| variant | s / iteration | ratio to {doc['rows'][0]['variant']} | set-up + warm-up s |",
           "|---|---|---|---|"]
    out += [f"| {r['variant']} | {r['seconds_per_iteration']:.3f} | {r['ratio_to_first']:.2f} | "
            f"{r['warmup_seconds']:.1f} |" for r in doc["rows"]]
    return "\n".join(out) + "\n"


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.bench.speed", description=__doc__.split("\n\n")[0])
    p.add_argument("--preset", default="fast")
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--iters", type=int, default=20)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--variants", default=",".join(VARIANTS))
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--out", type=Path, default=None, help="default docs/benchmarks/speed-PRESET")
    p.add_argument("--force", action="store_true")
    args = p.parse_args(argv)
    try:
        variants = [v.strip() for v in args.variants.split(",") if v.strip()]
        if not variants or not all(_known(v, args.preset) for v in variants):
            raise SvbrdfError(f"--variants: expected some of {', '.join(VARIANTS)}, preset:NAME or set:KEY=VALUE, "
                              f"got {args.variants!r}")
        if args.iters < 1 or args.repeats < 1 or args.size < 32:
            raise SvbrdfError("--iters and --repeats must be >= 1 and --size >= 32")
        out = args.out or repo_root() / "docs" / "benchmarks" / f"speed-{args.preset}"
        paths = results_paths(out, args.force)
        doc = measure(args.preset, args.size, args.iters, args.repeats, variants, args.threads,
                      say=lambda m: print(m, file=sys.stderr, flush=True))
    except (SvbrdfError, ValueError) as e:
        print(f"speed: error: {str(e).splitlines()[0]}", file=sys.stderr)
        return 2
    write_results(paths, "svbrdf.trainer.bench.speed", argv, doc, markdown)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
