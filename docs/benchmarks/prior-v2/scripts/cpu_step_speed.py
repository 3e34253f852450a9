"""Seconds per v2 training step on the CPU (issue 26's CPU chunks), eager or with ``--compile``.

    OMP_NUM_THREADS=1 python docs/benchmarks/prior-v2/scripts/cpu_step_speed.py eager|compile N [CKPT]

Resumes CKPT (default the committed ``resume.pt``) into a :class:`svbrdf.trainer.prior.PriorTrainer` on one CPU
thread, takes 5 steps (one draw of materials: warm-up and, with ``compile``, the compiling), then N more and prints
their mean wall time and data time per step (a draw every ``material_reuse`` steps included). Nothing is saved.
"""
import sys
import time

import torch

from svbrdf.trainer.checkpoint import load_checkpoint
from svbrdf.trainer.prior import PriorConfig, PriorTrainer

mode, n = sys.argv[1], int(sys.argv[2])
ckpt = load_checkpoint(sys.argv[3] if len(sys.argv) > 3 else "docs/benchmarks/prior-v2/resume.pt")
torch.set_num_threads(1)
kw = {"compile": True} if mode == "compile" else {}
trainer = PriorTrainer(PriorConfig.from_dict(ckpt["prior_config"]), device="cpu", threads=1, **kw)
trainer.load_resume(ckpt)
t = time.perf_counter()
for _ in range(5):
    trainer._step()
print(f"{mode}: warm-up (5 steps) {time.perf_counter() - t:.1f} s"
      + (f", note: {trainer.compile_note}" if getattr(trainer, "compile_note", None) else ""), flush=True)
steps = [trainer._step()[1] for _ in range(n)]
print(f"{mode}: {sum(f['seconds'] for f in steps) / n:.2f} s/step over {n} "
      f"(data {sum(f['data_seconds'] for f in steps) / n:.2f} s)", flush=True)
