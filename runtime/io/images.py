"""Image files in and out (OpenImageIO), with the project's colour convention and safety rules.

Reading (:func:`read_image`): any format OpenImageIO reads (PNG 8/16-bit, JPEG, TIFF, OpenEXR half/float,
...) becomes an (H, W, 3) float32 array, oriented as displayed (EXIF ``Orientation`` applied).

* integer files (8/16-bit PNG, JPEG, TIFF) are taken as sRGB-encoded: values are divided by the type's
  maximum and decoded to linear with :func:`svbrdf.runtime.core.colour.srgb_to_linear` (unless ``raw=True``,
  which keeps the stored values, e.g. for roughness or normal maps);
* float files (EXR, float TIFF, HDR) are taken as linear, ``raw`` or not. NaN/Inf pixels are refused,
  negative values are clamped to 0 with a warning.
* grayscale becomes RGB; alpha (read unassociated, so colour is not premultiplied) and any channel after
  the third are dropped with an :class:`ImageWarning`.

Writing (:func:`write_image`): PNG (8/16-bit), OpenEXR (half/float) or TIFF (8/16/32-bit), atomically
(:func:`svbrdf.runtime.io.files.atomic_write`), never over an existing file unless ``force=True``. PNG files are
encoded by :func:`svbrdf.runtime.io.png.write_png` (the "up" filter and ISA-L's deflate; decision:
docs/decisions/013-png-encoder.md), the others by OpenImageIO; both leave
the GIL while they encode, so files can be written from several threads.

OpenImageIO never raises on a bad file; every call here is checked and turned into an
:class:`~svbrdf.runtime.errors.ImageError` with a one-line message ``"<path>: <problem>"``. A read that returns pixels
is checked too: a problem the reader reported while decoding refuses the file (a truncated or corrupt JPEG decodes,
grey where the data is missing, with only a libjpeg warning).
"""

from __future__ import annotations

import functools
import mmap
import os
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable, Iterator, Optional, Tuple, Union

import numpy as np
import OpenImageIO as oiio

from ..core.colour import linear_to_srgb, srgb_to_linear
from ..errors import ImageError, exists_message
from .files import atomic_write
from .png import COLOUR_CHUNKS, write_png
from ..core.filters import all_finite, block_mean

PathLike = Union[str, os.PathLike]

_FLOAT_TYPES = (oiio.HALF, oiio.FLOAT, oiio.DOUBLE)
#: Writable extensions -> allowed ``bits`` -> OpenImageIO pixel type. For EXR, 16 = half, 32 = float.
_WRITE_TYPES = {
    ".png": {8: oiio.UINT8, 16: oiio.UINT16},
    ".exr": {16: oiio.HALF, 32: oiio.FLOAT},
    ".tif": {8: oiio.UINT8, 16: oiio.UINT16, 32: oiio.FLOAT},
    ".tiff": {8: oiio.UINT8, 16: oiio.UINT16, 32: oiio.FLOAT},
}
WRITE_EXTENSIONS = tuple(_WRITE_TYPES)


class ImageWarning(UserWarning):
    """Something about an input image was changed on read (alpha dropped, negatives clamped, ...)."""


def _one_line(msg: str) -> str:
    lines = [ln.strip() for ln in str(msg).splitlines() if ln.strip()]
    return lines[0] if lines else "unknown error"


def _without_path(msg: str, path: Path) -> str:
    """``msg`` without the `` ("<path>")`` libjpeg's messages end with (the error names the file first)."""
    return msg.removesuffix(f' ("{path}")')


def _open(path: Path) -> "oiio.ImageInput":
    """Open ``path`` for reading with unassociated alpha; raise ImageError with a classified reason."""
    if not path.exists():
        raise ImageError(f"{path}: no such file")
    if path.is_dir():
        raise ImageError(f"{path}: is a directory, not an image")
    if path.stat().st_size == 0:
        raise ImageError(f"{path}: empty file (0 bytes)")
    cfg = oiio.ImageSpec()
    cfg.attribute("oiio:UnassociatedAlpha", 1)  # PNG alpha would otherwise premultiply the colour
    oiio.geterror()  # this thread's earlier errors are not this file's
    inp = oiio.ImageInput.open(str(path), cfg)
    if inp is None:
        err = oiio.geterror()
        if "could not find a format reader" in err:
            raise ImageError(f"{path}: unsupported or unrecognised image format")
        raise ImageError(f"{path}: unreadable or corrupt image ({_without_path(_one_line(err), path)})")
    oiio.geterror()  # what other formats' readers said while the file was probed
    try:  # a progressive JPEG is decoded on opening: its damage is reported here
        _check(path, inp)
    except ImageError:
        inp.close()
        raise
    return inp


def image_info(path: PathLike) -> dict:
    """Header facts of an image file without decoding its pixels.

    Returns:
        dict with ``width``, ``height`` (as stored, before orientation), ``channels``, ``channel_names``,
        ``format`` (OpenImageIO format name, e.g. "png", "openexr"), ``dtype`` (e.g. "uint8", "half"),
        ``is_float`` and ``orientation`` (EXIF 1..8).

    Raises:
        ImageError: missing, empty, unsupported or unreadable file; a damaged progressive JPEG (decoded on opening).
    """
    path = Path(path)
    inp = _open(path)
    try:
        spec = inp.spec()
        return {
            "width": spec.width,
            "height": spec.height,
            "channels": spec.nchannels,
            "channel_names": list(spec.channelnames),
            "format": inp.format_name(),
            "dtype": str(spec.format),
            "is_float": spec.format.basetype in _FLOAT_TYPES,
            "orientation": spec.get_int_attribute("Orientation", 1),
        }
    finally:
        inp.close()


def _reorient(arr: np.ndarray, orientation: int) -> np.ndarray:
    """Apply an EXIF orientation (1..8) so the array is as displayed (OpenImageIO's reorient)."""
    if orientation == 1:
        return arr
    h, w, c = arr.shape
    buf = oiio.ImageBuf(oiio.ImageSpec(w, h, c, oiio.FLOAT))
    buf.set_pixels(oiio.ROI(), np.ascontiguousarray(arr))
    buf.specmod().attribute("Orientation", int(orientation))
    out = oiio.ImageBufAlgo.reorient(buf)
    if out.has_error:
        raise RuntimeError(f"OpenImageIO reorient failed: {out.geterror()}")
    return out.get_pixels(oiio.FLOAT)


#: Filter of every downsizing (:func:`resize_long_side`): non-negative, so a linear photo stays >= 0.
RESIZE_FILTER = "blackman-harris"
#: Bytes of float32 pixels one strip of a reduced read holds (:func:`read_image` with ``max_size``).
STRIP_BYTES = 64 << 20


def resize_long_side(image: np.ndarray, max_size: int) -> np.ndarray:
    """Downsize an (H, W, C) float32 image so its long side is ``max_size`` (aspect kept, sides rounded).

    Uses OpenImageIO ``ImageBufAlgo.resize`` with :data:`RESIZE_FILTER`; returns ``image`` itself when it is
    already small enough.
    """
    h, w, c = image.shape
    if max(h, w) <= max_size:
        return image
    nh, nw = _reduced_size(h, w, max_size)
    src = oiio.ImageBuf(oiio.ImageSpec(w, h, c, oiio.FLOAT))
    src.set_pixels(oiio.ROI(), np.ascontiguousarray(image, dtype=np.float32))
    dst = oiio.ImageBufAlgo.resize(src, filtername=RESIZE_FILTER, roi=oiio.ROI(0, nw, 0, nh, 0, 1, 0, c))
    if dst.has_error:
        raise ImageError(f"cannot resize a {w}x{h} image to {nw}x{nh} ({_one_line(dst.geterror())})")
    return np.asarray(dst.get_pixels(oiio.FLOAT), dtype=np.float32).reshape(nh, nw, c)


def _reduced_size(h: int, w: int, max_size: int) -> tuple:
    scale = max_size / max(h, w)
    return max(1, round(h * scale)), max(1, round(w * scale))


_TABLE_TYPES = (oiio.UINT8, oiio.UINT16)


@functools.lru_cache(maxsize=4)
def _code_table(basetype, raw: bool) -> np.ndarray:
    """float32 value of every code of an unsigned 8/16-bit file as :func:`read_image` decodes it: OpenImageIO's
    own conversion to float (``code / max``), then :func:`~svbrdf.runtime.core.colour.srgb_to_linear` unless
    ``raw``. Each pixel is converted on its own, so looking its code up gives the same bits
    (tests/runtime/io/test_imageio.py)."""
    n = 256 if basetype == oiio.UINT8 else 65536
    codes = np.arange(n, dtype=np.uint8 if n == 256 else np.uint16).reshape(1, n, 1)
    buf = oiio.ImageBuf(oiio.ImageSpec(n, 1, 1, basetype))
    buf.set_pixels(oiio.ROI(), codes)
    values = np.clip(np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float32).reshape(n), 0.0, 1.0)
    table = values if raw else srgb_to_linear(values)
    table = np.ascontiguousarray(table, dtype=np.float32)
    table.setflags(write=False)
    return table


class _Decoder:
    """Turns stored pixels (any rows of the file, as float32) into the (rows, W, 3) float32 of :func:`read_image`,
    keeping what must be said once per file (dropped channels, clamped negatives)."""

    def __init__(self, path: Path, spec: "oiio.ImageSpec", raw: bool) -> None:
        self.path, self.raw = path, raw
        self.is_float = spec.format.basetype in _FLOAT_TYPES
        # 8/16-bit unsigned files are read as stored and decoded through a table of every code (_code_table): the
        # same float32 values as converting each pixel, without the float copies (019-large-photos-in-strips.md).
        self.native = next((t for t in _TABLE_TYPES if spec.format.basetype == t), None)
        self.read_type = self.native if self.native is not None else oiio.FLOAT
        nch = spec.nchannels
        self.keep = 1 if nch <= 2 else 3
        self.dropped = None
        if nch > self.keep:
            what = "alpha channel" if spec.alpha_channel >= self.keep else "extra channel(s)"
            self.dropped = f"{path}: {what} dropped ({', '.join(list(spec.channelnames)[self.keep:])})"
        self.negatives = 0

    def __call__(self, arr: np.ndarray) -> np.ndarray:
        arr = arr[..., :self.keep]
        if self.keep == 1:
            arr = np.repeat(arr, 3, axis=-1)
        if self.native is not None:
            return _code_table(self.native, self.raw)[arr]
        if self.is_float:
            bad = int(np.count_nonzero(~np.isfinite(arr)))
            if bad:
                raise ImageError(f"{self.path}: {bad} NaN/Inf pixel values")
            neg = int(np.count_nonzero(arr < 0))
            if neg:
                self.negatives += neg
                arr = np.maximum(arr, 0.0)
        else:
            # Signed integer types map to [-1, 1] in OpenImageIO; photos are non-negative.
            arr = np.clip(arr, 0.0, 1.0)
            if not self.raw:
                arr = srgb_to_linear(arr)
        return np.asarray(arr, dtype=np.float32)

    def warn(self) -> None:
        if self.dropped:
            warnings.warn(ImageWarning(self.dropped), stacklevel=3)
        if self.negatives:
            warnings.warn(ImageWarning(f"{self.path}: {self.negatives} negative values clamped to 0"), stacklevel=3)


def _dims(path: Path, spec: "oiio.ImageSpec") -> Tuple[int, int, int]:
    """(height, width, channels) of a file's header; ImageError for an empty image."""
    h, w, nch = spec.height, spec.width, spec.nchannels
    if w <= 0 or h <= 0 or nch <= 0:
        raise ImageError(f"{path}: empty image ({w}x{h}, {nch} channels)")
    return h, w, nch


#: libjpeg warnings about a JPEG's header, not its pixels: such a file is read. libjpeg reports only its first
#: warning, so the file must also have an end-of-image marker after its last scan (:func:`_jpeg_ends`).
_HEADER_NOTES = ("unknown JFIF revision number", "Unknown Adobe color transform code",
                 "Invalid SOS parameters for sequential JPEG")


def _is_note(problem: str) -> bool:
    return any(note in problem for note in _HEADER_NOTES)


def _reported(path: Path, inp: "oiio.ImageInput") -> list:
    """The problems ``inp``'s reader reported (on ``inp`` and in OpenImageIO's global error, both per thread) since
    they were last asked for, one line each (:func:`_without_path`); clears them."""
    text = f"{inp.geterror()}\n{oiio.geterror()}"
    return [_without_path(ln.strip(), path) for ln in text.splitlines() if ln.strip()]


def _unreadable(path: Path, inp: "oiio.ImageInput", problems: Optional[list] = None) -> ImageError:
    """The one-line error of a file its reader could not decode completely (``problems``: :func:`_reported`)."""
    problems = _reported(path, inp) if problems is None else problems
    bad = [p for p in problems if not _is_note(p)] or problems or ["unknown error"]
    return ImageError(f"{path}: unreadable, corrupt or truncated image ({bad[0]})")


def _check(path: Path, inp: "oiio.ImageInput") -> None:
    """Raise :func:`_unreadable` when ``inp``'s reader reported a problem in this thread since the last check, other
    than a :data:`_HEADER_NOTES` one of a JPEG that ends (:func:`_jpeg_ends`). Call it after every read that
    returned pixels, in the thread that read."""
    problems = _reported(path, inp)
    if not problems:
        return
    if not all(map(_is_note, problems)):
        raise _unreadable(path, inp, problems)
    if not _jpeg_ends(path):
        raise _unreadable(path, inp, ["no end-of-image marker after the last scan"])


def _jpeg_ends(path: Path) -> bool:
    """Whether a JPEG file has an end-of-image marker (FF D9) after its last start-of-scan one (FF DA)."""
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
        return data.find(b"\xff\xd9", max(0, data.rfind(b"\xff\xda"))) >= 0


def read_image(path: PathLike, *, raw: bool = False, max_size: Optional[int] = None) -> np.ndarray:
    """Read an image file as an (H, W, 3) float32 array, as displayed (EXIF orientation applied).

    Args:
        path: image file (anything OpenImageIO reads: PNG, JPEG, TIFF, OpenEXR, ...).
        raw: keep the stored values of integer files (``value / max`` in [0, 1]) instead of decoding sRGB to
            linear; use it for data maps (roughness, normals). Float files are linear either way.
        max_size: downsize so the long side is at most ``max_size`` (as :func:`resize_long_side`), and warn
            that it did. A file at least twice that size is read in strips of scanlines, each averaged over
            k x k pixel blocks (k = the integer part of the reduction, in linear values) before the final
            resize, so memory stays near :data:`STRIP_BYTES` plus the reduced image whatever the file's size.

    Returns:
        (H, W, 3) float32: linear RGB in [0, 1] for integer files (sRGB-encoded [0, 1] if ``raw``); linear
        RGB >= 0 for float files (may exceed 1).

    Raises:
        ImageError: missing, empty, unsupported, unreadable/corrupt/truncated file, 0-pixel image, or NaN/Inf
            pixels in a float file.

    Warns:
        ImageWarning: alpha or extra channels dropped; negative float values clamped to 0; the photo downsized.
    """
    path = Path(path)
    inp = _open(path)
    try:
        spec = inp.spec()
        h, w, nch = _dims(path, spec)
        orientation = spec.get_int_attribute("Orientation", 1)
        decode = _Decoder(path, spec, raw)
        k = int(max(h, w) // max_size) if max_size and max(h, w) > max_size else 1
        if k < 2:  # the whole file at once
            arr = inp.read_image(0, 0, 0, nch, decode.read_type)
            if arr is None:
                raise _unreadable(path, inp)
            _check(path, inp)
            arr = decode(np.asarray(arr).reshape(h, w, nch))
        else:  # strips of k * m rows, each reduced to m rows of k x k block means
            m = max(1, STRIP_BYTES // (k * w * nch * 4))
            strips = []
            for y0 in range(0, h, k * m):
                y1 = min(h, y0 + k * m)
                rows = inp.read_scanlines(0, 0, y0, y1, 0, 0, nch, decode.read_type)
                if rows is None:
                    raise _unreadable(path, inp)
                _check(path, inp)
                strips.append(block_mean(decode(np.asarray(rows).reshape(y1 - y0, w, nch)), k,
                                             partial=True))
            arr = np.concatenate(strips, axis=0)
    finally:
        inp.close()
    decode.warn()
    arr = _reorient(arr, orientation)
    if max_size and max(h, w) > max_size:
        arr = resize_long_side(arr, max_size)
        oh, ow = (w, h) if orientation in (5, 6, 7, 8) else (h, w)
        warnings.warn(ImageWarning(f"{path}: downsized from {ow}x{oh} to {arr.shape[1]}x{arr.shape[0]} pixels "
                                   f"(long side limit {max_size}: --max-size, or max_size in the API)"),
                      stacklevel=2)
    return np.ascontiguousarray(arr, dtype=np.float32)


def read_strips(path: PathLike, rows: int) -> Iterator[Tuple[int, np.ndarray]]:
    """``(y0, strip)``: the pixels of a file as :func:`read_image` decodes them (linear, (r, W, 3) float32; no
    ``max_size``), ``rows`` rows at a time from the top (the last strip shorter), so that a caller that only needs
    reductions of a large photo (block means, luminance) never holds it whole. The next strip is decoded on a second
    thread while the caller works on this one (OpenImageIO leaves the GIL while it decodes). Decision:
    docs/decisions/019-large-photos-in-strips.md.

    Args:
        path: image file stored as displayed (EXIF orientation 1; :func:`image_info`).
        rows: rows per strip, >= 1.

    Raises:
        ImageError: as :func:`read_image` (missing, unreadable, truncated, NaN/Inf in a float file), when the
            strip is reached.
        ValueError: a file with another orientation, or ``rows`` < 1.

    Warns:
        ImageWarning: as :func:`read_image` (alpha dropped, negatives clamped), after the last strip.
    """
    path = Path(path)
    if rows < 1:
        raise ValueError(f"rows must be >= 1, got {rows}")
    inp = _open(path)
    try:
        spec = inp.spec()
        h, w, nch = _dims(path, spec)
        if spec.get_int_attribute("Orientation", 1) != 1:
            raise ValueError(f"{path}: read_strips reads files stored as displayed (EXIF orientation 1)")
        decode = _Decoder(path, spec, False)

        def load(y0: int) -> np.ndarray:
            y1 = min(h, y0 + rows)
            px = inp.read_scanlines(0, 0, y0, y1, 0, 0, nch, decode.read_type)
            if px is None:
                raise _unreadable(path, inp)
            _check(path, inp)  # in this (the decoding) thread: OpenImageIO's errors are per thread
            return np.asarray(px).reshape(y1 - y0, w, nch)

        with ThreadPoolExecutor(1) as pool:  # leaving it (a caller that stops early too) waits for the decoding
            ahead = pool.submit(load, 0)
            for y0 in range(0, h, rows):
                stored = ahead.result()
                if y0 + rows < h:
                    ahead = pool.submit(load, y0 + rows)
                yield y0, np.asarray(decode(stored), dtype=np.float32)
    finally:
        inp.close()
    decode.warn()


def _as_hwc(path: Path, arr: np.ndarray) -> np.ndarray:
    a = np.asarray(arr)
    if a.ndim == 2:
        a = a[..., None]
    if a.ndim != 3 or a.shape[-1] not in (1, 3, 4) or a.shape[0] < 1 or a.shape[1] < 1:
        raise ImageError(f"{path}: cannot write an array of shape {np.shape(arr)} (expected (H, W), (H, W, 1), "
                         f"(H, W, 3) or (H, W, 4))")
    a = a.astype(np.float32, copy=False)
    if not all_finite(a):
        raise ImageError(f"{path}: refusing to write NaN/Inf values")
    return a


#: Bytes of float32 one strip of :func:`_strips` converts (and writes) at a time.
QUANTISE_STRIP_BYTES = 8 << 20


def _rows(a: np.ndarray, y0: int, rows: int, transform) -> np.ndarray:
    """Rows ``y0:y0 + rows`` of ``a`` as a new float32 array, through ``transform`` when given."""
    s = a[y0:y0 + rows]
    if transform is None:
        return np.array(s, dtype=np.float32)
    s = np.asarray(transform(s), dtype=np.float32)
    if s.shape[:2] != (min(rows, a.shape[0] - y0), a.shape[1]) or s.shape[-1] != a.shape[-1]:
        raise ValueError(f"transform changed a strip's shape to {s.shape}")
    return s


def _strips(a: np.ndarray, bits: Optional[int], srgb_encode: bool, transform=None):
    """``(y0, strip)`` of (H, W, C) float ``a``, :data:`QUANTISE_STRIP_BYTES` of float32 at a time (each through
    ``transform`` first), as the file stores it. ``bits`` 8 or 16: uint8/uint16 codes as OpenImageIO writes a float
    buffer into an integer file: clip to [0, 1] (sRGB-encode the first three channels and clip again with
    ``srgb_encode``), then round half to even of ``value * max`` in float32 (what OpenImageIO's writer does with a
    float buffer: the same codes, half-way values included, tests/runtime/io/test_imageio.py). ``bits`` None: the
    float32 values. No strip outlives its writing: no full-size copy of the image is made."""
    h, w, c = a.shape
    rows = max(1, QUANTISE_STRIP_BYTES // (w * c * 4))
    for y0 in range(0, h, rows):
        s = _rows(a, y0, rows, transform)
        if bits is None:
            yield y0, s
            continue
        dtype, top = (np.uint8, 255.0) if bits == 8 else (np.uint16, 65535.0)
        np.clip(s, 0.0, 1.0, out=s)
        if srgb_encode:
            s[..., :3] = linear_to_srgb(s[..., :3])  # alpha stays linear
            np.clip(s, 0.0, 1.0, out=s)
        np.multiply(s, np.float32(top), out=s)
        np.rint(s, out=s)
        yield y0, s.astype(dtype)


def write_image(
    path: PathLike,
    arr: np.ndarray,
    *,
    bits: int = 16,
    srgb_encode: bool = False,
    force: bool = False,
    colour_space: Optional[str] = None,
    transform: Optional[Callable[[np.ndarray], np.ndarray]] = None,
) -> Path:
    """Write a float image atomically as PNG, OpenEXR or TIFF (format from the extension).

    Args:
        path: target file; its folder must exist. Extension ``.png``, ``.exr``, ``.tif`` or ``.tiff``.
        arr: (H, W), (H, W, 1), (H, W, 3) or (H, W, 4) float array. Integer formats clip it to [0, 1] and
            round to the nearest code; float formats store it as is. A fourth channel is written as an
            unassociated (straight) alpha: it is never sRGB-encoded and the colour is not divided by it.
        bits: 8 or 16 for PNG; 16 (half) or 32 (float) for EXR; 8, 16 or 32 (float) for TIFF.
        srgb_encode: ``arr`` is linear colour: encode it with the sRGB curve before quantising and tag the file
            sRGB (integer formats only). Otherwise values are stored as given.
        colour_space: the colour-space tag of an integer file (``oiio:ColorSpace``): ``"linear"`` for data maps
            (in a PNG a gAMA chunk of 1.0, so that readers such as ``oiiotool`` do not take them as sRGB),
            ``"sRGB"`` for an image already sRGB-encoded. Default: ``"sRGB"`` with ``srgb_encode``, else untagged.
        force: overwrite an existing file.
        transform: a conversion applied to each strip of rows ((h, W, C) float32 -> the same shape) before the
            file's own encoding, so that it takes no full-size copy of ``arr`` (the writers clip and encode each
            map this way); NaN/Inf are checked on ``arr``.

    Returns:
        The written path.

    Raises:
        ImageError: target exists (and not ``force``), unsupported extension, missing folder, bad array
            (shape, NaN/Inf), or the write failed (OpenImageIO's error, or the system's for a PNG). No partial
            file is ever left behind.
        ValueError: ``bits`` not valid for the format, ``srgb_encode`` with a float format, or a PNG's
            ``colour_space`` other than ``"linear"``, ``"sRGB"`` or None.
    """
    path = Path(path)
    if path.exists() and not force:
        raise ImageError(exists_message(path))
    ext = path.suffix.lower()
    if ext not in _WRITE_TYPES:
        raise ImageError(f"{path}: unsupported output format {ext or '(none)'!r} (use {', '.join(WRITE_EXTENSIONS)})")
    if bits not in _WRITE_TYPES[ext]:
        raise ValueError(f"bits={bits!r} is not valid for {ext} (allowed: {sorted(_WRITE_TYPES[ext])})")
    pixel_type = _WRITE_TYPES[ext][bits]
    is_float = pixel_type in (oiio.HALF, oiio.FLOAT)
    if srgb_encode and is_float:
        raise ValueError(f"srgb_encode is for integer formats; {ext} with bits={bits} stores linear floats")
    if ext == ".png" and colour_space not in COLOUR_CHUNKS:
        raise ValueError(f"a PNG's colour_space is 'linear', 'sRGB' or None, got {colour_space!r}")
    if path.is_dir():
        raise ImageError(f"{path}: is a directory")
    if not path.parent.is_dir():
        raise ImageError(f"{path}: folder {path.parent} does not exist")

    a = _as_hwc(path, arr)
    h, w, c = a.shape

    # quantised (or transformed) and written strip by strip: the caller's array is never modified and no
    # full-size copy of it is made
    strips = None if (is_float and transform is None) else _strips(a, None if is_float else bits, srgb_encode,
                                                                   transform)
    if ext == ".png":  # our encoder (:mod:`.png`); OpenImageIO writes the other formats
        tag = colour_space or ("sRGB" if srgb_encode else None)
        with atomic_write(path, force=force, error=ImageError) as tmp:
            try:
                with open(tmp, "wb") as file:
                    write_png(file, (s for _, s in strips), w, h, c, bits, tag)
            except OSError as exc:
                raise ImageError(f"{path}: write failed ({exc.strerror or exc})") from None
        return path
    spec = oiio.ImageSpec(w, h, c, pixel_type)
    if c == 4:  # without this OpenImageIO treats alpha as associated and un-premultiplies the colour on write
        spec.attribute("oiio:UnassociatedAlpha", 1)
    if not is_float:
        spec.attribute("oiio:ColorSpace", colour_space or ("sRGB" if srgb_encode else "Raw"))
    with atomic_write(path, force=force, error=ImageError) as tmp:  # keeps the extension: OIIO picks the format
        out = oiio.ImageOutput.create(str(tmp))
        if out is None:
            raise ImageError(f"{path}: cannot write ({_one_line(oiio.geterror())})")
        ok = out.open(str(tmp), spec)
        if ok and strips is None:
            ok = out.write_image(np.ascontiguousarray(a))
        elif ok:
            for y0, strip in strips:
                ok = out.write_scanlines(y0, y0 + strip.shape[0], 0, np.ascontiguousarray(strip))
                if not ok:
                    break
        err = "" if ok else out.geterror()
        ok = out.close() and ok
        if not ok:
            raise ImageError(f"{path}: write failed ({_one_line(err or out.geterror())})")
    return path


def text_supported() -> bool:
    """True when OpenImageIO can draw text here (``ImageBufAlgo.render_text`` needs a usable font)."""
    buf = oiio.ImageBuf(oiio.ImageSpec(64, 32, 3, oiio.FLOAT))
    return bool(oiio.ImageBufAlgo.render_text(buf, 2, 20, "1.0", 12, "", (1.0, 1.0, 1.0))) and \
        float(buf.get_pixels(oiio.FLOAT).sum()) > 0


__all__ = ["ImageWarning", "read_image", "read_strips", "write_image", "image_info", "WRITE_EXTENSIONS",
           "text_supported"]
