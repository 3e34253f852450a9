"""Evidence for the ground-truth conventions: fit the Des18 input panels with the project renderer.

Each Des18 test file holds a rendered flash photo (the input panel) next to the maps it was rendered from. For
every file and each of five ways to read the maps (normal +y up / down x diffuse and specular panels linear /
sRGB-encoded, plus +y up with only the diffuse panel sRGB-encoded), this fits the scene the renderer cannot
know (camera and light positions, camera distance, exposure, strength of the distance fall-off) by Adam, in the
Deschaintre convention (diffuse x (1 - rho_s), 45 deg field of view to start from), and reports the sRGB RMSE
between the fitted rendering and the input panel.
The reading that the renderer reproduces best is the file's convention.

Scene parameters (scene units: the photo spans x in [-1, 1]; the maps stay texel-aligned with the photo):
camera at (cx, cy, d), light at (lx, ly, d) (a phone flash sits in the camera plane), exposure e, and fall-off
exponent g in [0, 6]: radiance = e * render(falloff off) * (d^2 / |light - p|^2)^g (g = 1: inverse square;
a flash cone cos^k on top of it is g = 1 + k/2, since cos = d / |light - p| for a light pointing down).
Start: camera and light above the brightest point of the (blurred) input panel, d = 1 / tan(22.5 deg),
e from the mean ratio, g = 1.

A second table gives an independent, fit-free check of the normal convention:
:func:`svbrdf.trainer.bench.datasets.normal_curl_ratio` of every ground-truth set (Des18, Des19, Xuejiao).

Usage::

    python -m svbrdf.trainer.tools.fit_des18 [--data ../shared/data] [--size 144] [--steps 300]

Prints Markdown tables (per-file RMSE, wins and mean per variant; curl ratios). About 2 s of CPU per fit at 144 px
(one thread; 100 fits).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Dict, List, Sequence, Tuple

import numpy as np
import torch
import torch.nn.functional as F

from svbrdf.trainer.bench.datasets import find_cases, normal_curl_ratio, read_des18, read_gt
from svbrdf.runtime.core.maps import MAP_NAMES, Maps
from svbrdf.runtime.core.render import DESCHAINTRE, plane_positions
from svbrdf.trainer.colour import linear_to_srgb
from svbrdf.trainer.render import render_maps

DEFAULT_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
DES18_DIR = Path("weiyi-auxrender") / "test_data" / "Des18" / "gt-material"
#: (normal_y, maps_encoding) of each variant, in table order.
VARIANTS: Tuple[Tuple[str, str], ...] = (
    ("up", "linear"), ("up", "srgb"), ("down", "linear"), ("down", "srgb"), ("up", "srgb-diffuse"))


def _variant_name(v: Tuple[str, str]) -> str:
    return f"y-{v[0]}/{v[1]}"


def _area_down(img: np.ndarray, size: int) -> torch.Tensor:
    """(H, W, C) numpy -> (1, C, size, size) float32 tensor, area-averaged (linear data)."""
    t = torch.as_tensor(np.ascontiguousarray(img), dtype=torch.float32).permute(2, 0, 1)[None]
    return F.interpolate(t, size=(size, size), mode="area")


def _packed(maps: Maps, size: int) -> torch.Tensor:
    """(1, 8, size, size) packed maps, area-averaged; normals renormalised after averaging."""
    parts = {n: _area_down(a, size) for n, a in maps.items()}
    parts["normal"] = parts["normal"] / parts["normal"].norm(dim=1, keepdim=True).clamp_min(1e-8)
    return torch.cat([parts[n] for n in MAP_NAMES], dim=1)


def _bright_spot(photo: torch.Tensor) -> Tuple[float, float]:
    """Scene (x, y) of the brightest point of the blurred photo (1, 3, S, S)."""
    lum = F.avg_pool2d(photo.mean(1, keepdim=True), 9, stride=1, padding=4, count_include_pad=False)[0, 0]
    s = lum.shape[-1]
    i, j = divmod(int(torch.argmax(lum)), s)
    return 2.0 * (j + 0.5) / s - 1.0, 1.0 - 2.0 * (i + 0.5) / s


def fit(maps: torch.Tensor, target: torch.Tensor, steps: int, start: Tuple[float, float]) -> Tuple[float, Dict]:
    """Fit camera/light/exposure/fall-off so that the sRGB rendering of ``maps`` matches ``target`` in sRGB.

    Args:
        maps: (1, 8, S, S) packed maps.
        target: (1, 3, S, S) linear input panel in [0, 1].
        steps: Adam iterations.
        start: initial (x, y) of camera and light.

    Returns:
        (sRGB RMSE, fitted parameters).
    """
    s = maps.shape[-1]
    pos = torch.as_tensor(plane_positions(s, s)).permute(2, 0, 1)[None]  # (1, 3, S, S)
    d0 = DESCHAINTRE.camera_distance
    cam = torch.tensor([start[0], start[1]], requires_grad=True)
    light = torch.tensor([start[0], start[1]], requires_grad=True)
    log_d = torch.tensor(math.log(d0), requires_grad=True)
    falloff = torch.tensor(1.0, requires_grad=True)
    log_e = torch.tensor(0.0, requires_grad=True)

    def radiance() -> torch.Tensor:
        d = log_d.exp()
        c = torch.stack([cam[0], cam[1], d]).view(1, 3, 1, 1)
        lp = torch.stack([light[0], light[1], d]).view(1, 3, 1, 1)
        v, l = c - pos, lp - pos
        v = v / v.norm(dim=1, keepdim=True)
        d2 = (l * l).sum(1, keepdim=True)
        l = l / d2.sqrt()
        img = render_maps(maps, v, l, DESCHAINTRE)
        return img * (d * d / d2) ** falloff.clamp(0.0, 6.0)

    target_srgb = linear_to_srgb(target, clip=True)
    with torch.no_grad():  # exposure start: match the means in linear space
        log_e.fill_(math.log(max(float(target.mean()), 1e-8) / max(float(radiance().mean()), 1e-8)))

    def loss_fn() -> torch.Tensor:
        pred = linear_to_srgb(radiance() * log_e.exp(), clip=True)
        return ((pred - target_srgb) ** 2).mean()

    opt = torch.optim.Adam([cam, light, log_d, falloff, log_e], lr=0.02)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, steps)
    for _ in range(steps):
        opt.zero_grad()
        loss = loss_fn()
        loss.backward()
        opt.step()
        sched.step()
    with torch.no_grad():
        rmse = math.sqrt(float(loss_fn()))
        d = float(log_d.exp())
        params = {"camera": cam.tolist(), "light": light.tolist(), "distance": d,
                  "fov_deg": math.degrees(2 * math.atan(1 / d)), "exposure": float(log_e.exp()),
                  "falloff": float(falloff.clamp(0, 6))}
    return rmse, params


def fit_file(path: Path, size: int, steps: int) -> Dict[Tuple[str, str], Tuple[float, Dict]]:
    """RMSE and fitted parameters of every variant for one Des18 file."""
    out = {}
    for normal_y, encoding in VARIANTS:
        maps, photo = read_des18(path, normal_y=normal_y, maps_encoding=encoding)
        target = _area_down(photo, size)  # area-averaged in linear, compared in sRGB
        out[(normal_y, encoding)] = fit(_packed(maps, size), target, steps, _bright_spot(target))
    return out


def curl_table(data: Path) -> List[str]:
    rows = ["| file | format | curl ratio, y up (as stored) | curl ratio, y flipped |", "|---|---|---|---|"]
    for case in find_cases(data):
        if case.kind != "gt":
            continue
        maps, _ = read_gt(case.path, case.format)
        up = normal_curl_ratio(maps.normal)
        flipped = maps.normal * np.array([1.0, -1.0, 1.0], np.float32)
        rows.append(f"| {case.path.name} | {case.format} | {up:.3f} | {normal_curl_ratio(flipped):.3f} |")
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA, help="the shared data folder")
    ap.add_argument("--size", type=int, default=144, help="fit resolution (288 / 2 = exact 2x2 averaging)")
    ap.add_argument("--steps", type=int, default=300, help="Adam steps per fit")
    ap.add_argument("--limit", type=int, default=0, help="only the first N files (0 = all)")
    args = ap.parse_args(argv)
    folder = args.data / DES18_DIR
    files = sorted(folder.glob("*.png"))
    if not files:
        print(f"error: no Des18 files in {folder}", file=sys.stderr)
        return 1
    if args.limit:
        files = files[: args.limit]
    torch.set_num_threads(1)

    t0 = time.time()
    names = [_variant_name(v) for v in VARIANTS]
    print("| file | " + " | ".join(names) + " | best | fitted fov / fall-off (best) |")
    print("|---|" + "---|" * (len(VARIANTS) + 2))
    table = []
    for path in files:
        res = fit_file(path, args.size, args.steps)
        rmse = [res[v][0] for v in VARIANTS]
        best = VARIANTS[int(np.argmin(rmse))]
        p = res[best][1]
        table.append(rmse)
        cells = " | ".join(f"{r:.4f}" for r in rmse)
        print(f"| {path.name.split(';')[0]} | {cells} | {_variant_name(best)} | "
              f"{p['fov_deg']:.1f} deg / {p['falloff']:.2f} |", flush=True)
    table = np.array(table)
    wins = np.bincount(np.argmin(table, axis=1), minlength=len(VARIANTS))
    print("\n| variant | wins | mean sRGB RMSE | median sRGB RMSE |\n|---|---|---|---|")
    for k, name in enumerate(names):
        print(f"| {name} | {wins[k]} | {table[:, k].mean():.4f} | {np.median(table[:, k]):.4f} |")
    print(f"\n({len(files)} files x {len(VARIANTS)} variants, {args.size} px, {args.steps} Adam steps, "
          f"{time.time() - t0:.0f} s)\n")
    print("\n".join(curl_table(args.data)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
