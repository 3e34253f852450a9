"""Running ``svbrdf-preview`` from Blender: a subprocess, polled without blocking (plain Python, no bpy).

Blender's Python has neither numpy nor svbrdf, so the add-on never imports them: it runs the ``svbrdf-preview``
executable of an svbrdf installation (found on ``PATH`` or given in the add-on's preferences) with
``--target blender`` and reads the texture set it writes. :class:`PreviewRun` starts the process and is polled
(the add-on's modal operator polls it on a timer, so the interface stays live and the status bar shows the
command's progress lines); :func:`run_preview` is the same, synchronous (headless Blender, scripts, tests).

Every failure is a :class:`~.sets.SetError` with one line for the artist: the executable not found, the photo
missing, or the command's own error line (``svbrdf-preview: error: <message>``: a photo that cannot be read, an
existing set without overwrite, ``--refine`` without torch).
"""

from __future__ import annotations

import collections
import os
import shutil
import subprocess
import threading
import time

from .sets import SetError

#: The command's name, looked up on ``PATH`` when the preferences give no path.
EXECUTABLE = "svbrdf-preview"
_ERROR_MARK = "error: "


def find_executable(preference: str = "") -> str:
    """The ``svbrdf-preview`` to run: ``preference`` (a path set in the add-on's preferences) when given, else the one
    on ``PATH``.

    Raises:
        SetError: the preference is not an executable file, or there is none on ``PATH``.
    """
    preference = (preference or "").strip()
    if preference:
        path = os.path.abspath(os.path.expanduser(preference))
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
        raise SetError(f"svbrdf-preview not found at {path} (the svbrdf add-on's preferences): set the path of the "
                       f"svbrdf-preview of your svbrdf installation, e.g. .venv/bin/svbrdf-preview")
    found = shutil.which(EXECUTABLE)
    if found is None:
        raise SetError("svbrdf-preview is not on PATH: install svbrdf (pip install svbrdf) and set the path of its "
                       "svbrdf-preview in the svbrdf add-on's preferences")
    return found


def output_folder(photo, out_dir: str = "") -> str:
    """Where the set of ``photo`` goes: ``out_dir`` when given, else ``<photo folder>/<photo name>_svbrdf``
    (``svbrdf-preview``'s own default)."""
    photo = os.path.abspath(os.fspath(photo))
    if out_dir:
        return os.path.abspath(os.path.expanduser(out_dir))
    stem = os.path.splitext(os.path.basename(photo))[0]
    return os.path.join(os.path.dirname(photo), f"{stem}_svbrdf")


def preview_command(executable: str, photo, out_dir: str, *, tileable: bool = False, refine: bool = False,
                    overwrite: bool = False, threads: int = 0) -> list:
    """The command line: ``svbrdf-preview PHOTO -o OUT --target blender [--tileable] [--refine] [--force]``."""
    cmd = [executable, os.path.abspath(os.fspath(photo)), "-o", out_dir, "--target", "blender"]
    if tileable:
        cmd.append("--tileable")
    if refine:
        cmd.append("--refine")
    if overwrite:
        cmd.append("--force")
    if threads:
        cmd += ["--threads", str(int(threads))]
    return cmd


def _child_env() -> dict:
    """The environment of the command: Blender's own Python settings taken out (the command runs its own Python)."""
    env = dict(os.environ)
    for key in ("PYTHONHOME", "PYTHONPATH", "PYTHONSTARTUP", "PYTHONNOUSERSITE"):
        env.pop(key, None)
    return env


class PreviewRun:
    """One ``svbrdf-preview`` run for one photo, started at once and polled.

    Attributes:
        photo: the photo (absolute path).
        out_dir: the output folder (:func:`output_folder`).
        sidecar: the sidecar the run writes, ``<out_dir>/<photo name>.json``.
        command: the command line (:func:`preview_command`).
        started: ``time.monotonic()`` at the start.
    """

    def __init__(self, executable: str, photo, out_dir: str = "", **options):
        photo = os.path.abspath(os.fspath(photo))
        if not os.path.isfile(photo):
            raise SetError(f"photo not found: {photo}")
        self.photo = photo
        self.out_dir = output_folder(photo, out_dir)
        stem = os.path.splitext(os.path.basename(photo))[0]
        self.sidecar = os.path.join(self.out_dir, f"{stem}.json")
        self.command = preview_command(executable, photo, self.out_dir, **options)
        self._lines = collections.deque(maxlen=200)
        self.started = time.monotonic()
        try:
            self._proc = subprocess.Popen(self.command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                          stdin=subprocess.DEVNULL, env=_child_env(), text=True, errors="replace",
                                          bufsize=1)
        except OSError as exc:
            raise SetError(f"cannot run {executable}: {exc.strerror or exc}")
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self._proc.stdout:  # progress lines, the result line, error lines
            for part in line.replace("\r", "\n").splitlines():
                if part.strip():
                    self._lines.append(part.strip())
        self._proc.stdout.close()

    def poll(self):
        """The exit code once the command ended (its output read), else ``None``."""
        code = self._proc.poll()
        if code is None:
            return None
        self._reader.join(timeout=5)
        return code

    @property
    def status(self) -> str:
        """One line for the status bar: the elapsed time and the command's latest line."""
        last = self._lines[-1] if self._lines else "starting"
        return f"svbrdf: {time.monotonic() - self.started:.0f} s, {last[:160]}"

    def error(self) -> str:
        """The one-line reason of a failed run (the command's error line, else its last line and exit code)."""
        for line in reversed(self._lines):
            if _ERROR_MARK in line and line.startswith(EXECUTABLE):
                return line.split(_ERROR_MARK, 1)[1].replace("use --force to overwrite",
                                                             "tick Overwrite to replace it")
        code = self._proc.poll()
        last = self._lines[-1] if self._lines else "no output"
        return f"svbrdf-preview failed (exit code {code}): {last}"

    def result(self) -> str:
        """The sidecar of the finished run; :class:`SetError` (one line) when the run failed or wrote no set."""
        code = self.poll()
        if code is None:
            raise SetError("svbrdf-preview is still running")
        if code != 0:
            raise SetError(self.error())
        if not os.path.isfile(self.sidecar):
            raise SetError(f"svbrdf-preview wrote no texture set at {self.sidecar}")
        return self.sidecar

    def cancel(self) -> None:
        """Stop the command (the writer is all or nothing: no half set is left)."""
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()


def run_preview(executable: str, photo, out_dir: str = "", timeout: float = 3600.0, **options) -> str:
    """Run ``svbrdf-preview`` on ``photo`` to the end (see :class:`PreviewRun` for the arguments) and return the
    sidecar of the set it wrote; :class:`SetError` on any failure or after ``timeout`` seconds."""
    run = PreviewRun(executable, photo, out_dir, **options)
    end = time.monotonic() + timeout
    while run.poll() is None:
        if time.monotonic() > end:
            run.cancel()
            raise SetError(f"svbrdf-preview took more than {timeout:.0f} s on {photo}; stopped")
        time.sleep(0.05)
    return run.result()


__all__ = ["PreviewRun", "run_preview", "find_executable", "output_folder", "preview_command", "EXECUTABLE"]
