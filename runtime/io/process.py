"""Process tuning and memory checks of the per-photo work: numpy's huge pages off (:func:`small_pages`), glibc's heap
kept for photos up to :data:`REUSE_PIXELS` (:func:`reuse_memory`), and the refusal of a photo whose preview would
need more memory than is available (:func:`check_memory`, from the file's header). The CLIs and the batch workers
call :func:`small_pages` once and :func:`reuse_memory` per photo; an application embedding the library decides for
itself. :func:`~svbrdf.runtime.inference.pipeline.estimate` calls :func:`check_memory`."""

from __future__ import annotations

from typing import Optional

from ..errors import ImageError
from .images import image_info

__all__ = ["BYTES_PER_PIXEL", "REUSE_PIXELS", "available_memory", "check_memory", "downsized_pixels",
           "processed_pixels", "reuse_memory", "small_pages"]

#: Peak bytes of a preview per pixel of the processed photo (after ``max_size``), for :func:`check_memory`, with room
#: for other photos' shapes above the measured 106-116 B/px (docs/decisions/071-process-memory.md).
BYTES_PER_PIXEL = 140


def small_pages() -> bool:
    """Stop numpy asking the kernel for transparent huge pages on its large arrays (``madvise(MADV_HUGEPAGE)``, its
    default on Linux; the environment variable ``NUMPY_MADVISE_HUGEPAGE=0`` does the same at numpy's import): where
    the kernel compacts memory on such a request, large previews spend seconds in it. A process-wide numpy setting.
    Decision: docs/decisions/071-process-memory.md.

    Returns:
        whether numpy would have asked before the call (False where numpy has no such setting).
    """
    try:
        from numpy._core.multiarray import _set_madvise_hugepage
    except ImportError:  # numpy < 2 names it numpy.core; other builds may not have it
        try:
            from numpy.core.multiarray import _set_madvise_hugepage
        except ImportError:
            return False
    return bool(_set_madvise_hugepage(False))


#: Processed pixels up to which :func:`reuse_memory` keeps freed memory in the process (4096 x 4096).
REUSE_PIXELS = 4096 * 4096
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD, _M_MMAP_MAX = -1, -3, -4  # glibc's mallopt parameters (malloc.h)
#: glibc's settings put back after a kept heap: mapping above 32 MB and trimming the heap's top above 64 MB (where its
#: dynamic thresholds settle for arrays of this size; any mallopt call stops them moving).
_GLIBC_BACK = {_M_MMAP_MAX: 65536, _M_MMAP_THRESHOLD: 32 << 20, _M_TRIM_THRESHOLD: 64 << 20}
_kept = False


def reuse_memory(pixels: int) -> bool:
    """Set glibc's allocator for a photo of ``pixels`` processed pixels (:func:`processed_pixels`). Up to
    :data:`REUSE_PIXELS`, large arrays come from the heap and freed memory stays in the process for the next
    array (``mallopt``: ``M_MMAP_MAX`` 0, ``M_TRIM_THRESHOLD`` 2 GiB) instead of being mapped afresh each time
    and faulted in page by page; above it glibc maps each large array: its own settings when this never kept the
    heap, else :data:`_GLIBC_BACK` and the heap trimmed. A process-wide setting, like :func:`small_pages`.
    Decision: docs/decisions/071-process-memory.md.

    Returns:
        whether the heap is kept (False also where the C library has no ``mallopt``).
    """
    global _kept
    keep = pixels <= REUSE_PIXELS
    if keep == _kept:
        return keep
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc
        return False
    settings = {_M_TRIM_THRESHOLD: 2**31 - 1, _M_MMAP_MAX: 0} if keep else _GLIBC_BACK
    for param, value in settings.items():
        mallopt(param, value)
    if not keep:
        libc.malloc_trim(0)  # what the earlier, smaller photos left in the heap
    _kept = keep
    return keep


def processed_pixels(photo, max_size: int) -> int:
    """Pixels of ``photo`` (a file) once downsized to ``max_size``, from its header."""
    info = image_info(photo)
    return downsized_pixels(info["height"], info["width"], max_size)


def downsized_pixels(h: int, w: int, max_size: int) -> int:
    """Pixels of an ``h`` x ``w`` photo once its long side is at most ``max_size``."""
    scale = min(1.0, max_size / max(h, w, 1))
    return int(round(h * scale) * round(w * scale))


def available_memory() -> Optional[int]:
    """Bytes of memory the system can give without swapping (``MemAvailable`` of /proc/meminfo), None where
    unknown."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def check_memory(photo, max_size: int) -> dict:
    """Refuse, with one line, a photo whose preview at ``max_size`` would need more memory than is available
    (:data:`BYTES_PER_PIXEL` per processed pixel), before any pixel is decoded.

    Returns:
        the photo's header facts (:func:`~svbrdf.runtime.io.images.image_info`), read for the check.

    Raises:
        ImageError: the message names the photo, its size, the memory needed and available, and what to lower.
    """
    info = image_info(photo)
    h, w = info["height"], info["width"]
    needed = BYTES_PER_PIXEL * downsized_pixels(h, w, max_size)
    free = available_memory()
    if free is not None and needed > free:
        raise ImageError(f"{photo}: a {w}x{h} photo at --max-size {max_size} needs about {needed / 2**30:.1f} GiB "
                         f"and {free / 2**30:.1f} GiB are available; lower --max-size")
    return info
