"""PNG encoding of the maps: the "up" filter in numpy and ISA-L's deflate (python-isal), strip by strip.

:func:`write_png` is what :func:`svbrdf.runtime.io.images.write_image` uses for every PNG; reading stays with
OpenImageIO, whose PNG writer compresses with the system zlib, several times slower for files of about the same
size. Decision: docs/decisions/013-png-encoder.md.

The file: the PNG signature, IHDR (greyscale, grey + alpha, RGB or RGBA, 8 or 16 bits, no interlace), the
colour-space chunks (:data:`COLOUR_CHUNKS`), one IDAT chunk per compressed strip, IEND. Every row uses filter 2
("up": each byte minus the byte above it, modulo 256; the first row minus zeros), the bytes big-endian as the format
asks. The compressor and numpy release the GIL: several files can be written from several threads.
"""

from __future__ import annotations

import struct
import zlib
from typing import BinaryIO, Iterable, Optional

import numpy as np
from isal import isal_zlib

SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: ISA-L's deflate level (0-3; 013-png-encoder.md).
LEVEL = 1
#: PNG colour type by channel count (greyscale, grey + alpha, RGB, RGBA).
_COLOUR_TYPE = {1: 0, 2: 4, 3: 2, 4: 6}
_FILTER_UP = 2


def _chunk(kind: bytes, data: bytes = b"") -> tuple:
    """A chunk's three parts (length and type, data, CRC), written one after another without joining them."""
    return struct.pack(">I", len(data)) + kind, data, struct.pack(">I", zlib.crc32(data, zlib.crc32(kind)))


#: The chunks that tag a file's colour space, as OpenImageIO and other readers take them: ``"sRGB"`` the sRGB chunk
#: (perceptual intent) with its gAMA (1 / 2.2) and cHRM (Rec. 709 primaries, D65) fallbacks; ``"linear"`` a gAMA of
#: 1.0 (OpenImageIO reads it as linear Rec. 709); None nothing (readers take an untagged PNG as sRGB).
COLOUR_CHUNKS = {
    "sRGB": (*_chunk(b"sRGB", b"\x00"), *_chunk(b"gAMA", struct.pack(">I", 45455)),
             *_chunk(b"cHRM", struct.pack(">8I", 31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000))),
    "linear": _chunk(b"gAMA", struct.pack(">I", 100000)),
    None: (),
}


def write_png(file: BinaryIO, strips: Iterable[np.ndarray], width: int, height: int, channels: int, bits: int,
              colour_space: Optional[str] = None) -> None:
    """Write a PNG to the open binary ``file`` from its rows, strip by strip.

    Args:
        file: a binary file open for writing, at its start.
        strips: (h, width, channels) arrays of the image's rows, top to bottom, ``height`` rows in all: uint8 codes
            for ``bits`` 8, uint16 for 16 (as stored: no clipping, rounding or colour conversion here).
        width, height: the image's size in pixels (at least 1).
        channels: 1 (grey), 2 (grey + alpha), 3 (RGB) or 4 (RGBA, straight alpha).
        bits: 8 or 16.
        colour_space: a key of :data:`COLOUR_CHUNKS`.

    Raises:
        ValueError: a bad size, channel count, bit depth or colour space, or strips that do not make the image.
        OSError: the file could not be written.
    """
    if channels not in _COLOUR_TYPE or bits not in (8, 16) or width < 1 or height < 1:
        raise ValueError(f"cannot write a {width} x {height} PNG of {channels} channels at {bits} bits")
    if colour_space not in COLOUR_CHUNKS:
        raise ValueError(f"PNG colour space must be one of {sorted(map(str, COLOUR_CHUNKS))}, got {colour_space!r}")
    dtype = np.dtype(">u2") if bits == 16 else np.dtype(np.uint8)
    row_bytes = width * channels * dtype.itemsize
    file.writelines((SIGNATURE, *_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bits, _COLOUR_TYPE[channels],
                                                             0, 0, 0)), *COLOUR_CHUNKS[colour_space]))
    deflate = isal_zlib.compressobj(LEVEL)
    above = np.zeros(row_bytes, np.uint8)  # the row above the first: zeros, so its "up" filter is the row itself
    done = 0
    for strip in strips:
        if strip.ndim != 3 or strip.shape[1:] != (width, channels) or done + strip.shape[0] > height:
            raise ValueError(f"a strip of shape {strip.shape} does not fit a {width} x {height} x {channels} image "
                             f"at row {done}")
        if strip.dtype.itemsize != dtype.itemsize:
            raise ValueError(f"{bits}-bit PNG rows must be {dtype.itemsize}-byte codes, got {strip.dtype}")
        h = strip.shape[0]
        raw = np.ascontiguousarray(strip, dtype).view(np.uint8).reshape(h, row_bytes)
        rows = np.empty((h, 1 + row_bytes), np.uint8)
        rows[:, 0] = _FILTER_UP
        np.subtract(raw[:1], above, out=rows[:1, 1:])
        np.subtract(raw[1:], raw[:-1], out=rows[1:, 1:])
        above = raw[-1].copy()
        done += h
        data = deflate.compress(rows)
        if data:
            file.writelines(_chunk(b"IDAT", data))
    if done != height:
        raise ValueError(f"the strips gave {done} rows of a {height}-row image")
    file.writelines((*_chunk(b"IDAT", deflate.flush()), *_chunk(b"IEND")))


__all__ = ["write_png", "COLOUR_CHUNKS", "LEVEL"]
