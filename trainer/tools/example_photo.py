"""An example photo with a clear flash highlight: one procedural material rendered as a realistic flash photo.

::

    python -m svbrdf.trainer.tools.example_photo --out runs/example/procedural_leather.png \\
        --grid runs/example/highlight_example.png

Meant as the second bundled example (the first, ``runtime/examples/carved_wood.png``, has no highlight), once the
maps of a highlight photo are clean enough to show first (issue "what a new user trips over", item 7).

The photo is made by this project alone (no third-party content, so it is under the project's licence): a
material of :mod:`svbrdf.trainer.procedural` (family ``--family``, seed ``--seed``) rendered by the one renderer
with inverse-square fall-off at a 60 deg field of view, the flash on the lens axis, then recorded by the camera
model of :mod:`svbrdf.trainer.camera_model` (exposure ``--ev`` stops, so the highlight clips; vignetting 0.1; shot and
read noise; 8-bit sRGB): :func:`svbrdf.trainer.prior.simulate_photos` with its ranges fixed. With ``--grid``, a
picture of what the runtime makes of it (rows: the preview without and with the post-processing of
:mod:`svbrdf.runtime.post.flash_trend`, then the default refine; columns as :mod:`svbrdf.trainer.tools.before_after`),
and a JSON beside it with each row's label-free burn-in.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from svbrdf.runtime.errors import SvbrdfError


def make_photo(family: str, seed: int, size: int, ev: float) -> np.ndarray:
    """(size, size, 3) linear photo in [0, 1] (8-bit sRGB values decoded) of one procedural material."""
    import torch

    from svbrdf.trainer.prior import PriorConfig, simulate_photos
    from svbrdf.trainer.procedural import sample_materials

    cfg = PriorConfig.from_dict({"photos": {
        "fov_deg": (60.0, 60.0), "light_offset": 0.0, "physical_share": 0.0,
        "camera": {"ev": (ev, ev), "vignetting": (0.1, 0.1), "shot": (1e-4, 1e-4), "read": (0.002, 0.002)}}})
    g = torch.Generator().manual_seed(seed)
    maps, _ = sample_materials(1, size, g, families=[family])
    photos, _, _ = simulate_photos(maps, cfg, g)
    return photos[0].permute(1, 2, 0).numpy()


def grid(photo: np.ndarray, threads: int = 1):
    """The rows (preview without and with the post-processing, default refine) and their burn-in scores."""
    from svbrdf.runtime.inference.pipeline import estimate
    from svbrdf.runtime.inference.session import load_session
    from svbrdf.runtime.post import PostProcess
    from svbrdf.trainer.refine import refine
    from svbrdf.trainer.tools.before_after import row_image

    session = load_session(threads=threads)
    rows, scores = [], {}
    for label, flag in (("preview without post-processing", False), ("preview", True)):
        maps = estimate(photo, session, post=PostProcess(flash_trend=flag, uniform_specular=flag))
        rows.append(row_image(photo, maps))
        scores[label] = maps.meta["burn_in"]["burn_in"]
    maps = refine(photo, estimate(photo, session), session.render_config, threads=threads)
    rows.append(row_image(photo, maps))
    scores[f"refine ({maps.meta['refine']['kept']})"] = maps.meta["burn_in"]["burn_in"]
    return np.concatenate(rows, axis=0), scores


def main(argv: Optional[Sequence[str]] = None) -> int:
    from svbrdf.runtime.io.images import write_image

    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.tools.example_photo",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--family", default="leather", help="procedural family (default leather)")
    p.add_argument("--seed", type=int, default=1002, help="material seed (default 1002)")
    p.add_argument("--size", type=int, default=384, help="side, px (default 384)")
    p.add_argument("--ev", type=float, default=0.7, help="exposure, stops (default 0.7: the highlight clips)")
    p.add_argument("--out", type=Path, required=True, help="the photo (8-bit sRGB PNG)")
    p.add_argument("--grid", type=Path, default=None, help="also write the before/after picture here")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    args = p.parse_args(argv)
    try:
        for path in (args.out, args.grid):
            if path is not None and path.exists() and not args.force:
                raise SvbrdfError(f"{path}: exists (use --force to overwrite)")
        photo = make_photo(args.family, args.seed, args.size, args.ev)
        write_image(args.out, photo, bits=8, srgb_encode=True, force=args.force)
        print(f"{args.out}: {args.family} seed {args.seed}, {args.size} px, "
              f"{100 * float((photo.max(axis=-1) >= 0.98).mean()):.1f} % of pixels clipped")
        if args.grid is not None:
            from svbrdf.runtime.io.images import read_image

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                picture, scores = grid(read_image(args.out), args.threads)  # the photo as a user's file reads
            write_image(args.grid, picture, bits=8, force=args.force)
            args.grid.with_suffix(".json").write_text(json.dumps(
                {"command": " ".join(["python -m svbrdf.trainer.tools.example_photo"] + list(argv or sys.argv[1:])),
                 "burn_in": scores}, indent=1) + "\n")
            print(f"{args.grid}: " + ", ".join(f"{k} burn-in {v:.2f}" for k, v in scores.items()))
    except (SvbrdfError, ValueError) as e:
        print(f"example_photo: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
