"""A tiny exported preview model shared by the session and CLI tests (exported once per test session)."""

import warnings
from pathlib import Path

import pytest

#: Field of view stored in the tiny model's training config (not the default 66), to see it travel.
TINY_FOV = 50.0


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


# ------------------------------------------------------------------------------------------ headless Chromium

#: Browser executables tried in order ($SVBRDF_CHROMIUM first); the browser tests skip when none is found.
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")


def find_chromium():
    """Path of a Chromium-family browser, or None ($SVBRDF_CHROMIUM, then the names above on $PATH)."""
    import os
    import shutil

    env = os.environ.get("SVBRDF_CHROMIUM")
    if env:
        return env if shutil.which(env) or os.path.isfile(env) else None
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    return None


class Chromium:
    """Headless Chromium driven over the DevTools protocol through a pipe (``--remote-debugging-pipe``: JSON
    messages separated by NUL bytes on file descriptors 3 and 4), with the standard library only: no network, no
    websocket, no driver package. One page (tab); ``call`` sends a command and returns its result."""

    def __init__(self, executable, profile, width=1400, height=900):
        import os
        import subprocess

        to_child_r, self._w = os.pipe()
        self._r, from_child_w = os.pipe()

        def fds():  # in the child: the pipe ends as fds 3 (commands in) and 4 (replies out)
            a, b = os.dup(to_child_r), os.dup(from_child_w)
            os.dup2(a, 3)
            os.dup2(b, 4)

        args = [executable, "--headless", "--remote-debugging-pipe", "--no-sandbox", "--no-first-run",
                "--no-default-browser-check", "--disable-extensions", "--disable-background-networking",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--hide-scrollbars",
                f"--user-data-dir={profile}", f"--window-size={width},{height}", "about:blank"]
        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, close_fds=False, preexec_fn=fds)
        os.close(to_child_r)
        os.close(from_child_w)
        self._buf = b""
        self._id = 0
        self.events = []
        target = self.call("Target.createTarget", url="about:blank")["targetId"]
        self.session = self.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        self.call("Page.enable", session=True)
        self.call("Emulation.setDeviceMetricsOverride", session=True, width=width, height=height,
                  deviceScaleFactor=1, mobile=False)

    def _read(self, timeout):
        import json
        import os
        import select
        import time

        end = time.monotonic() + timeout
        while b"\0" not in self._buf:
            left = end - time.monotonic()
            if left <= 0 or not select.select([self._r], [], [], left)[0]:
                raise TimeoutError("no reply from Chromium")
            chunk = os.read(self._r, 1 << 20)
            if not chunk:
                raise RuntimeError("Chromium closed the pipe")
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def call(self, method, session=False, timeout=60.0, **params):
        import json
        import os

        self._id += 1
        msg = {"id": self._id, "method": method, "params": params}
        if session:
            msg["sessionId"] = self.session
        os.write(self._w, json.dumps(msg).encode() + b"\0")
        while True:
            reply = self._read(timeout)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_event(self, method, timeout=60.0):
        for i, ev in enumerate(self.events):
            if ev.get("method") == method:
                return self.events.pop(i)
        while True:
            ev = self._read(timeout)
            if ev.get("method") == method:
                return ev
            self.events.append(ev)

    def open(self, url):
        self.events.clear()
        self.call("Page.navigate", session=True, url=url)
        self.wait_event("Page.loadEventFired")

    def evaluate(self, expression, timeout=60.0):
        """The value of a JavaScript expression in the page (promises awaited); JavaScript errors raise."""
        result = self.call("Runtime.evaluate", session=True, timeout=timeout, expression=expression,
                           awaitPromise=True, returnByValue=True)
        if "exceptionDetails" in result:
            details = result["exceptionDetails"]
            raise RuntimeError(details.get("exception", {}).get("description") or details.get("text"))
        return result["result"].get("value")

    def screenshot(self):
        """A PNG of the page's viewport (bytes)."""
        import base64

        return base64.b64decode(self.call("Page.captureScreenshot", session=True, format="png")["data"])

    def close(self):
        import os
        import subprocess

        try:
            self.call("Browser.close", timeout=10)
        except Exception:
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for fd in (self._r, self._w):
            try:
                os.close(fd)
            except OSError:
                pass


@pytest.fixture(scope="module")
def chromium(tmp_path_factory):
    """A headless Chromium page (:class:`Chromium`); skips when no browser is found or it cannot start."""
    exe = find_chromium()
    if exe is None:
        pytest.skip(f"no Chromium found (tried $SVBRDF_CHROMIUM, {', '.join(CHROMIUM_NAMES)}); "
                    "e.g. apt-get install chromium")
    try:
        browser = Chromium(exe, tmp_path_factory.mktemp("chromium-profile"))
    except (OSError, RuntimeError, TimeoutError) as exc:
        pytest.skip(f"{exe} did not start headless ({exc})")
    yield browser
    browser.close()
