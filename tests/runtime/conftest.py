"""A tiny exported preview model shared by the session and CLI tests (exported once per test session)."""

import warnings
from pathlib import Path

import pytest

#: Field of view stored in the tiny model's training config (not the default 66), to see it travel.
TINY_FOV = 50.0


def read_stored(path):
    """Every channel of an image file as stored (value / max), alpha unassociated: what a DCC tool (Blender's image
    node, Substance, Unreal) reads."""
    import numpy as np
    import OpenImageIO as oiio

    cfg = oiio.ImageSpec()
    cfg.attribute("oiio:UnassociatedAlpha", 1)
    inp = oiio.ImageInput.open(str(path), cfg)
    assert inp is not None, oiio.geterror()
    try:
        return np.asarray(inp.read_image(oiio.FLOAT), dtype=np.float32)
    finally:
        inp.close()


@pytest.fixture(scope="session")
def tiny_model(tmp_path_factory) -> Path:
    """``tiny.onnx`` + ``tiny.json`` + ``tiny.pt`` (random tiny generator, exported from a checkpoint).

    Exporting needs torch and onnxscript (the ``train`` extra); tests using this fixture skip without them.
    """
    torch = pytest.importorskip("torch")
    pytest.importorskip("onnxscript")
    from svbrdf.export.onnx import export_generator
    from svbrdf.trainer.checkpoint import build_checkpoint, save_checkpoint
    from svbrdf.trainer.config import resolve
    from svbrdf.trainer.models import Generator

    folder = tmp_path_factory.mktemp("tiny_model")
    config = resolve("tiny", fov_deg=TINY_FOV)
    torch.manual_seed(0)
    generator = Generator(config.generator)
    ckpt = build_checkpoint(generator=generator, discriminator=None, train_config=config.to_dict(),
                            stage="pretrain", step=7, iters=7,
                            photo={"name": "train.png", "sha256": "0" * 64, "height": 64, "width": 64})
    save_checkpoint(folder / "tiny.pt", ckpt)
    with warnings.catch_warnings():  # torch.export's own deprecation noise
        warnings.simplefilter("ignore", FutureWarning)
        export_generator(folder / "tiny.pt", folder / "tiny.onnx", sizes=((32, 32),))
    return folder / "tiny.onnx"


# ---------------------------------------------------------------------------------------- headless browsers
# The drivers (standard library only) are tests/support/browser.py's, not the package's; a browser test skips when
# its browser is absent or cannot start. CI gets them as Debian packages when it can (apt-get install chromium
# firefox-esr).


def _browser_module():
    """tests/support/browser.py, loaded by path (the tests are not a package; --import-mode=importlib)."""
    import importlib.util
    import sys

    name = "svbrdf_tests_support_browser"
    if name not in sys.modules:
        path = Path(__file__).resolve().parents[1] / "support" / "browser.py"
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def _start_browser(kind, profile, **kwargs):
    """The headless browser ``kind`` (``"chromium"`` or ``"firefox"``) in the new profile folder, or skip."""
    browser = _browser_module()
    BROWSERS, find_browser = browser.BROWSERS, browser.find_browser

    names, env, cls = BROWSERS[kind]
    exe = find_browser(kind)
    if exe is None:
        pytest.skip(f"no {kind} found (tried ${env}, {', '.join(names)}); e.g. apt-get install {names[0]}")
    try:
        return cls(exe, profile, **kwargs)
    except (OSError, RuntimeError, TimeoutError) as exc:
        pytest.skip(f"{exe} did not start headless ({exc})")


@pytest.fixture
def chromium_path():
    """The path of headless Chromium's executable (for a plain command line), or skip."""
    exe = _browser_module().find_browser("chromium")
    if exe is None:
        pytest.skip("no chromium found; e.g. apt-get install chromium")
    return exe


@pytest.fixture(scope="module", params=["chromium", "firefox"])
def browser(request, tmp_path_factory):
    """Each headless browser in turn, one page (a test using it runs once per browser; each skips on its own, also
    when the browser gives pages no WebGL 2 here, e.g. without Mesa's EGL and software driver)."""
    b = _start_browser(request.param, tmp_path_factory.mktemp(f"{request.param}-profile"))
    if not b.evaluate("!!document.createElement('canvas').getContext('webgl2')"):
        b.close()
        pytest.skip(f"{request.param} offers no WebGL 2 here (e.g. apt-get install libegl-mesa0 libgl1-mesa-dri)")
    yield b
    b.close()


@pytest.fixture
def start_browser(tmp_path):
    """``start_browser(kind, **options)``: a browser of the test's own (e.g. Firefox with other ``prefs``), closed
    after the test."""
    started = []

    def start(kind, **kwargs):
        started.append(_start_browser(kind, tmp_path / f"{kind}-profile", **kwargs))
        return started[-1]

    yield start
    for b in started:
        b.close()


@pytest.fixture(scope="module")
def session(tiny_model):
    """A one-thread preview session of :func:`tiny_model` (one per test module)."""
    from svbrdf.runtime.inference.session import load_session

    return load_session(tiny_model, threads=1)


@pytest.fixture
def flash_plane():
    """``flash_plane(path, fov, light=None, n=256, seed=0)``: a textured diffuse plane rendered with fall-off at
    ``fov`` (the flash above the centre or at ``light``), written as an 8-bit sRGB PNG (or a JPEG by its suffix);
    returns ``path``."""
    import numpy as np

    from svbrdf.runtime.core.maps import Maps
    from svbrdf.runtime.core.render import ZHAO, physical_config, render
    from svbrdf.runtime.io.images import write_image

    def make(path, fov, light=None, n=256, seed=0):
        rng = np.random.default_rng(seed)
        noise = rng.normal(0.0, 1.0, (n // 8, n // 8, 1)).repeat(8, 0).repeat(8, 1)
        maps = Maps(diffuse=np.clip(np.array([0.45, 0.3, 0.2]) * np.exp(0.3 * noise), 0, 1).astype(np.float32),
                    specular=np.zeros((n, n, 1), np.float32), roughness=np.full((n, n, 1), 0.5, np.float32),
                    normal=np.dstack([np.zeros((n, n, 2)), np.ones((n, n, 1))]).astype(np.float32))
        img = render(maps, light, physical_config(ZHAO.replace(fov_deg=fov)))
        write_image(path, np.clip(img / np.percentile(img, 99.5) * 0.9, 0, 1).astype(np.float32), bits=8,
                    srgb_encode=True)
        return path

    return make


@pytest.fixture
def small_flash_photo():
    """``small_flash_photo(h=40, w=56, seed=3)``: a small linear flash photo (a striped material brighter under a
    Gaussian highlight, a little noise), float32 [0, 1]."""
    import numpy as np

    def make(h=40, w=56, seed=3):
        rng = np.random.default_rng(seed)
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        base = 0.3 + 0.1 * np.sin(xx / 3.0)[..., None] * np.array([1.0, 0.8, 0.6], np.float32)
        flash = 0.6 * np.exp(-((yy - h / 2) ** 2 + (xx - w / 2) ** 2) / (2 * 8.0 ** 2))[..., None]
        return (base + flash + rng.normal(0, 0.01, (h, w, 3))).clip(0, 1).astype(np.float32)

    return make

