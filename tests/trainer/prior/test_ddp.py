"""The prior trainer data-parallel (issue 64, item 5): two processes with gloo on the CPU take the same update as one
process with the combined batch."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from svbrdf.trainer.models import GeneratorConfig
from svbrdf.trainer.prior import PriorTrainer, prior_preset
from svbrdf.trainer.prior.config import override

STEPS = 2


def tiny():
    """The v2 loss and stream (batched, relighting, detail and slope terms) at test size: 2 materials per process."""
    return override(prior_preset("v2"), {
        "generator": GeneratorConfig(width=0.125, decoder_blocks=3, train_encoder=True, arch="unet"),
        "photos.size": 32, "photos.photo_size": 64, "optim.batch": 2, "optim.bf16": False, "losses.slope": 1.0,
        "optim.ema": 0.9, "monitor.checkpoint_every": 0, "monitor.eval_every": 0, "monitor.log_every": 1,
        "optim.iters": 10})


#: One process of the data-parallel run, started as torchrun starts it (RANK, WORLD_SIZE, MASTER_ADDR/PORT in the
#: environment): the trainer joins the gloo group itself.
WORKER = """
import sys, torch
sys.path.insert(0, {here!r})
from test_ddp import STEPS, tiny
from svbrdf.trainer.prior import PriorTrainer
torch.set_num_threads(1)
trainer = PriorTrainer(tiny(), device="cpu", threads=1)
rank = trainer.rank
assert (trainer.world, trainer.shares) == (2, [rank]), (trainer.world, trainer.shares)
losses = [float(trainer._step()[0]["total"])]
grads = {{n: p.grad.clone() for n, p in trainer.generator.named_parameters() if p.grad is not None}}
losses += [float(trainer._step()[0]["total"]) for _ in range(STEPS - 1)]
state = {{"grads": grads, "weights": trainer.generator.state_dict(), "ema": trainer.model.state_dict()}}
torch.save({{**state, "losses": losses}}, {out!r} + "." + str(rank))
torch.distributed.destroy_process_group()
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.integration
def test_two_gloo_processes_take_the_update_of_one_process_with_the_combined_batch(tmp_path):
    torch.set_num_threads(1)
    out = str(tmp_path / "rank")
    code = WORKER.format(here=str(Path(__file__).parent), out=out)
    port = str(_free_port())
    procs = []
    for rank in range(2):
        env = {**os.environ, "RANK": str(rank), "LOCAL_RANK": str(rank), "WORLD_SIZE": "2",
               "MASTER_ADDR": "127.0.0.1", "MASTER_PORT": port, "OMP_NUM_THREADS": "1"}
        procs.append(subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True))
    for p in procs:
        text = p.communicate(timeout=240)[0]
        assert p.returncode == 0, text[-3000:]
    ranks = [torch.load(f"{out}.{r}", weights_only=False) for r in range(2)]
    one = PriorTrainer(tiny(), device="cpu", threads=1, combine=2)
    start = {k: v.clone() for k, v in one.generator.state_dict().items()}
    losses = [float(one._step()[0]["total"])]
    grads = {n: p.grad.clone() for n, p in one.generator.named_parameters() if p.grad is not None}
    losses += [float(one._step()[0]["total"]) for _ in range(STEPS - 1)]
    # the combined loss is the mean of the two processes' losses
    for s in range(STEPS):
        assert abs(losses[s] - (ranks[0]["losses"][s] + ranks[1]["losses"][s]) / 2) < 1e-5 * abs(losses[s])
    # the first step's averaged gradient is the combined batch's (to float rounding of sums in another order:
    # 1e-5 of the gradient's largest component allowed; a sum instead of a mean, or another share, is off by 10-100 %)
    assert sorted(grads) == sorted(ranks[0]["grads"]) and len(grads) > 10
    largest = max(float(g.abs().max()) for g in grads.values())
    for key, value in grads.items():
        for r in ranks:
            torch.testing.assert_close(r["grads"][key], value, rtol=1e-4, atol=1e-5 * largest)
    # after STEPS Adam steps both processes hold the one process's weights. Adam moves each weight by about lr
    # (g / |g| on the first step), so where a gradient is about Adam's eps (1e-8) a rounding difference of the
    # gradient changes that weight's move by up to 2 lr per step: nearly every weight within 5 % of one step, a
    # few (at most 1 in 1000) up to the 2 lr per step Adam can differ by.
    lr = tiny().optim.lr
    moved, off, total = 0.0, 0, 0
    for which in ("weights", "ema"):
        final = (one.generator if which == "weights" else one.model).state_dict()
        for key, value in final.items():
            if not value.is_floating_point():
                continue
            for r in ranks[:1] if which == "ema" else ranks:
                diff = (r[which][key].float() - value.float()).abs()
                assert float(diff.max()) <= 2 * lr * STEPS + 1e-7, (which, key, float(diff.max()))
                off += int((diff > 0.05 * lr).sum())
                total += diff.numel()
            if which == "weights":
                moved = max(moved, float((value.float() - start[key].float()).abs().max()))
    assert off <= total / 1000, (off, total)
    assert moved > 0.5 * lr  # the weights did move (the comparison is not of two untouched starts)
    assert ranks[0]["losses"] != ranks[1]["losses"]  # each process trained on its own share


def test_combine_is_for_one_process_and_one_share_is_the_stream_as_it_was():
    torch.set_num_threads(1)
    with pytest.raises(ValueError, match="combine"):
        PriorTrainer(tiny(), device="cpu", threads=1, combine=0)
    a = PriorTrainer(tiny(), device="cpu", threads=1)
    assert (a.rank, a.world, a.shares) == (0, 1, [0])
    b = PriorTrainer(tiny(), device="cpu", threads=1, combine=1)
    assert torch.equal(a._draw()[0], b._draw()[0])
    assert "WORLD_SIZE" not in os.environ or int(os.environ["WORLD_SIZE"]) == 1
