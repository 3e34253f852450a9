"""Stress: awkward image files through ``read_image``, the preview session (``estimate``) and ``svbrdf-preview``.

Every file is either handled correctly (right shape, linear values as the colour convention says, valid maps) or
refused with a one-line :class:`~svbrdf.runtime.errors.SvbrdfError`; nothing crashes, nothing half-written.
Files are written with OpenImageIO directly, so this covers files the project itself would never write (NaN,
Inf, negative floats, grey + alpha, 1 x 1 ...).
"""

import re
import warnings

import numpy as np
import OpenImageIO as oiio
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from svbrdf.runtime.core.colour import srgb_to_linear
from svbrdf.runtime.errors import ImageError, SvbrdfError
from svbrdf.runtime.io.images import ImageWarning, read_image
from svbrdf.runtime.inference.manifest import MIN_SIZE

pytest.importorskip("onnxruntime")
from svbrdf.runtime.cli.preview import main  # noqa: E402
from svbrdf.runtime.inference.pipeline import estimate

STRESS = settings(max_examples=40, deadline=None, derandomize=True,
                  suppress_health_check=[HealthCheck.too_slow])
ERR = "svbrdf-preview: error: "

#: name -> (extension, OpenImageIO type, float file?)
FORMATS = {
    "png8": (".png", oiio.UINT8, False),
    "png16": (".png", oiio.UINT16, False),
    "tif16": (".tif", oiio.UINT16, False),
    "exr-half": (".exr", oiio.HALF, True),
    "exr-float": (".exr", oiio.FLOAT, True),
    "tif-float": (".tif", oiio.FLOAT, True),
}
CHANNEL_NAMES = {1: ["Y"], 2: ["Y", "A"], 3: ["R", "G", "B"], 4: ["R", "G", "B", "A"]}
#: Contents any file can hold, and those only a float file can hold.
CONTENTS = ("black", "white", "noise", "highlight")
FLOAT_CONTENTS = ("hdr", "negative", "nan", "inf")


def _content(kind: str, h: int, w: int, c: int, seed: int = 0) -> np.ndarray:
    """(h, w, c) float32 pixel values as stored in the file (integer files: [0, 1] before quantisation)."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    blob = np.exp(-((yy - h / 2) ** 2 + (xx - w / 2) ** 2) / (0.1 * max(h, w) ** 2 + 1))[..., None]
    tex = 0.15 + 0.1 * rng.random((h, w, c))
    if kind == "black":
        arr = np.zeros((h, w, c))
    elif kind == "white":  # fully clipped
        arr = np.ones((h, w, c))
    elif kind == "noise":
        arr = rng.random((h, w, c))
    elif kind == "highlight":  # a flash highlight clipped at 1 in the middle of a texture
        arr = np.clip(tex + 3.0 * blob, 0.0, 1.0)
    elif kind == "hdr":  # an unclipped linear highlight, up to 1e4 (within half range)
        arr = tex + 1e4 * blob**4
    elif kind == "negative":  # some negatives, as a noisy float render can have
        arr = rng.normal(0.2, 0.3, (h, w, c))
    elif kind in ("nan", "inf"):
        arr = tex.copy()
        arr[h // 2, w // 2, 0] = np.nan if kind == "nan" else np.inf
    else:
        raise AssertionError(kind)
    return arr.astype(np.float32)


def _write(path, arr, fmt):
    """Write ``arr`` as stored values with OpenImageIO (straight alpha, no colour conversion)."""
    h, w, c = arr.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    spec.channelnames = tuple(CHANNEL_NAMES[c])
    if "A" in CHANNEL_NAMES[c]:
        spec.alpha_channel = c - 1
        spec.attribute("oiio:UnassociatedAlpha", 1)
    out = oiio.ImageOutput.create(str(path))
    assert out is not None and out.open(str(path), spec), oiio.geterror()
    assert out.write_image(np.ascontiguousarray(arr)), out.geterror()
    assert out.close()
    return path


def _expected(stored: np.ndarray, fmt, is_float: bool) -> np.ndarray:
    """What read_image must return for ``stored``: (H, W, 3) linear, as the module docstring specifies."""
    colour = stored[..., :1] if stored.shape[-1] <= 2 else stored[..., :3]
    colour = np.repeat(colour, 3 // colour.shape[-1], axis=-1).astype(np.float64)
    if is_float:
        if fmt == oiio.HALF:
            colour = colour.astype(np.float16).astype(np.float64)
        return np.maximum(colour, 0.0)
    top = 255 if fmt == oiio.UINT8 else 65535
    return srgb_to_linear(np.round(np.clip(colour, 0, 1) * top) / top)


def _assert_valid_maps(maps, shape):
    assert maps.shape == shape
    for name, arr in maps.items():
        assert np.isfinite(arr).all(), name
    for name in ("diffuse", "specular", "roughness"):
        arr = getattr(maps, name)
        assert arr.min() >= 0 and arr.max() <= 1, name
    np.testing.assert_allclose(np.linalg.norm(maps.normal, axis=-1), 1.0, atol=1e-5)


# ------------------------------------------------------------------------------ read_image + estimate
@STRESS
@given(
    h=st.integers(1, 24),
    w=st.integers(1, 40),
    fmt_name=st.sampled_from(sorted(FORMATS)),
    channels=st.sampled_from([1, 2, 3, 4]),
    content=st.sampled_from(CONTENTS + FLOAT_CONTENTS),
    seed=st.integers(0, 2**16),
)
@example(h=1, w=1, fmt_name="png8", channels=3, content="white", seed=0)
@example(h=5, w=7, fmt_name="png16", channels=1, content="noise", seed=0)
@example(h=8, w=8, fmt_name="exr-float", channels=4, content="hdr", seed=0)
@example(h=8, w=8, fmt_name="exr-half", channels=3, content="nan", seed=0)
@example(h=9, w=13, fmt_name="exr-float", channels=3, content="negative", seed=0)
def test_any_file_is_read_correctly_or_refused(session, tmp_path_factory, h, w, fmt_name, channels, content,
                                               seed):
    ext, fmt, is_float = FORMATS[fmt_name]
    if content in FLOAT_CONTENTS and not is_float:
        content = "noise"
    stored = _content(content, h, w, channels, seed)
    path = _write(tmp_path_factory.mktemp("img") / f"photo{ext}", stored, fmt)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if content in ("nan", "inf"):
            with pytest.raises(ImageError, match="NaN/Inf") as err:
                read_image(path)
            assert str(path) in str(err.value) and "\n" not in str(err.value)
            with pytest.raises(ImageError, match="NaN/Inf"):
                estimate(path, session)
            return
        image = read_image(path)
    messages = [str(w.message) for w in caught if issubclass(w.category, ImageWarning)]
    assert image.shape == (h, w, 3) and image.dtype == np.float32
    assert np.isfinite(image).all() and image.min() >= 0
    want = _expected(stored, fmt, is_float)
    np.testing.assert_allclose(image, want, rtol=1e-5, atol=1e-4)
    assert any("alpha channel dropped" in m for m in messages) == (channels in (2, 4))
    assert any("negative values clamped" in m for m in messages) == bool(is_float and (stored < 0).any())

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImageWarning)
        if min(h, w) < MIN_SIZE:
            with pytest.raises(ImageError, match=f"{w}x{h} pixels; the model needs at least 8x8") as err:
                estimate(path, session)
            assert str(path) in str(err.value)
            return
        maps = estimate(path, session)
    _assert_valid_maps(maps, (h, w))


@pytest.mark.parametrize("h,w", [(8, 600), (600, 8), (8, 8), (9, 200)])
def test_thin_images_run_in_one_pass_and_in_tiles(session, h, w):
    photo = _content("highlight", h, w, 3)
    whole = estimate(photo, session)
    _assert_valid_maps(whole, (h, w))
    tiled = estimate(photo, session, tile=64, overlap=16)
    _assert_valid_maps(tiled, (h, w))
    assert (tiled.meta["tiles"] > 1) == (max(h, w) > 64)


def test_downsizing_below_the_minimum_is_refused(session):
    with pytest.raises(ImageError, match="600x8 downsized to 300x4 is below 8 px; raise max_size"):
        estimate(_content("noise", 8, 600, 3), session, max_size=300)


@pytest.mark.parametrize("value", [3.0e38, -3.0e38, 1e30, 65504.0])
def test_extreme_finite_float_values_give_valid_maps_or_a_clear_error(session, tmp_path, value):
    """Finite but absurd float photos (near the float32 limit): valid maps or a one-line SvbrdfError, never
    NaN maps handed back silently."""
    stored = _content("highlight", 16, 16, 3)
    stored[4:12, 4:12] = value
    path = _write(tmp_path / "extreme.exr", stored, oiio.FLOAT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImageWarning)
        try:
            maps = estimate(path, session)
        except SvbrdfError as exc:
            msg = str(exc)
            assert str(path) in msg and "\n" not in msg
            return
    _assert_valid_maps(maps, (16, 16))


# ------------------------------------------------------------------------------ svbrdf-preview
#: file name -> (stored content, format, exit status of the photo, substring of the error line)
CLI_CASES = {
    "black.png": (_content("black", 16, 16, 3), oiio.UINT8, None),
    "white16.png": (_content("white", 12, 20, 3), oiio.UINT16, None),
    "noise_rgba.png": (_content("noise", 16, 24, 4), oiio.UINT8, None),
    "grey16.tif": (_content("highlight", 20, 16, 1), oiio.UINT16, None),
    "grey_alpha.png": (_content("highlight", 16, 16, 2), oiio.UINT8, None),
    "wide.png": (_content("highlight", 8, 600, 3), oiio.UINT8, None),
    "negative.exr": (_content("negative", 16, 16, 3), oiio.FLOAT, None),
    "hdr.exr": (_content("hdr", 16, 16, 3), oiio.HALF, None),
    "one.png": (_content("white", 1, 1, 3), oiio.UINT8, "1x1 pixels; the model needs at least 8x8"),
    "small.png": (_content("noise", 5, 7, 3), oiio.UINT8, "7x5 pixels; the model needs at least 8x8"),
    "nan.exr": (_content("nan", 16, 16, 3), oiio.FLOAT, "NaN/Inf"),
    "inf.exr": (_content("inf", 16, 16, 3), oiio.HALF, "NaN/Inf"),
}


def test_cli_batch_of_awkward_files(tiny_model, tmp_path, capsys):
    src = tmp_path / "photos"
    src.mkdir()
    paths = {name: _write(src / name, arr, fmt) for name, (arr, fmt, _) in CLI_CASES.items()}
    out_dir = tmp_path / "out"
    code = main([*map(str, paths.values()), "--model", str(tiny_model), "-o", str(out_dir), "--threads", "1"])
    out, err = capsys.readouterr()
    assert code == 1
    assert "Traceback" not in err
    errors = [ln for ln in err.splitlines() if ln.startswith(ERR)]
    warning_lines = [ln for ln in err.splitlines() if ln.startswith("svbrdf-preview: warning: ")]
    progress = [ln for ln in err.splitlines() if re.match(r"svbrdf-preview: \d+/\d+ \[", ln)]  # the batch's
    assert len(errors) + len(warning_lines) + len(progress) == len(err.splitlines())  # nothing else on stderr
    bad = {name: msg for name, (_, _, msg) in CLI_CASES.items() if msg}
    assert len(errors) == len(bad)
    for name, msg in bad.items():
        line = [ln for ln in errors if name in ln]
        assert len(line) == 1 and line[0].startswith(f"{ERR}{paths[name]}: ") and msg in line[0], (name, errors)
        assert not list(out_dir.glob(f"{paths[name].stem}*"))  # nothing written for a refused photo
    assert len(out.splitlines()) == len(CLI_CASES) - len(bad)
    for name in set(CLI_CASES) - set(bad):
        stem = paths[name].stem
        assert stem in out
        h, w = CLI_CASES[name][0].shape[:2]
        for suffix in ("basecolor", "normal", "roughness", "specular"):
            back = read_image(out_dir / f"{stem}_{suffix}.png", raw=True)
            assert back.shape == (h, w, 3) and np.isfinite(back).all(), (name, suffix)
    assert any("noise_rgba.png: alpha channel dropped" in ln for ln in warning_lines)
    assert any("negative.exr" in ln and "negative values clamped" in ln for ln in warning_lines)
    assert not list(out_dir.glob(".*"))  # no temporary file left behind
