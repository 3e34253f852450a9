"""Make ``docs/images/real_photos.jpg``: real flash photos through ``svbrdf-preview --refine`` with its defaults, one
row each: the photo, the files as written (base colour, normal, roughness, specular) and the relit panel (the flash,
a light upper left, a light lower right).

    python docs/images/real_photos.py PHOTO... [--max-size 1024] [--out docs/images/real_photos.jpg] [--force]

Every panel is shown at :data:`ROW` px high; each row says whether the refine kept its fit or the preview.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from svbrdf.runtime.io.images import read_image

sys.path.insert(0, str(Path(__file__).resolve().parent))
from texture_set import HERE, join, panel, write_jpeg  # noqa: E402

ROW = 240  # px: the height of every panel


def _fit(img: np.ndarray, height: int = ROW) -> np.ndarray:
    img = np.repeat(img, 3, axis=-1) if img.shape[-1] == 1 else img[..., :3]
    src = oiio.ImageBuf(np.ascontiguousarray(img, np.float32))
    width = round(img.shape[1] * height / img.shape[0])
    return oiio.ImageBufAlgo.resize(src, roi=oiio.ROI(0, width, 0, height, 0, 1, 0, 3)).get_pixels(oiio.FLOAT)


def row(photo: Path, folder: Path, max_size: int) -> np.ndarray:
    """One photo's row, from ``svbrdf-preview PHOTO --refine`` written into ``folder``."""
    subprocess.run([sys.executable, "-m", "svbrdf.runtime.cli.preview", str(photo), "-o", str(folder), "--refine",
                    "--max-size", str(max_size), "-q"], check=True)
    name = photo.stem
    meta = json.loads((folder / f"{name}.json").read_text())["meta"]
    raw = lambda role: read_image(folder / f"{name}_{role}.png", raw=True)  # noqa: E731  (the file's codes)
    relit = raw("relit")
    w = relit.shape[1] // 3
    rec = meta["refine"]
    kept = "refined" if rec["kept"] == "refined" else f"preview kept ({rec['reason']})"
    with warnings.catch_warnings():  # the downsizing svbrdf-preview did too
        warnings.simplefilter("ignore")
        image = read_image(photo, raw=True, max_size=max_size)
    panels = [(image, f"{name}: {kept}"), (raw("basecolor"), "base colour"), (raw("normal"), "normal (OpenGL)"),
              (raw("roughness"), "roughness"), (raw("specular"), "specular"), (relit[:, :w], "relit, flash"),
              (relit[:, w:2 * w], "relit, upper left"), (relit[:, 2 * w:], "relit, lower right")]
    return join([panel(_fit(img), label) for img, label in panels], axis=1)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("photos", nargs="+", type=Path)
    p.add_argument("--max-size", type=int, default=1024, help="svbrdf-preview --max-size (default 1024)")
    p.add_argument("--out", type=Path, default=HERE / "real_photos.jpg")
    p.add_argument("--force", action="store_true", help="overwrite --out")
    args = p.parse_args(argv)
    if args.out.exists() and not args.force:
        raise SystemExit(f"{args.out}: exists (--force to overwrite)")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, photo in enumerate(args.photos):
            rows.append(row(photo, Path(tmp) / str(i), args.max_size))
    width = max(r.shape[1] for r in rows)
    rows = [np.pad(r, ((0, 0), (0, width - r.shape[1]), (0, 0)), constant_values=0.12) for r in rows]
    write_jpeg(join(rows, axis=0), args.out, args.force)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
