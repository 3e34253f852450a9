"""A material library: many flash photos -> one texture set each, resumable, on a local process pool or Ray.

Layout of a library folder::

    LIBRARY/library.json        the manifest (MANIFEST_FILE): one record per photo, written only by the driver
    LIBRARY/<name>/             one texture set per photo, as svbrdf-preview writes it (any --target; with
                                --tileable maps that repeat without a seam; with --view its <name>_view.html)
    LIBRARY/thumbs/<name>.png   a strip of small views: photo, four maps, relit (contact_sheet.STRIP_VIEWS)
    LIBRARY/index.html, index.png   the contact sheet (:mod:`svbrdf.runtime.contact_sheet`; a "view" link per
                                    material that has a viewer page)

The work of one photo is :func:`run_job`, the same function whichever engine runs it: it gets the photo's bytes
and the options, runs the per-photo path of ``svbrdf-preview`` (:func:`svbrdf.runtime.cli.photo_maps`), writes
the texture set (and, with ``--view``, its viewer page, :func:`svbrdf.runtime.viewer.write_viewer`) into a private
temporary folder and returns the files' bytes with the scores. Only the driver
(:func:`run_batch`) writes into the library: each set is staged in ``LIBRARY/.staging/`` and renamed into place
in one step, then the manifest is rewritten atomically (:func:`svbrdf.runtime.files.atomic_write`). So a killed
run loses at most the photos in flight, never leaves half a set, and never corrupts the manifest; a set renamed
into place just before the kill is adopted on the next run (its sidecar records the photo's hash and options).

A photo is done when its record and its set's sidecar hold its content hash and the same options
(:data:`OPTION_KEYS`, :func:`same_options`); an option added to :data:`OPTION_KEYS` later takes its value in
:data:`OPTION_DEFAULTS` where an older library's records lack it, so a library written before ``--tileable`` and
``--view`` is not redone by a run without them.
"""

from __future__ import annotations

import argparse
import glob
import hashlib
import json
import os
import secrets
import shutil
import sys
import tempfile
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, Iterator, List, Mapping, Optional, Sequence, Tuple

from . import __version__
from .errors import OVERWRITE_HINT, MissingExtraError, SvbrdfError, exists_message

PROG = "svbrdf-batch"
#: The manifest's file name in the library folder, and its format version.
MANIFEST_FILE = "library.json"
MANIFEST_VERSION = 1
#: Folder of the contact sheet's strips; no texture set takes this name.
THUMBS = "thumbs"
STAGING = ".staging"
LOCK_FILE = ".svbrdf-batch.lock"
#: Extensions taken from a folder given as input (case-insensitive).
PHOTO_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr", ".hdr", ".bmp", ".webp")
#: The options of :func:`svbrdf.runtime.cli.add_texture_options` that change a texture set (recorded per photo;
#: a done photo is redone only when they or the photo change).
OPTION_KEYS = ("refine", "quality", "iters", "target", "maps", "normal", "format", "max_size", "tile", "fov",
               "tileable", "view")
#: The options added to :data:`OPTION_KEYS` after libraries were first written, with the value a record that
#: lacks them was made with (:func:`same_options`).
OPTION_DEFAULTS = {"tileable": False, "view": False}


def collect_photos(items: Iterable[str]) -> List[Path]:
    """The photos named by ``items``: files, folders (their photo files, :data:`PHOTO_SUFFIXES`, sorted, not
    recursive), glob patterns (sorted matches) and list files ``@list.txt`` (one item per line, relative to the
    list's folder; blank lines and ``#`` comments skipped). Duplicates (same resolved path) are kept once, first
    place. A named file that does not exist is kept (it fails as a bad photo).

    Raises:
        SvbrdfError: an unreadable list file, a folder with no photos, a pattern with no match, or no photos at all.
    """
    out: Dict[str, Path] = {}

    def add(path: Path) -> None:
        out.setdefault(str(path.resolve()), path)

    def visit(item: str, base: Optional[Path]) -> None:
        if item.startswith("@"):
            listing = Path(item[1:]) if base is None else base / item[1:]
            try:
                lines = listing.read_text(encoding="utf-8").splitlines()
            except (OSError, UnicodeDecodeError) as exc:
                raise SvbrdfError(f"{listing}: cannot read the list ({getattr(exc, 'strerror', None) or exc})") \
                    from None
            for line in lines:
                line = line.strip()
                if line and not line.startswith("#"):
                    visit(line, listing.parent)
            return
        path = Path(item) if base is None or Path(item).is_absolute() else base / item
        if path.is_dir():
            found = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in PHOTO_SUFFIXES)
            if not found:
                raise SvbrdfError(f"{path}: no photos in this folder ({', '.join(PHOTO_SUFFIXES)})")
            for p in found:
                add(p)
        elif not path.exists() and glob.has_magic(str(path)):
            found = sorted(Path(p) for p in glob.glob(str(path)) if Path(p).is_file())
            if not found:
                raise SvbrdfError(f"{path}: no file matches")
            for p in found:
                add(p)
        else:
            add(path)

    for item in items:
        visit(str(item), None)
    if not out:
        raise SvbrdfError("no photos given")
    return list(out.values())


def sha256_file(path: Path) -> str:
    """Hex sha256 of a file's content."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _base_name(path: Path) -> str:
    name = path.stem.replace(os.sep, "_").replace("/", "_").lstrip(".") or "photo"
    return name


def library_names(photos: Sequence[Path], known: Mapping[str, str]) -> Dict[Path, str]:
    """The texture set name of each photo: the name ``known`` gives its resolved path (an earlier run), else its
    file stem, with ``-2``, ``-3``, ... added in the order of ``photos`` when the stem is taken (by another photo
    of this run or of the library, or :data:`THUMBS`). Deterministic for a given order and library."""
    used = set(known.values()) | {THUMBS}
    names: Dict[Path, str] = {}
    for p in photos:
        name = known.get(str(p.resolve()))
        if name is not None:
            names[p] = name
    for p in photos:
        if p in names:
            continue
        base = _base_name(p)
        name, k = base, 2
        while name in used:
            name, k = f"{base}-{k}", k + 1
        used.add(name)
        names[p] = name
    return names


def library_options(args: argparse.Namespace, model_sha256: str) -> Dict[str, Any]:
    """What makes a texture set (:data:`OPTION_KEYS` of ``args`` plus the model's sha256), JSON-ready; ``args``
    without a key of :data:`OPTION_DEFAULTS` gets its default."""
    opts = {k: getattr(args, k, OPTION_DEFAULTS[k]) if k in OPTION_DEFAULTS else getattr(args, k)
            for k in OPTION_KEYS}
    opts["maps"] = list(opts["maps"])
    opts["model_sha256"] = model_sha256
    return opts


def same_options(recorded: Any, options: Mapping[str, Any]) -> bool:
    """Whether the options ``recorded`` for a set (manifest or sidecar; possibly from an older version, without
    the keys of :data:`OPTION_DEFAULTS`) are ``options`` (:func:`library_options`)."""
    return isinstance(recorded, dict) and {**OPTION_DEFAULTS, **recorded} == {**OPTION_DEFAULTS, **options}


# ----------------------------------------------------------------------------------------------- the worker side

def _top_up(pending: Dict[Any, "Job"], jobs: Iterator["Job"], capacity: int, submit: Callable[["Job"], Any]) -> bool:
    """Submit jobs (``pending[submit(job)] = job``) until ``capacity`` are in flight; True once ``jobs`` ran out."""
    while len(pending) < capacity:
        job = next(jobs, None)
        if job is None:
            return True
        pending[submit(job)] = job
    return False


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
    from .session import load_session

    key = (model, threads, maps)
    if key not in _SESSIONS:
        _SESSIONS[key] = load_session(model, threads=threads, maps=maps)
    return _SESSIONS[key]


def _one_line(exc: BaseException) -> str:
    from .errors import cli_message

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
    args = argparse.Namespace(**opts, force=False, quiet=job.quiet, threads=job.threads)
    args.maps = tuple(opts["maps"])
    tmp = Path(tempfile.mkdtemp(prefix="svbrdf-batch-"))
    photo = tmp / f"{job.name}{Path(job.source).suffix}"

    def clean(text: str) -> str:  # name the user's photo, not the worker's copy
        return text.replace(str(photo), job.source)

    try:
        from .cli import PROG as PREVIEW, _load_refine, photo_maps, write_maps
        from .imageio import read_image
        from .render import rerender_rmse

        photo.write_bytes(job.data)
        session = _session(job.model, job.threads, args.maps)
        if session.info.sha256 != opts["model_sha256"]:
            raise SvbrdfError(f"this worker's model {session.info.path} (sha256 {session.info.sha256[:12]}) is not "
                              f"the driver's ({opts['model_sha256'][:12]}); install the same model on every node")
        config = session.render_config if args.fov is None else session.render_config.replace(fov_deg=args.fov)
        refine = _load_refine() if args.refine else None
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            maps, relit, detail = photo_maps(photo, session, config, args, refine, name=Path(job.source).name)
            maps.meta["source"] = job.source
        with warnings.catch_warnings():  # the photo again, for the scores: its warnings were said above
            warnings.simplefilter("ignore")
            image = read_image(photo, max_size=args.max_size)
        scores = {"burn_in": float(maps.meta["burn_in"]["burn_in"]),
                  "rerender_rmse": float(rerender_rmse(maps, image, [None], config)) if maps.complete else None}
        extra = {"tool": f"{PROG} {__version__} ({PREVIEW} per photo)",
                 "batch": {"sha256": job.sha256, "options": opts, "scores": scores}}
        out = tmp / "set"
        write_maps(maps, relit, out, job.name, args, extra)
        from .contact_sheet import strip

        from .imageio import write_image
        write_image(tmp / "thumb.png", strip(image, maps, relit), bits=8, colour_space="sRGB")
        return {"name": job.name, "status": "done", "files": {p.name: p.read_bytes() for p in sorted(out.iterdir())},
                "thumb": (tmp / "thumb.png").read_bytes(), "scores": scores, "size": list(maps.shape),
                "detail": detail, "warnings": [clean(str(w.message)) for w in caught],
                "timings": {"total": time.perf_counter() - start, **maps.meta.get("timings", {})}}
    except Exception as exc:  # one bad photo: reported by the driver, the batch goes on
        return {"name": job.name, "status": "failed", "error": clean(_one_line(exc)),
                "timings": {"total": time.perf_counter() - start}}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


# ------------------------------------------------------------------------------------------------------ engines

def plan_workers(cores: int, workers: Optional[int], threads: Optional[int], gpu: bool = False) -> Tuple[int, int]:
    """``(workers, threads per worker)`` of the local pool: ``--workers`` and ``--threads`` when given, the other
    one from the cores (``cores // workers`` threads, ``cores // threads`` workers); by default one thread per
    core-worker, or one worker with every core when the refine runs on a GPU (one photo at a time)."""
    cores = max(1, cores)
    if workers and threads:
        return workers, threads
    if workers:
        return workers, max(1, cores // workers)
    if threads:
        return max(1, cores // threads), threads
    return (1, cores) if gpu else (cores, 1)


class LocalEngine:
    """Runs jobs in this process (``workers == 1``) or in a pool of ``workers`` spawned processes."""

    def __init__(self, workers: int):
        self.workers = workers
        self.capacity = 1 if workers == 1 else 2 * workers
        self._pool = None

    def __enter__(self) -> "LocalEngine":
        return self

    def _new_pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        # spawn, not fork: onnxruntime's and torch's thread pools do not survive a fork.
        return ProcessPoolExecutor(self.workers, mp_context=multiprocessing.get_context("spawn"))

    def run(self, jobs: Iterator[Job]) -> Iterator[Tuple[Job, Dict[str, Any]]]:
        """Yield ``(job, result)`` as jobs finish, keeping at most :attr:`capacity` in flight."""
        if self.workers == 1:
            for job in jobs:
                yield job, run_job(job)
            return
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        self._pool = self._new_pool()
        pending: Dict[Any, Job] = {}
        jobs = iter(jobs)
        exhausted = False
        while True:
            exhausted = exhausted or _top_up(pending, jobs, self.capacity, lambda j: self._pool.submit(run_job, j))
            if not pending:
                return
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            broken = False
            for fut in finished:
                job = pending.pop(fut)
                try:
                    result = fut.result()
                except BrokenProcessPool:
                    broken = True
                    result = _died(job, "a worker process died (out of memory?)")
                except Exception as exc:  # the job could not be sent or its result not returned
                    result = _died(job, _one_line(exc))
                yield job, result
            if broken:  # every job in flight is lost with the pool: report them, go on with a new pool
                for fut, job in pending.items():
                    yield job, _died(job, "a worker process died (out of memory?)")
                pending.clear()
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = self._new_pool()

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=exc[0] is None, cancel_futures=True)


def _died(job: Job, why: str) -> Dict[str, Any]:
    return {"name": job.name, "status": "failed", "error": f"{job.source}: {why}", "timings": {}}


def _import_ray():
    try:
        import ray
    except ImportError:
        from .install import install_command

        raise MissingExtraError(f"--ray needs Ray: {install_command('cluster')}") from None
    return ray


class RayEngine:
    """Runs jobs as Ray tasks (``num_cpus`` = threads, ``num_gpus`` = gpus) on the cluster at ``address``
    (``None``: a new local Ray instance; ``"auto"``: the cluster this machine belongs to), or on the Ray instance
    this process already joined."""

    def __init__(self, address: Optional[str], threads: int, gpus: float = 0.0, local_cpus: Optional[int] = None):
        self.ray = _import_ray()
        self.started = False
        if not self.ray.is_initialized():
            kwargs = {"include_dashboard": False, "log_to_driver": False}
            if address is None and local_cpus:
                kwargs["num_cpus"] = local_cpus
            try:
                self.ray.init(address=address, **kwargs)
            except Exception as exc:  # a bad address, no cluster there
                raise SvbrdfError(f"cannot join the Ray cluster {address or '(local)'}: {_one_line(exc)}") from None
            self.started = True
        cpus = int(self.ray.cluster_resources().get("CPU", 1))
        self.capacity = max(1, 2 * (cpus // max(1, threads)))
        self.task = self.ray.remote(run_job).options(num_cpus=threads, num_gpus=gpus or 0, max_retries=0)

    def __enter__(self) -> "RayEngine":
        return self

    def run(self, jobs: Iterator[Job]) -> Iterator[Tuple[Job, Dict[str, Any]]]:
        """Yield ``(job, result)`` as tasks finish, keeping at most :attr:`capacity` in flight."""
        ray = self.ray
        pending: Dict[Any, Job] = {}
        jobs = iter(jobs)
        exhausted = False
        try:
            while True:
                exhausted = exhausted or _top_up(pending, jobs, self.capacity, self.task.remote)
                if not pending:
                    return
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    job = pending.pop(ref)
                    try:
                        result = ray.get(ref)
                    except Exception as exc:  # the task's worker died, or the node
                        result = _died(job, f"Ray task failed ({_one_line(exc)})")
                    yield job, result
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)

    def __exit__(self, *exc) -> None:
        if self.started:
            self.ray.shutdown()


# ------------------------------------------------------------------------------------------------------ the driver

class Library:
    """A library folder and its manifest (see the module docstring); only the driver makes one.

    Attributes:
        root: the folder.
        records: texture set name -> record ``{"source", "sha256", "options", "status": "done" | "failed",
            "error", "timings", "scores", "size", "files", "updated"}``.
    """

    def __init__(self, root: Path, force: bool = False):
        self.root = Path(root)
        self.path = self.root / MANIFEST_FILE
        self.records: Dict[str, Dict[str, Any]] = {}
        if self.root.exists() and not self.root.is_dir():
            raise SvbrdfError(f"{self.root}: exists and is not a folder")
        if self.path.is_file():
            try:
                doc = json.loads(self.path.read_text(encoding="utf-8"))
                if doc.get("format") != "svbrdf-library" or not isinstance(doc.get("photos"), dict):
                    raise ValueError("not an svbrdf-batch manifest")
            except (OSError, ValueError, AttributeError) as exc:
                raise SvbrdfError(f"{self.path}: cannot read the library manifest ({exc})") from None
            self.records = doc["photos"]
        elif self.root.is_dir() and any(not p.name.startswith(".") for p in self.root.iterdir()) and not force:
            raise SvbrdfError(f"{self.root}: is not empty and holds no {MANIFEST_FILE} "
                              f"(not a library) ({OVERWRITE_HINT})")

    def known_names(self) -> Dict[str, str]:
        """Resolved source path -> name, of every record."""
        return {str(Path(r["source"]).resolve()): n for n, r in self.records.items()}

    def save(self) -> None:
        """Rewrite the manifest atomically."""
        from .files import atomic_write

        doc = {"format": "svbrdf-library", "version": MANIFEST_VERSION, "tool": f"{PROG} {__version__}",
               "photos": dict(sorted(self.records.items()))}
        with atomic_write(self.path, force=True) as tmp:
            tmp.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")

    def sidecar_batch(self, name: str) -> Optional[Dict[str, Any]]:
        """The ``batch`` record in the sidecar of the set ``name`` on disk (None: no set, or not written by
        svbrdf-batch)."""
        from .texture_set import SIDECAR_FILE

        try:
            meta = json.loads((self.root / name / SIDECAR_FILE.format(name=name)).read_text(encoding="utf-8"))
            batch = meta["meta"]["batch"]
            return batch if isinstance(batch, dict) else None
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def commit(self, name: str, files: Mapping[str, bytes], thumb: Optional[bytes], force: bool) -> None:
        """Put a texture set (file name -> bytes) in place as ``root/name/`` in one rename (and its strip)."""
        from .files import atomic_write

        staging = self.root / STAGING
        staging.mkdir(exist_ok=True)
        stage = staging / f"{name}.{secrets.token_hex(4)}"
        stage.mkdir()
        try:
            for fname, data in files.items():
                (stage / fname).write_bytes(data)
            if thumb is not None:
                (self.root / THUMBS).mkdir(exist_ok=True)
                with atomic_write(self.root / THUMBS / f"{name}.png", force=True) as tmp:
                    tmp.write_bytes(thumb)
            target = self.root / name
            if target.exists() or target.is_symlink():
                if not force and self.sidecar_batch(name) is None:
                    raise SvbrdfError(exists_message(target))
                old = staging / f"{name}.old-{secrets.token_hex(4)}"
                os.replace(target, old)
                os.replace(stage, target)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(stage, target)
        finally:
            shutil.rmtree(stage, ignore_errors=True)


@contextmanager
def _locked(root: Path) -> Iterator[None]:
    """One driver per library: an exclusive lock on ``root/LOCK_FILE`` (released by the OS when the process dies)."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    with open(root / LOCK_FILE, "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise SvbrdfError(f"{root}: another {PROG} is writing this library") from None
        yield


@dataclass
class BatchSummary:
    """What :func:`run_batch` did: counts of this run and the library's records."""

    done: int = 0
    failed: int = 0
    skipped: int = 0
    refused: int = 0
    records: Dict[str, Dict[str, Any]] = field(default_factory=dict)


def run_batch(photos: Sequence[Path], root: Path, args: argparse.Namespace, *, engine: str = "local",
              workers: Optional[int] = None, ray_address: Optional[str] = None, gpus_per_task: float = 0.0,
              report: Callable[[str], None] = lambda line: None, warn: Callable[[str], None] = lambda line: None,
              error: Callable[[str], None] = lambda line: None) -> BatchSummary:
    """Make (or complete) the library ``root`` from ``photos`` with the texture options ``args``
    (:func:`svbrdf.runtime.cli.add_texture_options`); see the module docstring for the files.

    Photos already done with the same content hash and options (:func:`same_options`) are skipped; failed and new
    ones run. A done photo whose photo or options changed (``--tileable`` or ``--view`` added or dropped included)
    is redone only with ``args.force`` (else refused, one error line). With ``args.view`` each set holds its viewer
    page. Progress of the whole batch goes to stderr (:class:`~svbrdf.runtime.progress.Progress`, unless
    ``args.quiet``); each finished photo is passed to ``report`` (one line), its warnings to ``warn`` and each
    failure to ``error``.

    Args:
        engine: ``"local"`` (a process pool, :func:`plan_workers`) or ``"ray"`` (``ray_address``; ``None`` starts a
            local Ray instance).
        workers: local pool size (default from the cores); with Ray, the CPUs of a local instance it starts.
        gpus_per_task: Ray tasks' ``num_gpus``.

    Raises:
        SvbrdfError: the library cannot be used (not a library, locked, unreadable manifest), no model.
        MissingExtraError: ``--refine`` without torch, ``ray`` without Ray.
    """
    from .cli import _load_refine
    from .progress import Progress
    from .session import _cpu_count, load_session

    library = Library(root, force=args.force)
    if args.refine:
        _load_refine()  # before any work: every photo would fail the same way
    session = load_session(args.model, threads=1, maps=args.maps)
    options = library_options(args, session.info.sha256)
    root.mkdir(parents=True, exist_ok=True)
    summary = BatchSummary(records=library.records)
    with _locked(root):
        shutil.rmtree(root / STAGING, ignore_errors=True)  # what a killed run left staged
        library.save()  # from now on the folder is a library, whatever happens
        names = library_names(photos, library.known_names())
        todo: List[Tuple[Path, str, str]] = []
        changed = False
        for photo in photos:
            name = names[photo]
            record = library.records.get(name)
            try:
                sha = sha256_file(photo)
            except OSError as exc:
                summary.failed += 1
                error(f"{photo}: cannot read ({exc.strerror or exc})")
                library.records[name] = _failed_record(photo, None, options, f"{photo}: cannot read "
                                                       f"({exc.strerror or exc})", {})
                changed = True
                continue
            on_disk = library.sidecar_batch(name)
            same = on_disk is not None and on_disk.get("sha256") == sha and same_options(on_disk.get("options"),
                                                                                          options)
            if record is not None and record.get("status") == "done" and record.get("sha256") == sha \
                    and same_options(record.get("options"), options) and same:
                summary.skipped += 1
                continue
            if same and (record is None or record.get("status") != "done"):  # renamed in just before a kill
                library.records[name] = {**(record or {}), "source": str(photo), "sha256": sha, "options": options,
                                         "status": "done", "error": None, "scores": on_disk.get("scores"),
                                         "updated": _now()}
                library.records[name].setdefault("timings", {})
                changed = True
                summary.skipped += 1
                continue
            if record is not None and record.get("status") == "done" and not args.force and (root / name).exists():
                summary.refused += 1
                error(f"{root / name}: made from {'another photo' if record.get('sha256') != sha else 'the photo'}"
                      f"{'' if same_options(record.get('options'), options) else ' with other options'}; "
                      f"use --force to redo it")
                continue
            if record is None and (root / name).exists() and not args.force:
                summary.refused += 1
                error(exists_message(root / name))
                continue
            todo.append((photo, name, sha))
        if changed:
            library.save()

        cores = _cpu_count()
        torch = sys.modules.get("torch")  # loaded by _load_refine for --refine; never imported here
        gpu = bool(args.refine and torch is not None and torch.cuda.is_available())
        if engine == "ray":
            threads = args.threads or 1
            runner = RayEngine(ray_address, threads, gpus_per_task, local_cpus=workers)
        else:
            n, threads = plan_workers(cores, workers, args.threads, gpu)
            runner = LocalEngine(min(n, max(1, len(todo))))
        quiet_jobs = args.quiet or engine == "ray" or runner.workers != 1

        def jobs() -> Iterator[Job]:
            for photo, name, sha in todo:
                try:
                    data, why = photo.read_bytes(), None
                except OSError as exc:
                    data, why = b"", f"{photo}: cannot read ({exc.strerror or exc})"
                yield Job(name, str(photo), sha, data, options, args.model, threads, quiet_jobs, why)

        bar = Progress(len(todo), PROG, quiet=args.quiet or not todo, unit="photo")
        sources = {name: photo for photo, name, _ in todo}
        try:
            with runner:
                for job, result in runner.run(jobs()):
                    photo = sources[job.name]
                    if result["status"] == "done":
                        try:
                            library.commit(job.name, result["files"], result.get("thumb"), args.force)
                        except (SvbrdfError, OSError) as exc:
                            result = {"status": "failed", "error": _one_line(exc), "timings": result["timings"]}
                    if result["status"] == "done":
                        summary.done += 1
                        library.records[job.name] = {
                            "source": str(photo), "sha256": job.sha256, "options": options, "status": "done",
                            "error": None, "timings": _rounded(result["timings"]), "scores": result["scores"],
                            "size": result["size"], "files": sorted(result["files"]), "updated": _now()}
                        for line in result["warnings"]:
                            warn(line)
                        s = result["scores"]
                        rmse = "-" if s["rerender_rmse"] is None else f"{s['rerender_rmse']:.3f}"
                        report(f"{photo} -> {root / job.name}/  {result['size'][1]}x{result['size'][0]}  "
                               f"{result['timings']['total']:.2f} s ({result['detail']}; RMSE {rmse}, "
                               f"burn-in {s['burn_in']:.2f})")
                    else:
                        summary.failed += 1
                        library.records[job.name] = _failed_record(photo, job.sha256, options, result["error"],
                                                                   result.get("timings", {}))
                        error(result["error"])
                    library.save()
                    left = len(todo) - summary.done - summary.failed
                    bar.update(done=summary.done, failed=summary.failed, left=left)
        finally:
            bar.close()
            from .contact_sheet import write_contact_sheet

            try:
                write_contact_sheet(root, library.records)
            except (SvbrdfError, OSError) as exc:
                error(f"{root}: cannot write the contact sheet ({_one_line(exc)})")
    return summary


def _failed_record(photo: Path, sha: Optional[str], options, error: str, timings) -> Dict[str, Any]:
    return {"source": str(photo), "sha256": sha, "options": options, "status": "failed", "error": error,
            "timings": _rounded(timings), "scores": None, "updated": _now()}


def _rounded(timings: Mapping[str, float]) -> Dict[str, float]:
    return {k: round(float(v), 3) for k, v in timings.items()}


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


__all__ = ["collect_photos", "library_names", "library_options", "same_options", "plan_workers", "run_job",
           "run_batch", "Job", "Library", "BatchSummary", "LocalEngine", "RayEngine", "MANIFEST_FILE", "OPTION_KEYS",
           "OPTION_DEFAULTS", "PHOTO_SUFFIXES"]
