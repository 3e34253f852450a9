"""A material library: many flash photos -> one texture set each, resumable, on a local process pool or Ray.

Layout of a library folder::

    LIBRARY/library.json        the manifest (MANIFEST_FILE): one record per photo, written only by the driver
    LIBRARY/<name>/             one texture set per photo, as svbrdf-preview writes it (any --target; with
                                --tileable maps that repeat without a seam; with --view its <name>_view.html)
    LIBRARY/thumbs/<name>.png   a strip of small views: photo, four maps, relit (contact_sheet.STRIP_VIEWS)
    LIBRARY/index.html, index.png   the contact sheet (:mod:`svbrdf.runtime.outputs.contact_sheet`; a "view" link per
                                    material that has a viewer page)

The work of one photo is :func:`run_job`, the same function whichever engine runs it: it gets the photo's bytes
and the options, runs the per-photo path of ``svbrdf-preview`` (:func:`svbrdf.runtime.workflow.photo.process_photo`), writes
the texture set (and, with ``--view``, its viewer page, :func:`svbrdf.runtime.outputs.viewer.write_viewer`) into a private
temporary folder and returns the files' bytes with the scores. Only the driver
(:func:`run_batch`) writes into the library: each set is staged in ``LIBRARY/.staging/`` and renamed into place
in one step, then the manifest is rewritten atomically (:func:`svbrdf.runtime.io.files.atomic_write`). So a killed
run loses at most the photos in flight, never leaves half a set, and never corrupts the manifest; a set renamed
into place just before the kill is adopted on the next run (its sidecar records the photo's hash and options).

A photo is done when its record and its set's sidecar hold its content hash and the same options
(:data:`OPTION_KEYS`, :func:`same_options`); an option added to :data:`OPTION_KEYS` later takes its value in
:data:`OPTION_DEFAULTS` where an older library's records lack it, so a library written before ``--tileable`` and
``--view`` is not redone by a run without them.
"""

from __future__ import annotations

import glob
import hashlib
import json
import os
import secrets
import shutil
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Dict, Iterable, Iterator, List, Mapping, Optional, Sequence, Tuple

from .. import __version__
from ..core.relief import AO_STRENGTH
from ..errors import OVERWRITE_HINT, SvbrdfError, exists_message
from .engines import LocalEngine, RayEngine, plan_workers
from .job import PROG, Job, _one_line

if TYPE_CHECKING:  # pragma: no cover
    from ..workflow.options import PhotoOptions
#: The manifest's file name in the library folder, and its format version.
MANIFEST_FILE = "library.json"
MANIFEST_VERSION = 1
#: Folder of the contact sheet's strips; no texture set takes this name.
THUMBS = "thumbs"
STAGING = ".staging"
LOCK_FILE = ".svbrdf-batch.lock"
#: Extensions taken from a folder given as input (case-insensitive).
PHOTO_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr", ".hdr", ".bmp", ".webp")
#: The options (:class:`~svbrdf.runtime.workflow.options.PhotoOptions`) that change a texture set (recorded per photo;
#: a done photo is redone only when they or the photo change).
OPTION_KEYS = ("refine", "quality", "iters", "target", "maps", "normal", "format", "max_size", "tile", "fov",
               "tileable", "view", "relief", "ao_strength", "network_size")
#: The options added to :data:`OPTION_KEYS` after libraries were first written, with the value a record that
#: lacks them was made with (:func:`same_options`; ``network_size``: ``upsampling.network_size`` of the options, None
#: = the network at the photo's own size, as every set up to 2048 px was made before 2026-11-28).
OPTION_DEFAULTS = {"tileable": False, "view": False, "relief": [], "ao_strength": AO_STRENGTH, "network_size": None}


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


def library_options(args: Any, model_sha256: str) -> Dict[str, Any]:
    """What makes a texture set (:data:`OPTION_KEYS` of ``args``, a
    :class:`~svbrdf.runtime.workflow.options.PhotoOptions`, plus the model's sha256), JSON-ready; ``args``
    without a key of :data:`OPTION_DEFAULTS` gets its default."""
    opts = {k: getattr(args, k, OPTION_DEFAULTS[k]) if k in OPTION_DEFAULTS else getattr(args, k)
            for k in OPTION_KEYS if k != "network_size"}
    opts["network_size"] = getattr(getattr(args, "upsampling", None), "network_size", OPTION_DEFAULTS["network_size"])
    opts["maps"] = list(opts["maps"])
    if opts["relief"] is None:  # PhotoOptions' default: both relief maps with all four maps
        from ..core.maps import MAP_NAMES
        from ..core.relief import RELIEF_NAMES

        opts["relief"] = RELIEF_NAMES if tuple(opts["maps"]) == MAP_NAMES else ()
    opts["relief"] = list(opts["relief"])
    opts["model_sha256"] = model_sha256
    return opts


def same_options(recorded: Any, options: Mapping[str, Any]) -> bool:
    """Whether the options ``recorded`` for a set (manifest or sidecar; possibly from an older version, without
    the keys of :data:`OPTION_DEFAULTS`) are ``options`` (:func:`library_options`)."""
    return isinstance(recorded, dict) and {**OPTION_DEFAULTS, **recorded} == {**OPTION_DEFAULTS, **options}


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
        from ..io.files import atomic_write

        doc = {"format": "svbrdf-library", "version": MANIFEST_VERSION, "tool": f"{PROG} {__version__}",
               "photos": dict(sorted(self.records.items()))}
        with atomic_write(self.path, force=True) as tmp:
            tmp.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")

    def sidecar_batch(self, name: str) -> Optional[Dict[str, Any]]:
        """The ``batch`` record in the sidecar of the set ``name`` on disk (None: no set, or not written by
        svbrdf-batch)."""
        from ..outputs.texture_set import SIDECAR_FILE

        try:
            meta = json.loads((self.root / name / SIDECAR_FILE.format(name=name)).read_text(encoding="utf-8"))
            batch = meta["meta"]["batch"]
            return batch if isinstance(batch, dict) else None
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def commit(self, name: str, files: Mapping[str, bytes], thumb: Optional[bytes], force: bool) -> None:
        """Put a texture set (file name -> bytes) in place as ``root/name/`` in one rename (and its strip)."""
        from ..io.files import atomic_write

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


def run_batch(photos: Sequence[Path], root: Path, args: "PhotoOptions", *, engine: str = "local",
              workers: Optional[int] = None, ray_address: Optional[str] = None, gpus_per_task: float = 0.0,
              report: Callable[[str], None] = lambda line: None, warn: Callable[[str], None] = lambda line: None,
              error: Callable[[str], None] = lambda line: None) -> BatchSummary:
    """Make (or complete) the library ``root`` from ``photos`` with the texture options ``args`` (a
    :class:`~svbrdf.runtime.workflow.options.PhotoOptions`); see the module docstring for the files.

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
    from ..inference.refine import load_refine
    from ..inference.session import _cpu_count, load_session
    from ..progress import Progress

    library = Library(root, force=args.force)
    if args.refine:
        load_refine()  # before any work: every photo would fail the same way
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
        torch = sys.modules.get("torch")  # loaded by load_refine for --refine; never imported here
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
            from ..outputs.contact_sheet import write_contact_sheet

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


__all__ = ["collect_photos", "library_names", "library_options", "same_options", "run_batch", "Library",
           "BatchSummary", "MANIFEST_FILE", "OPTION_KEYS", "OPTION_DEFAULTS", "PHOTO_SUFFIXES"]
