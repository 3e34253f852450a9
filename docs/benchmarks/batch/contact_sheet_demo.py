"""Flash photos of procedural materials (no third-party data) for the contact-sheet screenshot.

    python docs/benchmarks/batch/contact_sheet_demo.py OUT_DIR [N]

Writes N (default 8) 256 px sRGB PNGs, seed 7: procedural materials (:mod:`svbrdf.trainer.procedural`) rendered as
realistic flash photos (:func:`svbrdf.trainer.prior.simulate_photos`), named after their material family.
"""

import sys
from pathlib import Path

import torch

from svbrdf.runtime.imageio import write_image
from svbrdf.trainer.prior import PriorConfig, simulate_photos
from svbrdf.trainer.procedural import sample_materials

out, n = Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 8
out.mkdir(parents=True, exist_ok=True)
rng = torch.Generator().manual_seed(7)
maps, names = sample_materials(n, 256, rng)
photos, _, _ = simulate_photos(maps, PriorConfig(), rng)
for i, (photo, name) in enumerate(zip(photos, names)):
    write_image(out / f"{i:02d}_{name}.png", photo.permute(1, 2, 0).numpy(), bits=8, srgb_encode=True, force=True)
print(f"wrote {n} photos to {out}")
