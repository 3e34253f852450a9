"""Writing files all or nothing: one file (:func:`atomic_write`) or several files of one folder
(:func:`staged_write`).

Both write into hidden temporary names in the target folder (so the final ``os.replace`` is a rename on one
file system) and only move the result into place when the caller's block finished without error. On error
every temporary is removed and the targets are untouched. An existing target is refused unless ``force``
(checked before the block runs and again just before the move).

Errors are raised as ``error`` (default :class:`~svbrdf.runtime.errors.SvbrdfError`; image writers pass
:class:`~svbrdf.runtime.errors.ImageError`) with a one-line ``"<path>: <problem>"`` message.
"""

from __future__ import annotations

import os
import secrets
import shutil
from contextlib import contextmanager
from pathlib import Path
from typing import Dict, Iterator, Sequence, Type, Union

from ..errors import SvbrdfError, exists_message as _exists

PathLike = Union[str, os.PathLike]


@contextmanager
def atomic_write(path: PathLike, *, force: bool = False,
                 error: Type[SvbrdfError] = SvbrdfError) -> Iterator[Path]:
    """Write one file atomically: the block writes a temporary file that then replaces ``path``.

    Usage::

        with atomic_write(path, force=force) as tmp:
            tmp.write_text(text, encoding="utf-8")

    Args:
        path: the file to write; its folder must exist.
        force: replace an existing ``path``.
        error: exception type raised for the problems below.

    Yields:
        The temporary path ``<folder>/.<stem>.tmp-<random><suffix>``: same folder and extension as ``path``
        (writers that pick a format from the extension work), created empty with ``O_EXCL`` (mode 0o666
        before the umask) so that no other writer gets the same name. The block may overwrite it.

    Raises:
        error: ``path`` exists (and not ``force``), its folder is missing, or the temporary file cannot be
            created or renamed. An exception raised by the block propagates unchanged; in every case the
            temporary file is removed and ``path`` is left as it was.
    """
    path = Path(path)
    if not force and path.exists():
        raise error(_exists(path))
    if not path.parent.is_dir():
        raise error(f"{path}: folder {path.parent} does not exist")
    tmp = None
    for _ in range(100):
        cand = path.with_name(f".{path.stem}.tmp-{secrets.token_hex(4)}{path.suffix}")
        try:
            os.close(os.open(cand, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
        except FileExistsError:
            continue
        except OSError as exc:
            raise error(f"{path}: cannot create a file in {path.parent} ({exc.strerror})") from None
        tmp = cand
        break
    if tmp is None:
        raise error(f"{path}: cannot create a temporary file in {path.parent}")
    try:
        yield tmp
        if not force and path.exists():  # a file may have appeared meanwhile
            raise error(_exists(path))
        try:
            os.replace(tmp, path)
        except OSError as exc:
            raise error(f"{path}: cannot replace the file ({exc.strerror})") from None
    finally:
        tmp.unlink(missing_ok=True)


@contextmanager
def staged_write(out_dir: PathLike, names: Sequence[str], *, force: bool = False,
                 error: Type[SvbrdfError] = SvbrdfError) -> Iterator[Path]:
    """Write several files of one folder all or nothing, through a hidden staging folder inside it.

    Usage::

        with staged_write(out_dir, ["a.png", "a.json"], force=force) as stage:
            write_image(stage / "a.png", ...)
            (stage / "a.json").write_text(...)

    ``out_dir`` is created (with parents) when missing. When the block ends without error, every file of
    ``names`` is moved from the staging folder into ``out_dir``, in the given order.

    Args:
        out_dir: output folder.
        names: file names (no path separators) the block writes into the staging folder.
        force: replace existing files.
        error: exception type raised for the problems below.

    Yields:
        The staging folder, ``<out_dir>/.<first name>.tmp-<random>``.

    Raises:
        error: a bad name, ``out_dir`` not a folder, a target exists (and not ``force``; the message names the
            first and counts the others), or a file-system error (``"<out_dir>: cannot write (...)"``). An
            ``error`` raised by the block propagates with the staging folder in its message replaced by
            ``out_dir`` (it names the target); other exceptions propagate unchanged. In every case the
            staging folder is removed, and so is ``out_dir`` if this call created it and it is still empty.
    """
    out_dir = Path(out_dir)
    for name in names:
        if not name or name in (".", "..") or "/" in name or os.sep in name:
            raise error(f"{out_dir}: invalid file name {name!r}")
    if out_dir.exists() and not out_dir.is_dir():
        raise error(f"{out_dir}: exists and is not a folder")
    targets: Dict[str, Path] = {n: out_dir / n for n in names}

    def refuse_existing() -> None:
        existing = [p for p in targets.values() if p.exists()]
        if existing and not force:
            raise error(_exists(existing[0], len(existing) - 1))

    refuse_existing()
    created = not out_dir.exists()
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise error(f"{out_dir}: cannot create folder ({exc.strerror})") from None
    stage = out_dir / f".{names[0] if names else 'files'}.tmp-{secrets.token_hex(4)}"
    done = False
    try:
        stage.mkdir()
        yield stage
        refuse_existing()  # a file may have appeared meanwhile
        for name, target in targets.items():
            os.replace(stage / name, target)
        done = True
    except error as exc:  # name the target, not the staging copy
        staged = str(stage) + os.sep
        if staged not in str(exc):
            raise
        raise type(exc)(str(exc).replace(staged, str(out_dir) + os.sep)) from None
    except OSError as exc:
        raise error(f"{out_dir}: cannot write ({exc.strerror or exc})") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if created and not done:
            try:
                out_dir.rmdir()  # only if still empty
            except OSError:
                pass


__all__ = ["atomic_write", "staged_write"]
