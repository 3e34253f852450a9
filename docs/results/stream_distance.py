"""A label-free distance between the stage one's stream photos and real flash photos (issue 64, item 3; decision 061).

    OMP_NUM_THREADS=1 python docs/results/stream_distance.py [--n 256] [--size 256 --photo-size 512] [--split tune]

Simple statistics of each photo (linear, [0, 1]): brightness (median luminance), fall-off (log2 of the median
luminance of the border eighth over that of the centre half square: 0 = even, negative = darker edges), clipped
share (max channel >= 0.99) and saturation (mean (max - min) / max of the sRGB values, pixels above 0.02). Compared:
``n`` photos of v4's stream with v2's stream settings (arm A: fields of view 45-75 deg, no prints, no block means),
of v4's (arm B) and the real photos (no ground truth) of one part of the shared data at 256 px. Robust to the few
odd real photos: ``|d|`` is the difference of the medians over the real photos' spread (1.4826 x their median
absolute deviation), ``W1`` the 1-D Wasserstein distance over the same spread.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from svbrdf.trainer.bench.cases import prepare_case
from svbrdf.trainer.bench.datasets import find_cases
from svbrdf.trainer.bench.split import select_split
from svbrdf.trainer.prior.photos import sample_batch
from svbrdf.trainer.prior.config import override
from svbrdf.trainer.prior.recipes import RECIPES

STATS = ("brightness", "fall_off", "clipped", "saturation")
ARM_A = {"photos.fov_deg": (45.0, 75.0), "materials.print_share": 0.0, "photos.block_mean": 1,
         "photos.block_share": 1.0}


def stats(photo: np.ndarray) -> np.ndarray:
    """The statistics of one (H, W, 3) linear photo, in :data:`STATS` order."""
    y = photo @ np.array([0.2126, 0.7152, 0.0722])
    s = y.shape[0]
    b, q = max(1, s // 8), s // 4
    border = np.concatenate([y[:b].ravel(), y[-b:].ravel(), y[b:-b, :b].ravel(), y[b:-b, -b:].ravel()])
    srgb = np.where(photo <= 0.0031308, 12.92 * photo, 1.055 * np.clip(photo, 0.0031308, None) ** (1 / 2.4) - 0.055)
    hi, lo = srgb.max(-1), srgb.min(-1)
    lit = photo.max(-1) > 0.02
    sat = float(((hi - lo) / np.maximum(hi, 1e-6))[lit].mean()) if lit.any() else 0.0
    return np.array([np.median(y), np.log2(max(np.median(border), 1e-6) / max(np.median(y[q:-q, q:-q]), 1e-6)),
                     (photo.max(-1) >= 0.99).mean(), sat])


def stream_stats(overrides: dict, n: int, size: int, photo_size: int, seed: int) -> np.ndarray:
    config = override(RECIPES["v4"].config_at(0), {"photos.size": size, "photos.photo_size": photo_size,
                                                   "optim.seed": seed, **overrides})
    rng, rows = torch.Generator().manual_seed(seed), []
    while len(rows) < n:
        photos, _, _ = sample_batch(config, rng)
        rows += [stats(p.permute(1, 2, 0).float().numpy().astype(np.float64)) for p in photos]
    return np.array(rows[:n])


def real_stats(root: Path, split: str) -> np.ndarray:
    found = [c for c in find_cases(root) if c.kind == "photo"]
    keep = set(select_split([c.name for c in found], split))
    return np.array([stats(prepare_case(c, 256).photo.astype(np.float64)) for c in found if c.name in keep])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=256)
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--photo-size", type=int, default=512)
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--split", default="tune", choices=("tune", "check"))
    ap.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[3] / "shared" / "data")
    a = ap.parse_args()
    torch.set_num_threads(1)
    real = real_stats(a.data, a.split)
    arms = {"A (v2 stream)": stream_stats({**ARM_A, "optim.batch": a.batch}, a.n, a.size, a.photo_size, a.seed),
            "B (v4 stream)": stream_stats({"optim.batch": a.batch}, a.n, a.size, a.photo_size, a.seed)}
    med = np.median(real, 0)
    sd = 1.4826 * np.median(np.abs(real - med), 0)
    print(f"stream: {a.n} photos an arm at {a.size} px (crops of {a.photo_size} px); real: {len(real)} photos "
          f"({a.split} part, 256 px)\n")
    print("| statistic | real median (spread) | " + " | ".join(f"{k} median (spread) | \\|d\\| | W1" for k in arms)
          + " |")
    print("|---|---|" + "---|---|---|" * len(arms))
    for i, name in enumerate(STATS):
        cells = [f"{med[i]:.3g} ({sd[i]:.2g})"]
        for x in arms.values():
            qs = np.linspace(0, 1, 101)
            w1 = np.abs(np.quantile(x[:, i], qs) - np.quantile(real[:, i], qs)).mean() / sd[i]
            m = np.median(x[:, i])
            cells += [f"{m:.3g} ({1.4826 * np.median(np.abs(x[:, i] - m)):.2g})", f"{abs(m - med[i]) / sd[i]:.2f}",
                      f"{w1:.2f}"]
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
