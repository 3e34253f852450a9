"""Contact sheet of the procedural pretraining materials (:mod:`svbrdf.trainer.procedural`).

::

    python -m svbrdf.trainer.tools.contact_sheet --out materials.png [--seed 0] \\
        [--per-family 4] [--size 128]

One row per family, ``--per-family`` samples side by side; each sample is five tiles: diffuse (sRGB-encoded),
specular, roughness, normal ((n + 1) / 2) and a co-located flash rendering (Zhao's renderer with light falloff,
clipped to [0, 1], sRGB-encoded). A white gap separates samples. Written as an 8-bit PNG; an existing file is
refused unless ``--force``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Optional, Sequence

import numpy as np
import torch

from svbrdf.runtime.core.colour import linear_to_srgb
from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.images import write_image
from svbrdf.runtime.core.maps import SLICES, encode_normal
from svbrdf.runtime.core.render import ZHAO
from svbrdf.trainer.procedural import FAMILIES, sample_materials
from svbrdf.trainer.render import FlashGeometry

#: Renderer of the flash tile.
RENDER_CONFIG = ZHAO.replace(falloff=True)
GAP = 4  # px of white between samples


def sample_tiles(maps: torch.Tensor, geometry: FlashGeometry) -> np.ndarray:
    """(B, 8, S, S) packed maps -> (B, S, 5 S, 3) sRGB-encoded tiles: diffuse, specular, roughness, normal, render."""
    grey = lambda t: np.repeat(t.permute(0, 2, 3, 1).numpy(), 3, axis=-1)  # noqa: E731
    hwc = lambda t: t.permute(0, 2, 3, 1).numpy()  # noqa: E731
    with torch.no_grad():
        render = geometry.render(maps).clamp(0.0, 1.0)
    parts = [linear_to_srgb(hwc(maps[:, SLICES["diffuse"]])),
             linear_to_srgb(grey(maps[:, SLICES["specular"]])),
             grey(maps[:, SLICES["roughness"]]),
             encode_normal(hwc(maps[:, SLICES["normal"]])),
             linear_to_srgb(hwc(render))]
    return np.concatenate([np.asarray(p, np.float32) for p in parts], axis=2)


def contact_sheet(seed: int = 0, per_family: int = 4, size: int = 128,
                  families: Sequence[str] = FAMILIES) -> np.ndarray:
    """(F (S + GAP), per_family (5 S + GAP), 3) sRGB-encoded sheet, one row per family."""
    g = torch.Generator().manual_seed(seed)
    geometry = FlashGeometry(size, size, RENDER_CONFIG)
    rows = []
    for fam in families:
        maps, _ = sample_materials(per_family, size, g, [fam])
        tiles = sample_tiles(maps, geometry)
        row = np.ones((size + GAP, per_family * (5 * size + GAP), 3), np.float32)
        for i, t in enumerate(tiles):
            x = i * (5 * size + GAP)
            row[:size, x:x + 5 * size] = t
        rows.append(row)
    return np.concatenate(rows, axis=0)


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.tools.contact_sheet",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True, help="PNG path")
    p.add_argument("--seed", type=int, default=0, help="generator seed (default 0)")
    p.add_argument("--per-family", type=int, default=4, help="samples per family (default 4)")
    p.add_argument("--size", type=int, default=128, help="tile side, px (default 128)")
    p.add_argument("--families", default=",".join(FAMILIES), help="comma list (default: all)")
    p.add_argument("--force", action="store_true", help="overwrite an existing file")
    args = p.parse_args(argv)
    try:
        if args.out.exists() and not args.force:
            raise SvbrdfError(f"{args.out}: exists (use --force to overwrite)")
        families = [f for f in args.families.split(",") if f]
        sheet = contact_sheet(args.seed, args.per_family, args.size, families)
        write_image(args.out, sheet, bits=8, force=args.force)
    except (SvbrdfError, ValueError) as e:
        print(f"contact_sheet: error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
