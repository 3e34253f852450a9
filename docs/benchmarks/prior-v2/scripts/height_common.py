"""What the height probes share: the normals' mean tilt and the train-and-evaluate loop."""
import time

import torch


def tilt(normals: torch.Tensor) -> float:
    """Mean angle from the vertical, degrees, of (B, 3, H, W) unit normals."""
    return float(torch.rad2deg(torch.acos(normals[:, 2].clamp(-1, 1))).mean())


def train_and_evaluate(trainer, n: int, evaluate, every: int = 50) -> None:
    """``evaluate(0)``, then ``n`` iterations of ``trainer`` with ``evaluate(i)`` every ``every``."""
    evaluate(0)
    t0 = time.time()
    for i in range(1, n + 1):
        trainer.iteration()
        if i % every == 0:
            print(f"{i} steps, {time.time() - t0:.0f} s", flush=True)
            evaluate(i)
