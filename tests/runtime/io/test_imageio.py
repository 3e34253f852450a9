"""Image reading/writing: formats, colour convention, channels, orientation, errors, atomic writes."""

import os
import warnings

import numpy as np
import OpenImageIO as oiio
import pytest

from svbrdf.runtime.io import images as imageio
from svbrdf.runtime.core.colour import linear_to_srgb, srgb_to_linear
from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.io.images import ImageWarning, image_info, read_image, write_image


def _write_oiio(path, arr, fmt, **attrs):
    """Write with OpenImageIO directly (to make files write_image refuses to make)."""
    h, w, c = arr.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    for k, v in attrs.items():
        spec.attribute(k, v)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(np.ascontiguousarray(arr, dtype=np.float32)), out.geterror()
    assert out.close()


@pytest.fixture
def img():
    return np.random.default_rng(0).random((13, 17, 3), dtype=np.float32)


# ---------------------------------------------------------------- round trips

@pytest.mark.parametrize(
    "ext,bits,tol,dtype",
    [
        ("png", 8, 0.5 / 255 + 1e-6, "uint8"),
        ("png", 16, 0.5 / 65535 + 1e-6, "uint16"),
        ("exr", 16, 2.5e-4, "half"),  # half: 11-bit significand, values < 1
        ("exr", 32, 0.0, "float"),
        ("tif", 8, 0.5 / 255 + 1e-6, "uint8"),
        ("tif", 16, 0.5 / 65535 + 1e-6, "uint16"),
        ("tiff", 32, 0.0, "float"),
    ],
)
def test_round_trip_raw(tmp_path, img, ext, bits, tol, dtype):
    path = write_image(tmp_path / f"a.{ext}", img, bits=bits)
    back = read_image(path, raw=True)
    assert back.shape == img.shape and back.dtype == np.float32
    assert np.abs(back - img).max() <= tol
    info = image_info(path)
    assert (info["width"], info["height"], info["channels"], info["dtype"]) == (17, 13, 3, dtype)
    assert not list(tmp_path.glob(".*"))  # no temp file left


def test_integer_files_are_decoded_from_srgb(tmp_path, img):
    path = write_image(tmp_path / "s.png", img, bits=16)  # stored codes = img
    np.testing.assert_allclose(read_image(path), srgb_to_linear(img), atol=1e-4)


def test_float_files_are_linear_raw_or_not(tmp_path, img):
    path = write_image(tmp_path / "f.exr", img * 3.0, bits=32)  # > 1 allowed in float files
    np.testing.assert_array_equal(read_image(path), img * 3.0)
    np.testing.assert_array_equal(read_image(path, raw=True), img * 3.0)


@pytest.mark.parametrize("bits,tol", [(8, 5e-3), (16, 1e-4)])
def test_srgb_encode_round_trip(tmp_path, img, bits, tol):
    path = write_image(tmp_path / "c.png", img, bits=bits, srgb_encode=True)
    # The stored codes are the sRGB encoding of the linear input ...
    q = 0.5 / (2 ** bits - 1) + 1e-6
    assert np.abs(read_image(path, raw=True) - linear_to_srgb(img)).max() <= q
    # ... and a normal read gives the linear values back.
    assert np.abs(read_image(path) - img).max() <= tol


def test_integer_write_clips(tmp_path):
    a = np.array([[-0.5, 0.25, 1.5]], np.float32)
    back = read_image(write_image(tmp_path / "c.png", a, bits=16), raw=True)
    np.testing.assert_allclose(back[..., 0], [[0.0, 0.25, 1.0]], atol=1e-5)


# ---------------------------------------------------------------- channels

@pytest.mark.parametrize("shape", [(6, 5), (6, 5, 1)])
def test_grayscale_becomes_rgb(tmp_path, shape):
    g = np.random.default_rng(1).random(shape, dtype=np.float32)
    path = write_image(tmp_path / "g.png", g, bits=16)
    assert image_info(path)["channels"] == 1
    back = read_image(path, raw=True)
    assert back.shape == (6, 5, 3)
    for c in range(3):
        np.testing.assert_allclose(back[..., c], g.reshape(6, 5), atol=1e-5)


def test_rgba_alpha_dropped_with_warning_and_not_premultiplied(tmp_path, img):
    rgba = np.concatenate([img, np.full(img.shape[:2] + (1,), 0.5, np.float32)], axis=-1)
    path = tmp_path / "rgba.png"
    _write_oiio(path, rgba, oiio.UINT16, **{"oiio:UnassociatedAlpha": 1})  # store colour as given
    with pytest.warns(ImageWarning, match="alpha"):
        back = read_image(path, raw=True)
    assert back.shape == img.shape
    np.testing.assert_allclose(back, img, atol=1e-4)  # premultiplied would be img * 0.5


def test_gray_alpha_dropped_with_warning(tmp_path, img):
    ga = np.concatenate([img[..., :1], np.full(img.shape[:2] + (1,), 0.25, np.float32)], axis=-1)
    path = tmp_path / "ga.png"
    _write_oiio(path, ga, oiio.UINT16, **{"oiio:UnassociatedAlpha": 1})
    with pytest.warns(ImageWarning, match="alpha"):
        back = read_image(path, raw=True)
    np.testing.assert_allclose(back, np.repeat(img[..., :1], 3, -1), atol=1e-4)


# ---------------------------------------------------------------- orientation

_ORIENT = {
    1: lambda a: a,
    2: lambda a: a[:, ::-1],
    3: lambda a: a[::-1, ::-1],
    4: lambda a: a[::-1],
    5: lambda a: a.transpose(1, 0, 2),
    6: lambda a: np.rot90(a, -1),  # "rotate 90 CW to display"
    7: lambda a: a[::-1, ::-1].transpose(1, 0, 2),
    8: lambda a: np.rot90(a, 1),
}


@pytest.mark.parametrize("orientation", sorted(_ORIENT))
def test_exif_orientation_tiff(tmp_path, img, orientation):
    path = tmp_path / "o.tif"
    _write_oiio(path, img, oiio.FLOAT, Orientation=orientation)
    assert image_info(path)["orientation"] == orientation
    np.testing.assert_array_equal(read_image(path), _ORIENT[orientation](img))


def test_exif_orientation_jpeg(tmp_path):
    # Blocky image so JPEG loss does not matter: a bright top-left quadrant in a 16x32 image.
    a = np.zeros((16, 32, 3), np.float32)
    a[:8, :16] = 1.0
    path = tmp_path / "o.jpg"
    _write_oiio(path, a, oiio.UINT8, Orientation=6)
    back = read_image(path, raw=True)
    assert back.shape == (32, 16, 3)
    expected = np.rot90(a, -1)  # bright quadrant now top-right
    assert np.abs(back - expected).mean() < 0.02
    assert back[:16, 8:].mean() > 0.9 and back[:16, :8].mean() < 0.1


# ---------------------------------------------------------------- read errors

def test_missing_file(tmp_path):
    with pytest.raises(ImageError, match=r"nope\.png: no such file"):
        read_image(tmp_path / "nope.png")


def test_truncated_png(tmp_path, img):
    good = write_image(tmp_path / "good.png", img, bits=8)
    data = good.read_bytes()
    bad = tmp_path / "trunc.png"
    bad.write_bytes(data[: len(data) // 2])
    with pytest.raises(ImageError, match="trunc.png: unreadable, corrupt or truncated") as exc:
        read_image(bad)
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("name", ["corrupt.png", "corrupt.exr", "corrupt.jpg"])
def test_corrupt_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(np.random.default_rng(2).integers(0, 256, 300, dtype=np.uint8).tobytes())
    with pytest.raises(ImageError, match=rf"{name}: unreadable or corrupt") as exc:
        read_image(path)
    assert "\n" not in str(exc.value)


def _photo_file(path, **attrs):
    """A textured 512 x 384 photo written by OpenImageIO (8-bit, or half for EXR) with ``attrs``; returns its
    bytes."""
    yy, xx = np.mgrid[0:384, 0:512].astype(np.float32)
    noise = np.random.default_rng(5).random((384, 512), dtype=np.float32)
    arr = np.stack([0.5 + 0.5 * np.sin(xx / 7), 0.5 + 0.5 * np.cos(yy / 5), noise], axis=-1)
    _write_oiio(path, arr, oiio.HALF if path.suffix == ".exr" else oiio.UINT8, **attrs)
    return path.read_bytes()


def _markers(data, code):
    return [i for i in range(len(data) - 1) if data[i] == 0xFF and data[i + 1] == code]


def _cut(fraction):
    return lambda data: data[: int(len(data) * fraction)]


def _first_scan_cut(data):  # a progressive JPEG cut half-way through its first scan
    first, second = _markers(data, 0xDA)[:2]
    return data[: (first + second) // 2]


def _overwrite(data, at, new):
    return data[:at] + new + data[at + len(new):]


#: name -> (file made by :func:`_photo_file`, attributes, how the file is damaged)
DAMAGED = {
    "jpeg-cut-at-35%": ("p.jpg", {}, _cut(0.35)),
    "jpeg-cut-at-80%": ("p.jpg", {}, _cut(0.8)),
    "jpeg-stray-marker-mid-scan": ("p.jpg", {}, lambda d: _overwrite(d, len(d) // 2, b"\xff\xd0\x12\x34")),
    "jpeg-broken-sos": ("p.jpg", {}, lambda d: _overwrite(d, _markers(d, 0xDA)[0] + 1, b"\x00")),
    "jpeg-broken-dht": ("p.jpg", {}, lambda d: _overwrite(d, _markers(d, 0xC4)[0] + 1, b"\x00")),
    "progressive-cut-in-first-scan": ("p.jpg", {"jpeg:progressive": 1}, _first_scan_cut),
    "progressive-cut-at-50%": ("p.jpg", {"jpeg:progressive": 1}, _cut(0.5)),
    "progressive-stray-marker-mid-scan": ("p.jpg", {"jpeg:progressive": 1},
                                          lambda d: _overwrite(d, len(d) // 2, b"\xff\xd0\x12\x34")),
    "progressive-broken-sos": ("p.jpg", {"jpeg:progressive": 1},
                               lambda d: _overwrite(d, _markers(d, 0xDA)[0] + 1, b"\x00")),
    "progressive-broken-dht": ("p.jpg", {"jpeg:progressive": 1},
                               lambda d: _overwrite(d, _markers(d, 0xC4)[0] + 1, b"\x00")),
    "png-cut-at-50%": ("p.png", {}, _cut(0.5)),
    "tiff-cut-at-50%": ("p.tif", {}, _cut(0.5)),
    "exr-cut-at-50%": ("p.exr", {}, _cut(0.5)),
}
#: the ways a file's pixels are read: whole, in reduced strips (max_size: 2 x 2 blocks) and by read_strips
READERS = {
    "whole": read_image,
    "reduced-strips": lambda path: read_image(path, max_size=256),
    "read_strips": lambda path: [s for _, s in imageio.read_strips(path, 50)],
}


@pytest.mark.filterwarnings("ignore::svbrdf.runtime.io.images.ImageWarning")  # downsized
@pytest.mark.parametrize("reader", sorted(READERS))
@pytest.mark.parametrize("damage", list(DAMAGED))
def test_damaged_files_are_refused_by_every_reader(tmp_path, damage, reader):
    """A file the reader cannot decode completely (truncated, or a broken JPEG marker or scan) is refused with one
    line naming it, whichever way its pixels are read; the undamaged file reads."""
    name, attrs, damaged = DAMAGED[damage]
    good = tmp_path / name
    data = _photo_file(good, **attrs)
    READERS[reader](good)
    bad = tmp_path / f"bad{good.suffix}"
    bad.write_bytes(damaged(data))
    with pytest.raises(ImageError, match=rf"bad{good.suffix}: unreadable(, | or )corrupt") as exc:
        READERS[reader](bad)
    assert "\n" not in str(exc.value) and str(bad) in str(exc.value)


@pytest.mark.filterwarnings("ignore::svbrdf.runtime.io.images.ImageWarning")  # downsized
def test_a_jpeg_warning_that_is_not_damage_reads_but_cannot_hide_a_truncation(tmp_path):
    """libjpeg reports only its first warning: an unknown JFIF revision (a header note, the pixels are whole) is read,
    and the same file truncated is still refused (no end-of-image marker after its last scan)."""
    data = _photo_file(tmp_path / "p.jpg")
    at = data.index(b"JFIF\x00") + 5
    odd = tmp_path / "jfif2.jpg"
    odd.write_bytes(_overwrite(data, at, b"\x02"))
    np.testing.assert_array_equal(read_image(odd), read_image(tmp_path / "p.jpg"))
    assert len(list(imageio.read_strips(odd, 50))) == 8
    cut = tmp_path / "jfif2-cut.jpg"
    cut.write_bytes(odd.read_bytes()[: len(data) // 2])
    for reader in READERS.values():
        with pytest.raises(ImageError, match="jfif2-cut.jpg: unreadable, corrupt or truncated image"):
            reader(cut)


def test_non_image_file(tmp_path):
    path = tmp_path / "notes.txt"
    path.write_text("not an image\n")
    with pytest.raises(ImageError, match="notes.txt: unsupported"):
        read_image(path)


def test_empty_file_and_directory(tmp_path):
    path = tmp_path / "empty.png"
    path.write_bytes(b"")
    with pytest.raises(ImageError, match="empty.png: empty file"):
        read_image(path)
    with pytest.raises(ImageError, match="is a directory"):
        read_image(tmp_path)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_inf_exr_refused(tmp_path, img, bad):
    a = img.copy()
    a[3, 4, 1] = bad
    path = tmp_path / "bad.exr"
    _write_oiio(path, a, oiio.HALF)
    with pytest.raises(ImageError, match="bad.exr: 1 NaN/Inf"):
        read_image(path)


def test_negative_float_clamped_with_warning(tmp_path, img):
    a = img.copy()
    a[0, 0] = -0.25
    path = tmp_path / "neg.exr"
    _write_oiio(path, a, oiio.FLOAT)
    with pytest.warns(ImageWarning, match="3 negative values clamped"):
        back = read_image(path)
    expected = img.copy()
    expected[0, 0] = 0.0
    np.testing.assert_array_equal(back, expected)


# ---------------------------------------------------------------- write safety

def test_existing_file_untouched_without_force(tmp_path, img):
    path = write_image(tmp_path / "x.png", img, bits=8)
    before = path.read_bytes()
    with pytest.raises(ImageError, match=r"x\.png: exists \(pass force=True to overwrite\)"):
        write_image(path, np.zeros((2, 2, 3), np.float32), bits=8)
    # Checked before any other work: even an invalid array reports "exists".
    with pytest.raises(ImageError, match="exists"):
        write_image(path, np.full((2, 2), np.nan), bits=8)
    assert path.read_bytes() == before
    write_image(path, np.zeros((2, 2, 3), np.float32), bits=8, force=True)
    assert read_image(path).shape == (2, 2, 3) and read_image(path).max() == 0.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.png"]


def test_temp_file_same_folder_keeps_extension_and_mode(tmp_path, img, monkeypatch):
    seen = []
    real = os.replace
    monkeypatch.setattr(imageio.os, "replace", lambda s, d: (seen.append(str(s)), real(s, d)))
    old = os.umask(0o022)
    try:
        path = write_image(tmp_path / "m.exr", img)
    finally:
        os.umask(old)
    (src,) = seen
    assert os.path.dirname(src) == str(tmp_path)
    assert os.path.basename(src).startswith(".m.tmp-") and src.endswith(".exr")
    assert not os.path.exists(src)
    assert (path.stat().st_mode & 0o777) == 0o644


def test_failed_replace_leaves_nothing(tmp_path, img, monkeypatch):
    def boom(src, dst):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(imageio.os, "replace", boom)
    with pytest.raises(ImageError, match="f.png: cannot replace"):
        write_image(tmp_path / "f.png", img)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, bits", [("w.tif", 16), ("w.exr", 32)])  # by strips; whole
def test_failed_oiio_write_leaves_nothing(tmp_path, img, monkeypatch, name, bits):
    real_create = oiio.ImageOutput.create

    class Failing:
        def __init__(self, out):
            self.out = out

        def open(self, *a):
            return self.out.open(*a)

        def write_image(self, *a):
            return False

        def write_scanlines(self, *a):  # the integer formats are written strip by strip
            return False

        def geterror(self):
            return "disk full\nsecond line"

        def close(self):
            return self.out.close()

    class FakeImageOutput:
        @staticmethod
        def create(name):
            return Failing(real_create(name))

    monkeypatch.setattr(imageio.oiio, "ImageOutput", FakeImageOutput)
    with pytest.raises(ImageError, match=rf"{name}: write failed \(disk full\)$"):
        write_image(tmp_path / name, img, bits=bits)
    assert list(tmp_path.iterdir()) == []


def test_failed_png_write_leaves_nothing(tmp_path, img, monkeypatch):
    def full_disk(file, *args):
        file.write(b"\x89PNG")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(imageio, "write_png", full_disk)
    with pytest.raises(ImageError, match=r"w.png: write failed \(No space left on device\)$"):
        write_image(tmp_path / "w.png", img)
    assert list(tmp_path.iterdir()) == []


def test_write_argument_errors(tmp_path, img):
    with pytest.raises(ImageError, match="unsupported output format '.bmp'"):
        write_image(tmp_path / "a.bmp", img)
    with pytest.raises(ImageError, match="does not exist"):
        write_image(tmp_path / "no" / "a.png", img)
    with pytest.raises(ImageError, match="shape"):
        write_image(tmp_path / "a.png", np.zeros((4, 4, 2), np.float32))
    with pytest.raises(ImageError, match="shape"):
        write_image(tmp_path / "a.png", np.zeros((0, 4, 3), np.float32))
    with pytest.raises(ImageError, match="NaN/Inf"):
        write_image(tmp_path / "a.exr", np.full((2, 2), np.inf, np.float32))
    with pytest.raises(ValueError, match="bits"):
        write_image(tmp_path / "a.png", img, bits=32)
    with pytest.raises(ValueError, match="bits"):
        write_image(tmp_path / "a.exr", img, bits=8)
    with pytest.raises(ValueError, match="srgb_encode"):
        write_image(tmp_path / "a.exr", img, srgb_encode=True)
    with pytest.raises(ValueError, match="colour_space"):
        write_image(tmp_path / "a.png", img, colour_space="ACEScg")
    assert list(tmp_path.iterdir()) == []


def test_write_leaves_the_callers_array_alone(tmp_path):
    arr = np.linspace(-0.5, 1.5, 4 * 5 * 4, dtype=np.float32).reshape(4, 5, 4)
    before = arr.copy()
    write_image(tmp_path / "a.png", arr, bits=16, srgb_encode=True)
    np.testing.assert_array_equal(arr, before)


# ---------------------------------------------------------------- reduced reads (max_size)
def _big_photo(h, w, seed=0):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    smooth = 0.5 + 0.4 * np.sin(xx[..., None] / 37.0 + np.array([0.0, 1.0, 2.0])) * np.cos(yy[..., None] / 53.0)
    return np.clip(smooth + rng.normal(0, 0.02, (h, w, 3)), 0, 1).astype(np.float32)


@pytest.mark.parametrize("shape,max_size", [((300, 500), 100), ((301, 517), 64), ((90, 700), 128)])
def test_strip_read_matches_full_read_then_resize(tmp_path, monkeypatch, shape, max_size):
    """Files >= 2x max_size are read in strips of block means; the result is the full read's downsizing up to a
    little extra smoothing, at the same size, with the same warning."""
    path = tmp_path / "big.png"
    write_image(path, _big_photo(*shape), bits=16, srgb_encode=True)
    monkeypatch.setattr(imageio, "STRIP_BYTES", 4096)  # many strips, a partial last one
    with pytest.warns(ImageWarning, match=rf"downsized from {shape[1]}x{shape[0]} to"):
        small = read_image(path, max_size=max_size)
    full = imageio.resize_long_side(read_image(path), max_size)
    assert small.shape == full.shape and max(small.shape[:2]) == max_size
    assert small.min() >= 0.0
    assert np.abs(small - full).mean() < 0.01 and np.abs(small - full).max() < 0.1


def test_strip_read_block_means_are_exact(tmp_path, monkeypatch):
    """An exact 4x reduction (k = 4, no final resize) is the mean of each 4 x 4 block, partial blocks included."""
    a = _big_photo(40, 64)
    path = tmp_path / "f.exr"
    write_image(path, a, bits=32)
    monkeypatch.setattr(imageio, "STRIP_BYTES", 3000)
    with pytest.warns(ImageWarning, match="downsized"):
        small = read_image(path, max_size=16)
    assert small.shape == (10, 16, 3)
    np.testing.assert_allclose(small, a.reshape(10, 4, 16, 4, 3).mean(axis=(1, 3)), atol=1e-6)


def test_strip_read_applies_orientation_and_drops_alpha_once(tmp_path, img):
    big = np.concatenate([_big_photo(64, 128), np.ones((64, 128, 1), np.float32)], axis=-1)
    path = tmp_path / "o.tif"
    _write_oiio(path, big, oiio.FLOAT, Orientation=6)
    with pytest.warns(ImageWarning) as record:
        small = read_image(path, max_size=32)
    assert small.shape == (32, 16, 3)  # displayed 64 wide, 128 tall
    assert sum("alpha" in str(w.message) for w in record) == 1
    np.testing.assert_allclose(small, np.rot90(big[..., :3].reshape(16, 4, 32, 4, 3).mean(axis=(1, 3)), -1),
                               atol=1e-6)


def test_small_files_are_not_downsized_or_warned(tmp_path, img):
    path = tmp_path / "s.png"
    write_image(path, img, bits=16)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = read_image(path, max_size=max(img.shape[:2]))
    assert out.shape == img.shape


@pytest.mark.parametrize("dtype,oiio_type", [(np.uint8, "uint8"), (np.uint16, "uint16")])
@pytest.mark.parametrize("raw", [False, True])
def test_integer_files_decode_through_the_code_table_bit_for_bit(tmp_path, dtype, oiio_type, raw):
    """read_image looks each code of an 8/16-bit file up in a table (issue 54); the reference is the per-pixel
    path it replaced: OpenImageIO's float conversion, clip, srgb_to_linear (unless raw). Equal, not close."""
    import OpenImageIO as oiio

    from svbrdf.runtime.core.colour import srgb_to_linear
    from svbrdf.runtime.io.images import read_image

    rng = np.random.default_rng(7)
    top = np.iinfo(dtype).max
    codes = rng.integers(0, top + 1, (37, 53, 3)).astype(dtype)
    codes[0, :3, 0] = (0, 1, top)
    path = tmp_path / "codes.png"
    buf = oiio.ImageBuf(oiio.ImageSpec(53, 37, 3, oiio_type))
    buf.set_pixels(oiio.ROI(), codes)
    assert buf.write(str(path))
    inp = oiio.ImageInput.open(str(path))
    as_float = np.clip(np.asarray(inp.read_image(0, 0, 0, 3, oiio.FLOAT), np.float32), 0.0, 1.0)
    inp.close()
    expected = as_float if raw else srgb_to_linear(as_float)
    got = read_image(path, raw=raw)
    assert got.dtype == np.float32 and np.array_equal(got, expected)


@pytest.mark.parametrize("bits,srgb", [(8, False), (8, True), (16, False)])
def test_integer_writes_quantise_as_openimageio_does(tmp_path, bits, srgb, monkeypatch):
    """write_image quantises in numpy, strip by strip (issue 54); the reference is what it did before: hand
    OpenImageIO's PNG writer the whole clipped (sRGB-encoded) float array and let it convert. The same codes,
    including values exactly half-way between two codes (where ImageBuf.get_pixels, another conversion, can
    round up where the writer rounds to even)."""
    top = 255 if bits == 8 else 65535
    kind = oiio.UINT8 if bits == 8 else oiio.UINT16
    rng = np.random.default_rng(11)
    a = rng.random((97, 101, 3), dtype=np.float32) * 1.2 - 0.1
    a[0, :, 0] = (np.arange(101, dtype=np.float32) + 0.5) / top  # exactly half-way between two codes
    monkeypatch.setattr(imageio, "QUANTISE_STRIP_BYTES", 101 * 3 * 4 * 7)  # strips of 7 rows
    write_image(tmp_path / "q.png", a, bits=bits, srgb_encode=srgb)
    ref = np.clip(a, 0.0, 1.0)
    if srgb:
        ref = np.clip(linear_to_srgb(ref), 0.0, 1.0)
    out = oiio.ImageOutput.create(str(tmp_path / "ref.png"))
    assert out.open(str(tmp_path / "ref.png"), oiio.ImageSpec(101, 97, 3, kind)) and out.write_image(ref)
    out.close()
    read = []
    for name in ("q.png", "ref.png"):
        inp = oiio.ImageInput.open(str(tmp_path / name))
        read.append(inp.read_image(0, 0, 0, 3, kind))
        inp.close()
    assert np.array_equal(read[0], read[1])


@pytest.mark.parametrize("ext, bits", [(".png", 16), (".exr", 32)])
def test_a_transform_is_applied_strip_by_strip_as_a_full_copy_would_be(tmp_path, monkeypatch, ext, bits):
    """``write_image(transform=)`` gives the file of ``write_image(transform(arr))`` in strips of a few rows (no
    full-size copy), and refuses a transform that changes a strip's shape."""
    import svbrdf.runtime.io.images as images

    rng = np.random.default_rng(7)
    a = rng.uniform(-0.5, 1.5, (37, 11, 3)).astype(np.float32)
    f = lambda s: np.clip(s * 0.5 + 0.25, 0.0, 1.0)  # noqa: E731
    write_image(tmp_path / f"full{ext}", f(a), bits=bits)
    monkeypatch.setattr(images, "QUANTISE_STRIP_BYTES", 5 * 11 * 3 * 4)  # 5 rows per strip
    write_image(tmp_path / f"strips{ext}", a, bits=bits, transform=f)
    np.testing.assert_array_equal(read_image(tmp_path / f"strips{ext}", raw=True),
                                  read_image(tmp_path / f"full{ext}", raw=True))
    with pytest.raises(ValueError, match="shape"):
        write_image(tmp_path / f"bad{ext}", a, bits=bits, transform=lambda s: s[:, :5])
    assert not (tmp_path / f"bad{ext}").exists()


# ---------------------------------------------------------------- strip by strip (read_strips)
@pytest.mark.parametrize("kind", ["png8", "png16", "exr", "grey", "rgba"])
@pytest.mark.parametrize("rows", [1, 7, 64, 500])
def test_read_strips_is_read_image_in_strips(tmp_path, kind, rows):
    from svbrdf.runtime.io.images import read_strips

    photo = _big_photo(53, 71, seed=4)
    if kind == "png8":
        path = write_image(tmp_path / "p.png", photo, bits=8, srgb_encode=True)
    elif kind == "png16":
        path = write_image(tmp_path / "p.png", photo, bits=16, srgb_encode=True)
    elif kind == "exr":
        path = write_image(tmp_path / "p.exr", photo * 2.0, bits=32)
    elif kind == "grey":
        path = tmp_path / "g.png"
        _write_oiio(path, photo[..., :1], oiio.UINT16)
    else:
        path = tmp_path / "a.png"
        _write_oiio(path, np.concatenate([photo, np.ones_like(photo[..., :1])], axis=-1), oiio.UINT8)
    with warnings.catch_warnings(record=True) as whole_warnings:
        warnings.simplefilter("always")
        whole = read_image(path)
    with warnings.catch_warnings(record=True) as strip_warnings:
        warnings.simplefilter("always")
        strips = list(read_strips(path, rows))
    assert [y0 for y0, _ in strips] == list(range(0, 53, rows))
    assert all(s.dtype == np.float32 and s.shape[1:] == (71, 3) for _, s in strips)
    np.testing.assert_array_equal(np.concatenate([s for _, s in strips]), whole)
    assert [str(w.message) for w in strip_warnings] == [str(w.message) for w in whole_warnings]


def test_read_strips_refuses_what_it_cannot_read(tmp_path, img):
    from svbrdf.runtime.io.images import read_strips

    rotated = tmp_path / "r.tif"
    _write_oiio(rotated, img, oiio.FLOAT, Orientation=6)
    with pytest.raises(ValueError, match="orientation"):
        list(read_strips(rotated, 4))
    good = write_image(tmp_path / "good.png", _big_photo(64, 80), bits=8)
    with pytest.raises(ValueError, match="rows"):
        list(read_strips(good, 0))
    bad = tmp_path / "trunc.png"
    bad.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(ImageError, match="trunc.png: unreadable, corrupt or truncated"):
        list(read_strips(bad, 8))
    first = next(iter(read_strips(good, 8)))  # a caller that stops early: the file is closed, nothing hangs
    assert first[0] == 0 and first[1].shape == (8, 80, 3)
