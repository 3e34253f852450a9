"""Make ``docs/images/texture_set.jpg``: the bundled example photo, its texture set as ``svbrdf-preview`` writes it
(base colour, normal, roughness, height, AO) and the set relit under the relit panel's two other lights.

    python docs/images/texture_set.py [--out docs/images/texture_set.jpg] [--force]

The files are shown as written (the AO too); the relit views are the last two panels of ``<name>_relit.png``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from svbrdf.runtime.io.images import read_image

HERE = Path(__file__).resolve().parent
EXAMPLE = HERE.parents[1] / "runtime" / "examples" / "carved_wood.png"
LABEL = 26  # px of the label bar above each panel
GAP = 6


def panel(img: np.ndarray, label: str) -> np.ndarray:
    """``img`` (H, W, 1 or 3+) with a label bar above it, (LABEL + H, W, 3) float."""
    img = np.repeat(img, 3, axis=-1) if img.shape[-1] == 1 else img[..., :3]
    h, w = img.shape[:2]
    bar = oiio.ImageBuf(oiio.ImageSpec(w, LABEL, 3, oiio.FLOAT))
    oiio.ImageBufAlgo.fill(bar, (0.12, 0.12, 0.12))
    oiio.ImageBufAlgo.render_text(bar, 4, LABEL - 8, label, 15, "", (0.9, 0.9, 0.9))
    return np.concatenate([bar.get_pixels(oiio.FLOAT), img.astype(np.float32)], axis=0)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=HERE / "texture_set.jpg")
    p.add_argument("--force", action="store_true", help="overwrite --out")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-m", "svbrdf.runtime.cli.preview", str(EXAMPLE), "-o", tmp, "-q"],
                       check=True)
        folder, name = Path(tmp), EXAMPLE.stem
        meta = json.loads((folder / f"{name}.json").read_text())
        raw = lambda role: read_image(folder / f"{name}_{role}.png", raw=True)  # noqa: E731  (the file's codes)
        relit = raw("relit")
        w = relit.shape[1] // 3
        ao_strength = meta["relief"]["ao"]["strength"]
        panels = [(read_image(EXAMPLE, raw=True), "photo"), (raw("basecolor"), "base colour"),
                  (raw("normal"), "normal (OpenGL)"), (raw("roughness"), "roughness"),
                  (raw("height"), "height (white = high)"), (raw("ao"), f"AO (strength {ao_strength:g})"),
                  (relit[:, w:2 * w], "relit, light upper left"), (relit[:, 2 * w:], "relit, light lower right")]
        row = join([panel(img, label) for img, label in panels], axis=1)
        write_jpeg(row, args.out, args.force)
    print(f"wrote {args.out}")
    return 0


def join(tiles, axis: int) -> np.ndarray:
    """Tiles side by side (``axis`` 1) or stacked (0), :data:`GAP` px of the bars' grey between them."""
    shape = list(tiles[0].shape)
    shape[axis] = GAP
    gap = np.full(shape, 0.12, np.float32)
    return np.concatenate([t for tile in tiles for t in (tile, gap)][:-1], axis=axis)


def write_jpeg(image: np.ndarray, out: Path, force: bool) -> None:
    """``image`` (sRGB codes in [0, 1]) as a quality-90 JPEG; an existing ``out`` only with ``force``."""
    if out.exists() and not force:
        raise SystemExit(f"{out}: exists (--force to overwrite)")
    buf = oiio.ImageBuf(oiio.ImageSpec(image.shape[1], image.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), np.clip(image, 0, 1))
    buf.specmod().attribute("Compression", "jpeg:90")
    if not buf.write(str(out)):
        raise SystemExit(f"{out}: {buf.geterror()}")


if __name__ == "__main__":
    sys.exit(main())
