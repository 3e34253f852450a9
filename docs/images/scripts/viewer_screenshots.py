"""Screenshots of the viewer page (``svbrdf-preview --view``) for the README: ``docs/images/viewer_<browser>.jpg``.

The bundled example through ``svbrdf-preview runtime/examples/carved_wood.png --tileable --view`` into a temporary
folder, its ``carved_wood_view.html`` opened from its ``file://`` URL in each headless browser found
(:mod:`svbrdf.runtime.browser`: Chromium, Firefox) with the light and exposure given in the URL's fragment
(``#light=x,y,z&exposure=e``; default a low light at the top left, so that the relief shows), the page cropped to
its content and written as JPEG, quality 90. A browser that is absent is left out (said on stderr).

    OMP_NUM_THREADS=1 python docs/images/scripts/viewer_screenshots.py --out docs/images

Needs the package installed (``pip install -e .``) and the browsers (Debian: ``apt-get install chromium
firefox-esr``); no network.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "runtime" / "examples" / "carved_wood.png"
#: Scene units (half the photo width; the tiled view spans -3..3): a low light, top left of the material's centre.
LIGHT = (-0.9, 0.7, 0.6)
EXPOSURE = 1.5
#: The page's viewport (CSS pixels, one device pixel each).
VIEWPORT = (1340, 760)
#: What the README can afford per picture.
MAX_BYTES = 200_000

# The page's content: the three columns (the heading above is narrower), plus the body's margin.
_CONTENT = """(function () {
  var r = [0, 0];
  document.querySelectorAll("#views > div").forEach(function (e) {
    var b = e.getBoundingClientRect(); r[0] = Math.max(r[0], b.right); r[1] = Math.max(r[1], b.bottom);
  });
  return [Math.ceil(r[0]) + 12, Math.ceil(r[1]) + 12];
})()"""


def _jpeg(png: Path, out: Path, size, quality: int) -> None:
    """``png`` cropped to ``size`` (its top-left part), without alpha, as a JPEG of ``quality``."""
    import OpenImageIO as oiio

    buf = oiio.ImageBufAlgo.channels(oiio.ImageBuf(str(png)), (0, 1, 2))
    buf = oiio.ImageBufAlgo.cut(buf, oiio.ROI(0, size[0], 0, size[1]))
    buf.specmod().attribute("Compression", f"jpeg:{quality}")
    if not buf.write(str(out)) or buf.has_error:
        raise RuntimeError(f"{out}: {buf.geterror()}")


def main(argv=None) -> int:
    from svbrdf.runtime.browser import BROWSERS, find_browser
    from svbrdf.runtime.cli import main as preview

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=ROOT / "docs" / "images", help="folder of the pictures")
    p.add_argument("--light", type=float, nargs=3, default=LIGHT, metavar=("X", "Y", "Z"))
    p.add_argument("--exposure", type=float, default=EXPOSURE)
    p.add_argument("--quality", type=int, default=90)
    p.add_argument("--browsers", default="chromium,firefox", help="comma-separated, of: chromium, firefox")
    args = p.parse_args(argv)
    written = 0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if preview([str(EXAMPLE), "-o", str(tmp / "set"), "--tileable", "--view", "-q"]) != 0:
            return 1
        fragment = "#light={},{},{}&exposure={}".format(*args.light, args.exposure)
        url = (tmp / "set" / "carved_wood_view.html").as_uri() + fragment
        for kind in args.browsers.split(","):
            names, env, cls = BROWSERS[kind]
            exe = find_browser(kind)
            if exe is None:
                print(f"{kind}: not found (${env}, {', '.join(names)}): left out", file=sys.stderr)
                continue
            page = cls(exe, tmp / f"{kind}-profile", width=VIEWPORT[0], height=VIEWPORT[1])
            try:
                page.open(url)
                page.evaluate("window.svbrdfViewer.ready")
                error = page.evaluate("document.getElementById('err').textContent")
                if error:
                    raise RuntimeError(f"{kind}: {error}")
                size = page.evaluate(_CONTENT)
                (tmp / "shot.png").write_bytes(page.screenshot())
            finally:
                page.close()
            if size[0] > VIEWPORT[0] or size[1] > VIEWPORT[1]:
                raise RuntimeError(f"{kind}: the page ({size}) does not fit the viewport {VIEWPORT}")
            out = args.out / f"viewer_{kind}.jpg"
            _jpeg(tmp / "shot.png", out, size, args.quality)
            n = out.stat().st_size
            over = f"  over the {MAX_BYTES // 1000} KB budget" if n > MAX_BYTES else ""
            print(f"{out}: {size[0]} x {size[1]}, {n / 1000:.0f} KB ({Path(exe).name}){over}")
            written += 1
    return 0 if written else 1


if __name__ == "__main__":
    sys.exit(main())
