"""One photo's work in a batch (:func:`run_job`): the same function whichever engine runs it, in a worker.

It gets the photo's bytes and the options, runs the per-photo pipeline
(:func:`svbrdf.runtime.workflow.photo.process_photo` with the
:class:`~svbrdf.runtime.workflow.options.PhotoOptions` the driver recorded), writes the texture set (and, with
``view``, its viewer page) into a private temporary folder and returns the files' bytes with the scores.
"""

from __future__ import annotations

import functools
import shutil
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, Optional

from .. import __version__
from ..errors import SvbrdfError

PROG = "svbrdf-batch"

__all__ = ["Job", "run_job"]


@dataclass
class Job:
    """One photo's work, sent to a worker (picklable).

    Attributes:
        name: texture set name in the library.
        source: the photo's path, as recorded (for messages and the sidecar).
        sha256: the photo's content hash.
        data: the photo file's bytes (so that a Ray worker needs no shared file system).
        options: :func:`library_options`.
        model: ``--model`` as given (None: the worker's own lookup; its sha256 must match ``options``).
        threads: CPU threads of this job (onnxruntime, torch).
        quiet: no per-photo progress (True in pool and Ray workers).
        error: why the driver could not read the photo (the job then fails at once).
    """

    name: str
    source: str
    sha256: str
    data: bytes
    options: Dict[str, Any]
    model: Optional[str] = None
    threads: int = 1
    quiet: bool = True
    error: Optional[str] = None


_SESSIONS: Dict[tuple, Any] = {}  # per worker process: (model, threads, maps) -> PreviewSession


def _session(model: Optional[str], threads: int, maps: tuple):
    from ..inference.session import load_session

    key = (model, threads, maps)
    if key not in _SESSIONS:
        _SESSIONS[key] = load_session(model, threads=threads, maps=maps)
    return _SESSIONS[key]


def _one_line(exc: BaseException) -> str:
    from ..errors import cli_message

    text = str(exc) if isinstance(exc, SvbrdfError) else f"{type(exc).__name__}: {exc}"
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return cli_message(lines[0] if lines else type(exc).__name__)[:300]


def run_job(job: Job) -> Dict[str, Any]:
    """Make one photo's texture set (the per-photo function of every engine; runs in a worker).

    Returns:
        ``{"name", "status": "done", "files": {file name: bytes}, "thumb": PNG bytes, "scores": {"rerender_rmse",
        "burn_in"}, "timings": {"total", ...}, "size": [H, W], "detail", "warnings": [line, ...]}``, or
        ``{"name", "status": "failed", "error": one line, "timings"}``. Never raises for a bad photo.
    """
    start = time.perf_counter()
    if job.error is not None:
        return {"name": job.name, "status": "failed", "error": job.error, "timings": {}}
    opts = job.options
    tmp = Path(tempfile.mkdtemp(prefix="svbrdf-batch-"))
    photo = tmp / f"{job.name}{Path(job.source).suffix}"

    def clean(text: str) -> str:  # name the user's photo, not the worker's copy
        return text.replace(str(photo), job.source)

    try:
        from ..core.render import rerender_rmse
        from ..inference.guided import Upsampling
        from ..inference.refine import load_refine
        from ..io.images import read_image
        from ..io.process import processed_pixels, reuse_memory, small_pages
        from ..workflow.options import PhotoOptions
        from ..workflow.photo import process_photo
        from ..workflow.write import write_maps

        small_pages()  # the worker's process, as svbrdf-preview's
        options = PhotoOptions.from_mapping({**opts, "maps": tuple(opts["maps"])}).replace(
            force=False, quiet=job.quiet, threads=job.threads, model=job.model,
            upsampling=Upsampling(network_size=opts.get("network_size")))
        photo.write_bytes(job.data)
        try:
            reuse_memory(processed_pixels(photo, options.max_size))  # the worker's process, per photo
        except SvbrdfError:  # an unreadable photo: process_photo says so
            pass
        session = _session(job.model, job.threads, options.maps)
        if session.info.sha256 != opts["model_sha256"]:
            raise SvbrdfError(f"this worker's model {session.info.path} (sha256 {session.info.sha256[:12]}) is not "
                              f"the driver's ({opts['model_sha256'][:12]}); install the same model on every node")
        config = options.render_config(session)
        refine = load_refine() if options.refine else None
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            maps, relit, detail = process_photo(photo, options, session, config, refine,
                                                name=Path(job.source).name, later=True)  # relief beside the writes
            if callable(relit):  # rendered once: for the set's files, then for the thumbnail
                relit = functools.cache(relit)
            maps.meta["source"] = job.source
        with warnings.catch_warnings():  # the photo again, for the scores: its warnings were said above
            warnings.simplefilter("ignore")
            image = read_image(photo, max_size=options.max_size)
        scores = {"burn_in": float(maps.meta["burn_in"]["burn_in"]),
                  "rerender_rmse": float(rerender_rmse(maps, image, [None], config)) if maps.complete else None}
        extra = {"tool": f"{PROG} {__version__} (svbrdf-preview per photo)",
                 "batch": {"sha256": job.sha256, "options": opts, "scores": scores}}
        out = tmp / "set"
        write_maps(maps, relit, out, job.name, options, extra)
        from ..io.images import write_image
        from ..outputs.contact_sheet import strip

        write_image(tmp / "thumb.png", strip(image, maps, relit() if callable(relit) else relit), bits=8,
                    colour_space="sRGB")
        return {"name": job.name, "status": "done", "files": {p.name: p.read_bytes() for p in sorted(out.iterdir())},
                "thumb": (tmp / "thumb.png").read_bytes(), "scores": scores, "size": list(maps.shape),
                "detail": detail, "warnings": [clean(str(w.message)) for w in caught],
                "timings": {"total": time.perf_counter() - start, **maps.meta.get("timings", {})}}
    except Exception as exc:  # one bad photo: reported by the driver, the batch goes on
        return {"name": job.name, "status": "failed", "error": clean(_one_line(exc)),
                "timings": {"total": time.perf_counter() - start}}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
