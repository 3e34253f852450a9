"""The PNG encoder (runtime/io/png.py), read back by OpenImageIO (libpng, which checks every CRC and the zlib
stream's checksum)."""

import io

import numpy as np
import OpenImageIO as oiio
import pytest

from svbrdf.runtime.io.png import write_png


def _codes(shape, bits, seed=0):
    rng = np.random.default_rng(seed)
    return rng.integers(0, 2 ** bits, shape, dtype=np.uint16 if bits == 16 else np.uint8)


def _write(path, codes, bits, colour_space=None, rows=7):
    h, w, c = codes.shape
    with open(path, "wb") as f:
        write_png(f, (codes[y:y + rows] for y in range(0, h, rows)), w, h, c, bits, colour_space)
    return path


def _read(path):
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)  # alpha as stored, the colour not premultiplied
    buf = oiio.ImageBuf(str(path), 0, 0, config)
    assert not buf.has_error, buf.geterror()
    spec = buf.spec()
    pixels = buf.get_pixels(spec.format)
    assert not buf.has_error, buf.geterror()
    return pixels, spec


@pytest.mark.parametrize("bits", [8, 16])
@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("rows", [1, 7, 64])
def test_codes_read_back_exactly(tmp_path, bits, channels, rows):
    codes = _codes((37, 53, channels), bits)
    codes[5:9] = codes[4]  # rows equal to the row above: the "up" filter's zeros
    pixels, spec = _read(_write(tmp_path / "a.png", codes, bits, rows=rows))
    assert (spec.width, spec.height, spec.nchannels) == (53, 37, channels)
    assert spec.format == (oiio.UINT16 if bits == 16 else oiio.UINT8)
    np.testing.assert_array_equal(pixels.reshape(codes.shape), codes)


@pytest.mark.parametrize("shape", [(1, 1, 3), (1, 300, 3), (300, 1, 1)])
def test_one_pixel_wide_or_high(tmp_path, shape):
    codes = _codes(shape, 16, seed=1)
    pixels, _ = _read(_write(tmp_path / "a.png", codes, 16, rows=64))
    np.testing.assert_array_equal(pixels.reshape(shape), codes)


@pytest.mark.parametrize("colour_space, read_as", [("sRGB", "srgb"), ("linear", "lin"), (None, "srgb")])
def test_colour_space_tags(tmp_path, colour_space, read_as):
    """The tags OpenImageIO's own PNG writer gave the maps (an untagged PNG reads as sRGB, as the format says)."""
    _, spec = _read(_write(tmp_path / "a.png", _codes((4, 5, 3), 8), 8, colour_space))
    assert spec.get_string_attribute("oiio:ColorSpace").lower().startswith(read_as)


def test_uniform_map_is_small(tmp_path):
    """A uniform map (the preview's specular: one level per photo) is coded with matches: under 1 % of its bytes,
    where a Huffman-only coding cannot go under 1/8 (one bit a byte)."""
    flat = np.full((512, 512, 3), 4825, np.uint16)
    path = _write(tmp_path / "a.png", flat, 16, "linear", rows=100)
    assert path.stat().st_size < flat.nbytes / 100
    np.testing.assert_array_equal(_read(path)[0], flat)


def test_bad_arguments():
    codes = _codes((4, 5, 3), 16)
    for args in [(5, 4, 5, 16), (5, 4, 3, 12), (0, 4, 3, 16), (5, 0, 3, 16)]:
        with pytest.raises(ValueError, match="cannot write"):
            write_png(io.BytesIO(), [codes], *args)
    with pytest.raises(ValueError, match="colour space"):
        write_png(io.BytesIO(), [codes], 5, 4, 3, 16, "ACES")
    with pytest.raises(ValueError, match="does not fit"):
        write_png(io.BytesIO(), [codes], 6, 4, 3, 16)  # wrong width
    with pytest.raises(ValueError, match="does not fit"):
        write_png(io.BytesIO(), [codes, codes], 5, 6, 3, 16)  # too many rows
    with pytest.raises(ValueError, match="gave 4 rows"):
        write_png(io.BytesIO(), [codes], 5, 5, 3, 16)  # too few
    with pytest.raises(ValueError, match="2-byte codes"):
        write_png(io.BytesIO(), [codes.astype(np.uint8)], 5, 4, 3, 16)
