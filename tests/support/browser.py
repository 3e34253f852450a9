"""Headless browsers for checking and photographing the project's pages, with the standard library only.

Two drivers with the same small interface (``open(url)``, ``evaluate(expression)``, ``screenshot()``,
``close()``), used by ``tests/runtime/outputs/test_viewer.py`` and ``git show bc3896e:./docs/images/scripts/viewer_screenshots.py``:

* :class:`Chromium`: the DevTools protocol over a pipe (``--remote-debugging-pipe``), no network at all; WebGL
  through ANGLE's SwiftShader (software).
* :class:`Firefox`: Marionette (Firefox's built-in remote protocol, ``--marionette``) on a free port of
  127.0.0.1, in a fresh temporary profile. Headless Firefox on a machine without a GPU refuses WebGL unless it is
  told otherwise: the profile sets ``webgl.force-enabled`` and the process gets ``MOZ_WEBGL_FORCE_EGL=1``
  (headless has no X display, so GLX cannot serve; Mesa's EGL gives llvmpipe). Measured with Firefox ESR 153 and
  Mesa 22.3 on Debian 12: without the pref WebGL 2 fails with "AllowWebgl2:false", without the variable with
  "Exhausted GL driver options".

A browser's plain screenshot (``chromium --headless --screenshot``, ``firefox --headless --screenshot``) captures
at the load event; the viewer draws before it (its maps are inflated synchronously), so such a screenshot shows the
relit views. These drivers are for reading pixels and driving the page.

No driver package and no browser download: the executables are looked up on ``$PATH`` (:func:`find_browser`).
"""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import socket
import subprocess
import time
from pathlib import Path
from typing import Optional

#: Executables tried in order after $SVBRDF_CHROMIUM / $SVBRDF_FIREFOX.
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable", "chrome")
FIREFOX_NAMES = ("firefox-esr", "firefox")

__all__ = ["CHROMIUM_NAMES", "FIREFOX_NAMES", "BROWSERS", "find_browser", "Chromium", "Firefox"]


def find_browser(kind: str) -> Optional[str]:
    """Path of the browser ``kind`` (a key of :data:`BROWSERS`), or None: its environment variable (a name or a
    path) when set, else the first of its names on $PATH."""
    names, env, _ = BROWSERS[kind]
    value = os.environ.get(env)
    if value:
        return shutil.which(value) or (value if os.path.isfile(value) else None)
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    return None


def _stop(proc: subprocess.Popen, timeout: float = 10.0) -> None:
    try:
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


class Chromium:
    """Headless Chromium driven over the DevTools protocol through a pipe (``--remote-debugging-pipe``: JSON
    messages separated by NUL bytes on file descriptors 3 and 4), with the standard library only: no network, no
    websocket, no driver package. One page (tab); ``call`` sends a command and returns its result."""

    def __init__(self, executable, profile, width=1400, height=900):
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
        result = self.call("Page.navigate", session=True, url=url)
        if result.get("errorText"):
            raise RuntimeError(f"{url}: {result['errorText']}")
        if result.get("loaderId"):  # none for a navigation within the document (another #fragment)
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
        return base64.b64decode(self.call("Page.captureScreenshot", session=True, format="png")["data"])

    def close(self):
        try:
            self.call("Browser.close", timeout=10)
        except Exception:
            pass
        _stop(self.proc)
        for fd in (self._r, self._w):
            try:
                os.close(fd)
            except OSError:
                pass


#: Preferences of the temporary Firefox profile: Marionette on a free port, WebGL on a software driver, and
#: nothing that reaches for the network or asks a question at start.
FIREFOX_PREFS = {
    "marionette.port": 0,
    "webgl.force-enabled": True,
    "browser.shell.checkDefaultBrowser": False,
    "browser.startup.homepage_override.mstone": "ignore",
    "browser.aboutwelcome.enabled": False,
    "datareporting.policy.dataSubmissionEnabled": False,
    "toolkit.telemetry.reportingpolicy.firstRun": False,
    "app.update.disabledForTesting": True,
    "app.normandy.enabled": False,
    "extensions.update.enabled": False,
    "network.captive-portal-service.enabled": False,
    "network.connectivity-service.enabled": False,
    "browser.safebrowsing.update.enabled": False,
    "browser.tabs.warnOnClose": False,
}


class Firefox:
    """Headless Firefox driven over Marionette (messages ``<length>:<JSON>`` on a TCP socket of 127.0.0.1; the
    port Firefox picked is in ``<profile>/MarionetteActivePort``). ``profile`` must be a new, empty folder: the
    prefs (:data:`FIREFOX_PREFS`, then ``prefs``) go into its ``user.js``. ``width`` x ``height`` is the size of
    the page's viewport (the window is grown by its own frame to get it)."""

    def __init__(self, executable, profile, width=1400, height=900, prefs=None, timeout=60.0):
        profile = Path(profile)
        profile.mkdir(parents=True, exist_ok=True)
        lines = [f"user_pref({json.dumps(k)}, {json.dumps(v)});" for k, v in {**FIREFOX_PREFS, **(prefs or {})}.items()]
        (profile / "user.js").write_text("\n".join(lines) + "\n", encoding="utf-8")
        env = dict(os.environ, MOZ_HEADLESS="1", MOZ_WEBGL_FORCE_EGL="1", MOZ_CRASHREPORTER_DISABLE="1")
        self.log = profile / "firefox.log"
        with open(self.log, "wb") as log:
            self.proc = subprocess.Popen([executable, "--headless", "--marionette", "-no-remote", "-profile",
                                          str(profile), f"--window-size={width},{height}", "about:blank"],
                                         stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT, env=env)
        self._buf = b""
        self._id = 0
        self.timeout = timeout
        try:
            self._sock = socket.create_connection(("127.0.0.1", self._port(profile, timeout)), timeout=timeout)
            hello = self._read()
            if hello.get("marionetteProtocol") != 3:
                raise RuntimeError(f"unexpected Marionette greeting {hello}")
            self.call("WebDriver:NewSession", capabilities={})
            self.call("WebDriver:SetTimeouts", script=int(timeout * 1000), pageLoad=int(timeout * 1000))
            self._viewport(width, height)
        except BaseException:
            self.proc.kill()
            self.proc.wait()
            raise

    def _port(self, profile, timeout):
        path, end = profile / "MarionetteActivePort", time.monotonic() + timeout
        while True:
            text = path.read_text().strip() if path.exists() else ""
            if text:
                return int(text)
            if self.proc.poll() is not None:
                raise RuntimeError(f"Firefox exited ({self.proc.returncode}) before Marionette listened")
            if time.monotonic() > end:
                raise TimeoutError("Marionette did not start")
            time.sleep(0.1)

    def _read(self):
        while b":" not in self._buf:
            self._recv()
        size, rest = self._buf.split(b":", 1)
        self._buf = rest
        while len(self._buf) < int(size):
            self._recv()
        msg, self._buf = self._buf[:int(size)], self._buf[int(size):]
        return json.loads(msg)

    def _recv(self):
        try:
            chunk = self._sock.recv(1 << 20)
        except socket.timeout:
            raise TimeoutError("no reply from Firefox") from None
        if not chunk:
            raise RuntimeError("Firefox closed the connection")
        self._buf += chunk

    def call(self, command, **params):
        """Send a Marionette command; its result (``{"value": ...}`` for most), or RuntimeError with its error."""
        self._id += 1
        data = json.dumps([0, self._id, command, params]).encode()
        self._sock.sendall(str(len(data)).encode() + b":" + data)
        while True:
            kind, mid, error, result = self._read()
            if kind == 1 and mid == self._id:
                if error:
                    raise RuntimeError(f"{command}: {error.get('error')}: {error.get('message')}")
                return result

    def _viewport(self, width, height):
        inner = self.evaluate("[window.innerWidth, window.innerHeight]")
        rect = self.call("WebDriver:GetWindowRect")
        if inner != [width, height]:
            self.call("WebDriver:SetWindowRect", width=rect["width"] + width - inner[0],
                      height=rect["height"] + height - inner[1])

    def open(self, url):
        self.call("WebDriver:Navigate", url=url)

    def evaluate(self, expression):
        """The value of a JavaScript expression in the page (promises awaited); JavaScript errors raise."""
        return self.call("WebDriver:ExecuteScript", script=f"return ({expression});", args=[])["value"]

    def screenshot(self):
        """A PNG of the page's viewport (bytes)."""
        return base64.b64decode(self.call("WebDriver:TakeScreenshot", full=False, hash=False)["value"])

    def close(self):
        try:
            self.call("Marionette:Quit", flags=["eAttemptQuit"])
        except Exception:
            pass
        try:
            self._sock.close()
        except OSError:
            pass
        _stop(self.proc)


#: kind -> (executable names, environment variable naming the executable, driver class).
BROWSERS = {"chromium": (CHROMIUM_NAMES, "SVBRDF_CHROMIUM", Chromium),
            "firefox": (FIREFOX_NAMES, "SVBRDF_FIREFOX", Firefox)}
