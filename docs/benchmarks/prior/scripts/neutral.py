"""Does a neutral photo stay neutral? Preview every real photo of ../shared/data made greyscale; report the mean
chroma of the base colour.

Each photo (linear) is replaced by its Rec.709 luminance in all three channels, centre-cropped to a square and
resized to ``--size`` px; the preview model predicts the maps; the chroma of a pixel is max(RGB) - min(RGB) of
the sRGB-encoded base colour; the mean over pixels and photos is the number the prior issue asks under 0.02.

    python docs/benchmarks/prior/scripts/neutral.py --model models/NAME.onnx --out docs/benchmarks/prior/neutral.json
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from svbrdf.runtime.colour import linear_to_srgb
from svbrdf.runtime.imageio import read_image
from svbrdf.runtime.session import estimate, load_session, resize_long_side

LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)


def photos(root: Path):
    henzler = sorted((root / "henzler-flash" / "test").glob("*/*.JPG"))
    des18 = sorted((root / "deschaintre18-real").glob("*.png"))
    return henzler + des18


def grey_square(path: Path, size: int) -> np.ndarray:
    img = read_image(path)[..., :3]
    h, w = img.shape[:2]
    s = min(h, w)
    img = img[(h - s) // 2:(h - s) // 2 + s, (w - s) // 2:(w - s) // 2 + s]
    img = resize_long_side(np.ascontiguousarray(img), size)
    y = (img * LUMA).sum(-1, keepdims=True)
    return np.repeat(y, 3, axis=-1).astype(np.float32)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--model", default=None, help="ONNX model (default: the packaged one)")
    p.add_argument("--data", type=Path, default=Path(__file__).resolve().parents[5] / "shared" / "data")
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    session = load_session(args.model, threads=1)
    rows = []
    for path in photos(args.data):
        maps = estimate(grey_square(path, args.size), session)
        srgb = linear_to_srgb(np.clip(maps.diffuse, 0, 1))
        chroma = srgb.max(-1) - srgb.min(-1)
        rows.append({"photo": str(path.relative_to(args.data)), "mean_chroma": float(chroma.mean()),
                     "mean_base_colour_srgb": [float(v) for v in srgb.reshape(-1, 3).mean(0)]})
        print(f"{rows[-1]['photo']}: chroma {rows[-1]['mean_chroma']:.4f} base colour "
              f"{np.round(rows[-1]['mean_base_colour_srgb'], 3).tolist()}")
    mean = float(np.mean([r["mean_chroma"] for r in rows]))
    print(f"mean chroma over {len(rows)} greyscale photos: {mean:.4f} (model {session.info.path.name})")
    if args.out:
        args.out.write_text(json.dumps({"command": " ".join(["python", *sys.argv]), "model": session.info.path.name,
                                        "size": args.size, "mean_chroma": mean, "photos": rows}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
