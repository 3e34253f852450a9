"""One time-limited chunk of a recipe's prior run, started or resumed (the device command's trainer, issue 64).

    python -m svbrdf.trainer.prior.chunk --recipe v4 --out runs/prior_v4 --minutes 6            # starts (or --force)
    python -m svbrdf.trainer.prior.chunk --resume runs/prior_v4/checkpoint.pt --out runs/prior_v4 --minutes 6

Any recipe of :data:`svbrdf.trainer.prior.recipes.RECIPES` (as ``svbrdf-train prior --recipe`` does; this adds ``--set``).
``--set NAME=VALUE`` (a prior setting by its dotted name, ``optim.batch`` or ``generator.width``, value parsed as
JSON, else text: :func:`~svbrdf.trainer.prior.config.override`) changes the recipe's start, for a dry run at test
size (``--set photos.size=32 --set photos.photo_size=64 --set optim.batch=1``) or a batch chosen for a card; the
changes are recorded in the checkpoint's ``prior_config`` like every setting. Writes ``OUT/checkpoint.pt``
(resumable: :meth:`~svbrdf.trainer.prior.trainer.PriorTrainer.load_resume`) and ``OUT/train_log.jsonl``; prints one
line per log record. Data parallel under ``torchrun`` as :class:`~svbrdf.trainer.prior.trainer.PriorTrainer` is
(rank 0 writes).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, Dict, List, Optional

CHECKPOINT = "checkpoint.pt"
LOG = "train_log.jsonl"


def main(argv: Optional[List[str]] = None) -> int:
    from svbrdf.trainer import checkpoint as ckpt_io
    from svbrdf.trainer.config import parse_settings
    from svbrdf.trainer.prior import PriorConfig, PriorTrainer
    from svbrdf.trainer.prior.config import override
    from svbrdf.trainer.prior.recipes import RECIPES

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--recipe", choices=tuple(RECIPES), help="start this recipe (a new run)")
    ap.add_argument("--resume", type=Path, help="continue this checkpoint (its settings and recipe)")
    ap.add_argument("--out", type=Path, required=True, help="folder of the checkpoint and the log")
    ap.add_argument("--minutes", type=float, default=None, help="stop and save after this many minutes")
    ap.add_argument("--iters", type=int, default=None, help="end of the schedule (a new run: the recipe's)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="a new run's setting by its dotted name (e.g. optim.batch=16)")
    ap.add_argument("--device", default=None)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--force", action="store_true", help="start over in a used --out")
    a = ap.parse_args(argv)
    if bool(a.recipe) == bool(a.resume):
        ap.error("give --recipe (a new run) or --resume (a checkpoint), one of them")
    ckpt_path, log_path = a.out / CHECKPOINT, a.out / LOG
    kw: Dict[str, Any] = {"device": a.device, "threads": a.threads, "checkpoint_path": ckpt_path,
                          "log_path": log_path}
    if a.resume:
        if a.set:
            ap.error("--set is for a new run (a resume takes the checkpoint's settings)")
        ckpt = ckpt_io.load_checkpoint(a.resume)
        config = PriorConfig.from_dict(ckpt["prior_config"])
        if a.iters is not None:
            config = override(config, {"optim.iters": a.iters})
        trainer = PriorTrainer(config, **kw)
        trainer.load_resume(ckpt, a.resume)
        print(f"chunk: resuming {a.resume} at iteration {trainer.step}/{trainer.iters}", flush=True)
    else:
        if a.out.exists() and any(a.out.iterdir()) and not a.force:
            ap.error(f"{a.out}: not empty (use --force to start over, or --resume)")
        for p in (ckpt_path, log_path):
            p.unlink(missing_ok=True)
        chosen = RECIPES[a.recipe]
        try:
            over = parse_settings(a.set)
            config = override(chosen.config_at(0), over)
            if a.iters is not None:
                config = override(config, {"optim.iters": a.iters})
        except (TypeError, ValueError) as e:
            ap.error(str(e))
        trainer = PriorTrainer(config, recipe=chosen, **kw)
        print(f"chunk: starting recipe {a.recipe} ({config.optim.iters} iterations of {config.optim.batch} materials "
              f"at {config.photos.size} px, stream {config.materials.stream})" + (f", settings {over}" if over else ""),
              flush=True)
    a.out.mkdir(parents=True, exist_ok=True)
    trainer.say = lambda line: print(f"chunk: {line}", flush=True)

    def show(tr, rec) -> bool:
        keys = ("step", "total", "render", "s_per_iter", "data_seconds")
        print("chunk: " + ", ".join(f"{k} {rec[k]:.4g}" if isinstance(rec.get(k), float) else f"{k} {rec.get(k)}"
                                    for k in keys if k in rec), flush=True)
        return False

    trainer.callback = show
    trainer.run(None if a.minutes is None else 60.0 * a.minutes)
    state = "timed out" if trainer.timed_out else "done"
    print(f"chunk: {state} at iteration {trainer.step}/{trainer.iters}, device {trainer.device}, "
          f"bf16 {trainer.bf16}, world {trainer.world}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
