"""Shared by the probes of this folder: the roughness's radial profile beyond chance (radial_probe.py,
contour_probe.py: the step that was tried in svbrdf.runtime.flash_trend, ``flash_trend_profile.diff``, and not
adopted), the cases every probe reads and the means table every probe prints and writes."""
import json
from pathlib import Path

import numpy as np

from svbrdf.runtime.tiling import block_mean


def profile_beyond_chance(field, centre, bin_px=1.0, chance=4.0):
    """(H, W, C) the radial part of ``field`` (H, W, C): annulus means minus the mean, each shrunk by
    ``max(0, 1 - chance t / dev^2)``, ``t = s^2 l max(1, min(l, bin_px)) / n`` the variance an annulus's mean has by
    chance (s^2 the variance left after the profile, l the correlation length from 8 x 8 block means)."""
    h, w, c = field.shape
    r = np.hypot(np.arange(h)[:, None] + 0.5 - centre[0], np.arange(w)[None, :] + 0.5 - centre[1])
    k = (r / bin_px).astype(np.int64).ravel()
    n = np.bincount(k).astype(np.float64)
    out = np.zeros_like(field, dtype=np.float64)
    for j in range(c):
        g = field[..., j].astype(np.float64).ravel()
        g = g - g.mean()
        dev = np.bincount(k, g, minlength=len(n)) / np.maximum(n, 1.0)
        rest = (g - dev[k]).reshape(h, w, 1)
        s2 = float(np.mean(rest ** 2))
        if s2 > 0:
            area = float(np.clip(64.0 * np.var(block_mean(rest.astype(np.float32), 8), dtype=np.float64) / s2, 1, 64))
            t = s2 * np.sqrt(area) * max(1.0, min(np.sqrt(area), bin_px)) / np.maximum(n, 1.0)
            dev = dev * np.maximum(0.0, 1.0 - chance * t / np.maximum(dev ** 2, 1e-30))
        dev[n == 0] = 0.0
        out[..., j] = np.interp(r, (np.arange(len(n)) + 0.5) * bin_px, dev)
    return out


def write_means(rows, per, keys, out):
    """Print the mean of each of ``keys`` per variant (``rows``: variant -> list of metric dicts) as a Markdown
    table and write ``{"means", "cases": per}`` to ``out`` (a Path)."""
    table = {}
    for name, es in rows.items():
        t = {k: float(np.mean([e[k] for e in es if k in e])) for k in keys if any(k in e for e in es)}
        t["n"] = len(es)
        table[name if isinstance(name, str) else " ".join(name)] = t
    print("| variant | " + " | ".join(keys) + " |")
    for name, t in table.items():
        print(f"| {name} | " + " | ".join(f"{t[k]:.4f}" if k in t else "-" for k in keys) + " |")
    out.write_text(json.dumps({"means": table, "cases": per}, indent=1, default=float))


def probe_cases(src):
    """The cases of ``src``: ``procedural:N`` (N held-out procedural materials, seed 987654, realistic flash
    photos of svbrdf.trainer.prior.simulate_photos, 256 px) or ``shared:GLOB`` (the benchmark's cases of
    ../shared/data at 256 px)."""
    from svbrdf.trainer.bench.cases import BenchCase, load_cases

    if not src.startswith("procedural:"):
        return load_cases(Path(__file__).resolve().parents[5] / ".." / "shared" / "data", 256, src.split(":", 1)[1])
    import torch

    from svbrdf.runtime.maps import Maps
    from svbrdf.trainer.prior import PriorConfig, simulate_photos
    from svbrdf.trainer.procedural import sample_materials

    n = int(src.split(":")[1])
    rng = torch.Generator().manual_seed(987654)
    mats, names = sample_materials(n, 256, rng)
    photos, gts, _ = simulate_photos(mats, PriorConfig(), rng)
    return [BenchCase(f"proc{i}_{names[i]}", "", "synthetic", "procedural", photos[i].permute(1, 2, 0).numpy().copy(),
                      Maps.unpack(gts[i].permute(1, 2, 0).numpy()), (128.0, 128.0), None) for i in range(n)]
