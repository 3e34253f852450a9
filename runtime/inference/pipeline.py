"""The per-photo pipeline: photo -> :class:`~svbrdf.runtime.core.maps.Maps` (:func:`estimate`), and photo -> texture set
files with the options of the CLIs (:class:`PhotoOptions`, :func:`process_photo`, :func:`write_maps`); no torch
(``--refine`` calls into the trainer, :mod:`svbrdf.runtime.inference.refine`).

::

    session = load_session()                     # model lookup: see svbrdf.runtime.inference.manifest
    maps = estimate("photo.jpg", session)        # Maps, linear, OpenGL normals, meta with timings
    normal = estimate("photo.jpg", session, maps=["normal"]).normal   # runs only the normal decoder

Pipeline of :func:`estimate`:

1. read the photo with :func:`svbrdf.runtime.io.images.read_image` (linear float32) or take an array;
2. if its long side exceeds ``max_size``, downsize it (and warn) with OpenImageIO ``ImageBufAlgo.resize`` and
   the ``"blackman-harris"`` filter (:data:`~svbrdf.runtime.io.images.RESIZE_FILTER`): a non-negative kernel, so a
   linear photo stays >= 0 and a flash highlight does not ring into negative values as with the default
   lanczos3. A file at least twice ``max_size`` is read in strips averaged over pixel blocks first, so memory
   does not grow with the file's size (:func:`~svbrdf.runtime.io.images.read_image`);
3. divide the photo by its own smooth lighting (:func:`svbrdf.runtime.post.flash_trend.even_lighting`,
   :attr:`PostProcess.even_lighting`): the network sees the material evenly lit, not the flash's fall-off and broad highlight
   (what the model records decides: :attr:`PreviewSession.even_lighting`; a stage one shipped with
   ``network_input`` "photo" sees the photo as it is); run the model on that (the full graph, or the part graph
   of the one decoder the requested maps need: see :meth:`PreviewSession.graph_for`) in one pass when the image
   fits in one ``tile`` x ``tile`` window, else in overlapping tiles blended with
   :func:`svbrdf.runtime.inference.tiling.tiled_apply` (memory bounded by one tile's inference). The generator uses
   instance normalisation, so tiles see their own statistics: expect differences from a single pass that are small
   for stationary materials but not only at the seams;
4. clip every requested map to its range and renormalise the (blended) normals (:meth:`Maps.clipped`);
5. give the base colour the photo's colour balance (:func:`~svbrdf.runtime.post.photo_colour.photo_colour`, :attr:`PostProcess.colour_from_photo`): the
   generator's instance normalisation hides a photo's overall colour from it, and the learned stage one predicts a
   nearly grey base colour for every material (CHANGELOG.md, study prior, "Colour");
6. remove the smooth radial trend around the photo's flash highlight from the base colour, specular and roughness
   (:func:`svbrdf.runtime.post.flash_trend.remove_flash_trend`, :attr:`PostProcess.flash_trend`; first the highlight fill, :attr:`PostProcess.highlight_fill`): what the network left of the
   highlight and the fall-off (CHANGELOG.md, study accuracy, "Now"); the base colour's trend as one
   brightness gain for its three channels (its hue kept), then its coarse colours made the photo's
   (:func:`svbrdf.runtime.post.photo_colour.local_colour`);
7. make the specular one level, its median (:func:`svbrdf.runtime.post.flash_trend.uniform_specular`,
   :attr:`PostProcess.uniform_specular`): its spatial variation is noise by measurement.
"""

from __future__ import annotations

import functools
import os
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Callable, Iterable, Optional, Tuple, Union

import numpy as np

from ..core.filters import all_finite, block_mean
from ..core.maps import MAP_NAMES, N_CHANNELS, SLICES, Maps, select_maps
from ..core.relief import AO_STRENGTH, RELIEF_NAMES
from ..errors import ImageError, SvbrdfError
from ..io.images import ImageWarning, image_info, read_image, read_strips, resize_long_side
from ..post import PostProcess
from ..post import apply as apply_post
from ..post.flash_trend import even_lighting
from .guided import Upsampling, guided_upsample, luminance, network_photo
from .manifest import MIN_SIZE
from .session import PreviewSession, load_session
from .tiling import DEFAULT_OVERLAP, tile_boxes, tiled_apply

#: Long side (pixels) larger photos are downsized to, and the tile size of the tiled inference.
DEFAULT_MAX_SIZE = 2048
DEFAULT_TILE = 1024

__all__ = ["estimate", "process_photo", "write_maps", "PhotoOptions", "warn_if_greyscale", "DEFAULT_MAX_SIZE",
           "DEFAULT_TILE", "DEFAULT_OVERLAP", "check_memory", "available_memory", "BYTES_PER_PIXEL", "Upsampling", "small_pages",
           "processed_pixels", "reuse_memory", "REUSE_PIXELS"]


#: Largest channel spread (linear) of a photo taken as greyscale by :func:`warn_if_greyscale`.
GREY_TOLERANCE = 1.0 / 512


def warn_if_greyscale(image: np.ndarray, name: str) -> bool:
    """Warn (:class:`~svbrdf.runtime.io.images.ImageWarning`) when an (H, W, 3) photo has no colour: a one-channel
    file (read as R = G = B) or three channels equal within :data:`GREY_TOLERANCE`. The model then invents the
    colour of the diffuse and specular maps. Returns whether it warned."""
    grey = True
    rows = max(1, (1 << 20) // max(1, image.shape[1]))  # strips of a megapixel: a colour photo stops at the first
    for y0 in range(0, image.shape[0], rows):
        s = image[y0:y0 + rows]
        if any(float(np.abs(s[..., c] - s[..., 1]).max()) > GREY_TOLERANCE for c in (0, 2)):
            grey = False
            break
    if grey:
        _greyscale_warning(name)
    return grey


def _greyscale_warning(name: str) -> None:
    warnings.warn(ImageWarning(f"{name}: greyscale photo (no colour); the model invents the colour of the diffuse and "
                               f"specular maps"), stacklevel=3)


#: Peak bytes of a preview per pixel of the processed photo (after ``max_size``), for :func:`check_memory`:
#: measured 116 B/px at 4096 x 4096 (1.95 GB peak RSS) and 106 B/px at 8192 x 8192 (7.1 GB), with the interpreter
#: and the model (docs/lab/speed/README.md); 140 leaves room for other photos' shapes.
BYTES_PER_PIXEL = 140


def small_pages() -> bool:
    """Stop numpy asking the kernel for transparent huge pages on its large arrays (``madvise(MADV_HUGEPAGE)``, its
    default on Linux; the environment variable ``NUMPY_MADVISE_HUGEPAGE=0`` does the same at numpy's import). Where
    the kernel compacts memory on such a request (``/sys/kernel/mm/transparent_hugepage/defrag`` = ``madvise``, as on
    the project's machines), a 4096 px preview spent about 1 s more in the kernel: 9.15 and 8.45 s with them, 8.15
    and 7.45 s without (taking turns, 2-core AMD EPYC); no difference at 1024 px. A process-wide numpy setting: the
    CLIs and the batch workers call it; an application embedding the library decides for itself.

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


#: Bytes of float32 one strip of a photo read strip by strip takes (:func:`read_strips`): small enough for the C
#: allocator to reuse the strips' memory instead of mapping fresh pages.
READ_STRIP_BYTES = 8 << 20
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
    and faulted in page by page: measured with ``svbrdf-preview --threads 2`` on the 2-core AMD EPYC, taking turns,
    1024 px 0.90 -> 0.83 s (median of 3), 4096 px 6.56 / 6.08 -> 4.75 / 4.97 s, for a peak of 1122 -> 1436 MiB at
    4096 px. Above it glibc maps each large array (at 8192 px the heap would add 1 GiB to the peak, 3608 -> 4611 MiB,
    for 24.8 -> 22.3 s): its own settings when this never kept the heap, else :data:`_GLIBC_BACK` and the heap trimmed.
    A process-wide setting, like :func:`small_pages`: the CLIs and the batch workers call it per photo; an
    application embedding the library decides for itself.

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
    return _downsized_pixels(info["height"], info["width"], max_size)


def _downsized_pixels(h: int, w: int, max_size: int) -> int:
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
    needed = BYTES_PER_PIXEL * _downsized_pixels(h, w, max_size)
    free = available_memory()
    if free is not None and needed > free:
        raise ImageError(f"{photo}: a {w}x{h} photo at --max-size {max_size} needs about {needed / 2**30:.1f} GiB "
                         f"and {free / 2**30:.1f} GiB are available; lower --max-size")
    return info


def _as_image(photo: Union[str, os.PathLike, np.ndarray], max_size: int, info: Optional[dict] = None) -> tuple:
    """``(name, (H, W, 3) linear image with long side <= max_size, (height, width) before downsizing)``; ``info``:
    the file's header facts (:func:`check_memory`)."""
    if isinstance(photo, np.ndarray):
        name = "<array>"
        if photo.ndim != 3 or photo.shape[-1] != 3:
            raise ImageError(f"{name}: expected an (H, W, 3) linear RGB array, got shape {photo.shape}")
        image = np.asarray(photo, dtype=np.float32)
        if not all_finite(image):
            raise ImageError(f"{name}: image has NaN/Inf values")
        if min(image.shape[:2]) >= MIN_SIZE and max(image.shape[:2]) > max_size:
            small = resize_long_side(image, max_size)
            if min(small.shape[:2]) < MIN_SIZE:  # refused by the caller
                return name, small, image.shape[:2]
            warnings.warn(ImageWarning(f"{name}: downsized from {image.shape[1]}x{image.shape[0]} to "
                                       f"{small.shape[1]}x{small.shape[0]} pixels (max_size={max_size})"),
                          stacklevel=3)
            return name, small, image.shape[:2]
        return name, image, image.shape[:2]
    image = read_image(photo, max_size=max_size)
    if max(image.shape[:2]) < max_size:  # not downsized
        return str(photo), image, image.shape[:2]
    size = (info["width"], info["height"]) if info["orientation"] in (5, 6, 7, 8) else (info["height"], info["width"])
    return str(photo), image, size


def estimate(
    photo: Union[str, os.PathLike, np.ndarray],
    session: Optional[PreviewSession] = None,
    *,
    max_size: int = DEFAULT_MAX_SIZE,
    tile: int = DEFAULT_TILE,
    overlap: int = DEFAULT_OVERLAP,
    maps: Union[None, str, Iterable[str]] = None,
    post: PostProcess = PostProcess(),
    upsampling: Upsampling = Upsampling(),
    fov_deg: Optional[float] = None,
) -> Maps:
    """SVBRDF maps of one flash photo: all four, or only ``maps`` (running only the decoder they need).

    Args:
        photo: image file path, or an (H, W, 3) float32 **linear** RGB array; at least 8 x 8 pixels.
        session: a loaded :class:`PreviewSession` (default: :func:`load_session` with the default lookup).
        max_size: longer photos are downsized so their long side is ``max_size`` (see the module docstring).
        tile: images whose long side (after downsizing) exceeds ``tile`` are processed in ``tile`` x ``tile``
            windows; ``tile >= 8``.
        overlap: overlap of neighbouring windows, ``0 <= 2 * overlap <= tile``.
        maps: the maps to compute, names of :data:`~svbrdf.runtime.core.maps.MAP_NAMES` (or aliases; see
            :func:`~svbrdf.runtime.core.maps.select_maps`); default: the session's ``maps`` (all four unless the
            session was loaded for a subset). The maps of one decoder (``roughness``/``normal`` or
            ``diffuse``/``specular``) run that decoder's part graph when the model has it; a model exported
            without parts runs the full graph and warns once (``UserWarning``).
        post: the corrections around the network (:class:`~svbrdf.runtime.post.PostProcess`; default: all, as
            shipped).
        upsampling: a photo longer than :attr:`Upsampling.network_size` (512 px; after ``max_size``) runs the
            network and ``post`` on itself in k x k pixel blocks and gets its maps at its own size from
            :func:`~svbrdf.runtime.inference.guided.guided_upsample` (the photo's detail; better maps than the
            network at 1024 px, in half the time: :mod:`svbrdf.runtime.inference.guided`);
            ``Upsampling(network_size=None)``: the network at the photo's size (in tiles above ``tile``) at any size.
        fov_deg: the photo's field of view across its width, degrees (:func:`photo_camera`): the camera of the
            corrections that model the flash (the highlight's shoulder) and of the returned ``render_config``;
            None: the session's (the model's training camera).

    Returns:
        :class:`Maps` at the processed size with the requested maps (the others ``None``): diffuse (H, W, 3)
        linear [0, 1], specular and roughness (H, W, 1) [0, 1], normal (H, W, 3) unit OpenGL. ``meta`` holds
        ``source``, ``model`` (path, sha256, verified, ``graph``: ``"full"`` or the part that ran), ``maps``
        (the names computed), ``input_size`` and ``size`` ([H, W]), ``resized``, ``tiles``, ``tile``,
        ``overlap``, ``threads``, ``timings`` (seconds for ``read``, ``resize``, ``infer``, ``post``; on the
        guided path also ``upsample``), ``network_size`` ([h, w] the network ran at; guided path only) and
        ``burn_in``: the label-free highlight burn-in of the maps returned
        (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in`; ``burn_in["burn_in"]`` is the headline, the worst map's
        disc or ring score, 0.1-0.3 for a stationary material, higher when the flash stayed in the maps), ``burn_in_model`` the same of
        the network's maps before the flash trend was removed (``post.flash_trend``; what the skip rule of
        ``--quality auto`` reads), ``flash_trend`` what was removed and ``uniform_specular`` the specular level
        (``post.uniform_specular``). ``render_config`` is the
        session's (the model's training renderer), with ``fov_deg`` when given.

    Raises:
        ImageError: unreadable photo, bad array, or an image smaller than 8 px (before or after downsizing).
        ModelError: no usable model (when ``session`` is None), or a part file that does not match the manifest.
        SvbrdfError: unknown map names, or the model returned NaN/Inf maps (float photos with absurd values, near
            the float32 limit).
        ValueError: invalid ``max_size``, ``tile`` or ``overlap``.

    Warns:
        ImageWarning: a greyscale photo (:func:`warn_if_greyscale`); a photo downsized to ``max_size`` (files of
            any size are read in strips: :func:`~svbrdf.runtime.io.images.read_image`).
    """
    if max_size < MIN_SIZE or tile < MIN_SIZE or not 0 <= 2 * overlap <= tile:
        raise ValueError(f"need max_size >= {MIN_SIZE}, tile >= {MIN_SIZE} and 0 <= 2 * overlap <= tile; "
                         f"got max_size={max_size}, tile={tile}, overlap={overlap}")
    names = None if maps is None else select_maps(maps)
    timings = {}
    t = time.perf_counter()
    info = None if isinstance(photo, np.ndarray) else check_memory(photo, max_size)  # the one header read
    streamed = None if info is None else _streamed(photo, info, max_size, upsampling)
    if streamed is not None:  # a large photo file: only its block means and luminance are read into memory
        timings["read"], timings["resize"] = time.perf_counter() - t, 0.0
        return _estimate_guided(str(photo), streamed, timings, session, names, tile, overlap, post, upsampling,
                                fov_deg)
    name, image, (in_h, in_w) = _as_image(photo, max_size, info)
    if min(in_h, in_w) < MIN_SIZE:
        raise ImageError(f"{name}: image is {in_w}x{in_h} pixels; the model needs at least {MIN_SIZE}x{MIN_SIZE}")
    timings["read"] = time.perf_counter() - t
    if session is None:
        session = load_session(maps=names)
    names = names or session.maps
    graph = session.graph_for(names)

    t = time.perf_counter()
    warn_if_greyscale(image, name)  # the photo is already downsized (by _as_image)
    h, w = image.shape[:2]
    if min(h, w) < MIN_SIZE:
        raise ImageError(f"{name}: {in_w}x{in_h} downsized to {w}x{h} is below {MIN_SIZE} px; raise max_size")
    timings["resize"] = time.perf_counter() - t
    if upsampling.applies((h, w)):
        t = time.perf_counter()
        reduced = (network_photo(image, upsampling.factor((h, w))), luminance(image), (in_h, in_w))
        del image  # only the luminance is needed from here: the full-size photo is freed before the maps are made
        timings["resize"] += time.perf_counter() - t
        return _estimate_guided(name, reduced, timings, session, names, tile, overlap, post, upsampling, fov_deg)

    t = time.perf_counter()
    width = session.input_lighting(post.even_lighting)
    net_input = even_lighting(image, width) if width else image
    packed = tiled_apply(lambda x: session.run(x, names), net_input, tile, overlap)
    timings["infer"] = time.perf_counter() - t
    computed = np.concatenate([np.arange(N_CHANNELS)[SLICES[n]] for n in names])
    # A part graph leaves the other maps' channels NaN; overflow shows in the computed ones (e.g. float photos near
    # the float32 limit).
    if not np.isfinite(packed[..., computed]).all():
        raise SvbrdfError(f"{name}: the model returned NaN/Inf maps (photo values up to {float(image.max()):.3g}; "
                          f"expected linear RGB of order 1)")

    t = time.perf_counter()
    meta = {
        "source": name,
        "model": {"path": str(session.path), "sha256": session.info.sha256, "verified": session.info.verified,
                  "graph": graph},
        "maps": list(names),
        "even_lighting": width,  # what the network was shown: the photo evenly lit at this width, or None
        "input_size": [in_h, in_w],
        "size": [h, w],
        "resized": (h, w) != (in_h, in_w),
        "tiles": len(tile_boxes(h, w, tile, overlap)),
        "tile": tile,
        "overlap": overlap,
        "threads": session.threads,
    }
    config = session.render_config if fov_deg is None else session.render_config.replace(fov_deg=float(fov_deg))
    out = apply_post(Maps.unpack(packed, meta, maps=names, render_config=config).clipped(), image,
                     post)
    timings["post"] = time.perf_counter() - t
    out.meta["timings"] = timings
    return out


def _streamed(photo, info: dict, max_size: int, upsampling: Upsampling) -> Optional[tuple]:
    """For a photo file (header facts ``info``) on the guided path read as it is (no downsizing, EXIF orientation 1):
    ``(block means, luminance, input size)`` of :func:`_estimate_guided`, read strip by strip (:func:`read_strips`;
    the same values as from the whole photo, the greyscale warning included); otherwise None (:func:`_as_image`
    reads it)."""
    if upsampling.network_size is None:
        return None
    h, w = info["height"], info["width"]
    if info["orientation"] != 1 or max(h, w) > max_size or min(h, w) < MIN_SIZE or not upsampling.applies((h, w)):
        return None
    k = upsampling.factor((h, w))
    small = np.empty((-(-h // k), -(-w // k), 3), np.float32)
    guide = np.empty((h, w), np.float32)
    grey = True
    for y0, strip in read_strips(photo, k * max(1, READ_STRIP_BYTES // (k * w * 12))):
        small[y0 // k:y0 // k + -(-strip.shape[0] // k)] = block_mean(strip, k, partial=True)
        guide[y0:y0 + strip.shape[0]] = luminance(strip)
        grey = grey and not any(float(np.abs(strip[..., c] - strip[..., 1]).max()) > GREY_TOLERANCE for c in (0, 2))
    if grey:
        _greyscale_warning(str(photo))
    return small, guide, (h, w)


def _estimate_guided(name, reduced, timings, session, names, tile, overlap, post, upsampling, fov_deg) -> Maps:
    """:func:`estimate` of a photo larger than the network's size: the maps of the photo in k x k pixel blocks, brought
    back to its size by :func:`guided_upsample`. ``reduced``: ``(block means (h, w, 3), luminance (H, W), input size
    before max_size)``."""
    small, guide, input_size = reduced
    size = guide.shape
    guide_low = luminance(small)
    with warnings.catch_warnings():  # the photo itself was checked (and named) above
        warnings.simplefilter("ignore", ImageWarning)
        low = estimate(small, session, max_size=max(small.shape[:2]), tile=tile, overlap=overlap, maps=names,
                       post=post, upsampling=Upsampling(network_size=None), fov_deg=fov_deg)
    t = time.perf_counter()
    out = guided_upsample(low, guide_low, guide, upsampling)
    timings.update({k: v for k, v in low.meta["timings"].items() if k not in ("read", "resize")})
    timings["upsample"] = time.perf_counter() - t
    out.meta.update(source=name, input_size=list(input_size), size=list(size), resized=tuple(size) != tuple(input_size),
                    network_size=list(small.shape[:2]), timings=timings)
    return out


@dataclass(frozen=True)
class PhotoOptions:
    """How one photo becomes a texture set: the options both CLIs share (``svbrdf-preview``, ``svbrdf-batch``; built
    from their arguments by :func:`svbrdf.runtime.cli.options.photo_options`), with the shipped defaults.

    Attributes:
        model: ONNX model path (None: ``$SVBRDF_MODEL``, else the packaged model).
        threads: CPU threads (None: every core).
        fov: camera field of view across the photo width, degrees (None: each photo's EXIF record, else the model's;
            :func:`photo_camera`).
        normal: normal map convention of ``target`` generic: ``"opengl"`` (green up) or ``"dx"``.
        format: normal/roughness/specular/height/ao files of ``target`` generic: ``"png"`` (16-bit) or ``"exr"``
            (float).
        max_size: photos whose long side is longer are downsized to it (pixels).
        tile: larger images run in overlapping ``tile`` x ``tile`` windows (pixels).
        target: output preset (:data:`svbrdf.runtime.outputs.choices.TARGETS`).
        maps: the maps to compute and write (names of :data:`~svbrdf.runtime.core.maps.MAP_NAMES`, in that order).
        relief: the relief maps to derive from the normal map and write (names of
            :data:`~svbrdf.runtime.core.relief.RELIEF_NAMES`: ``"height"``, ``"ao"``; ``maps`` must hold ``"normal"``);
            computed after ``tileable``, across the wrap when it is set (:meth:`~svbrdf.runtime.core.maps.Maps.with_relief`).
            Default (None): both when ``maps`` are all four, none for a subset.
        ao_strength: the AO is that of the height times it (:data:`~svbrdf.runtime.core.relief.AO_STRENGTH`).
        tileable: make the maps repeat without a seam (:func:`svbrdf.runtime.post.tileable.make_tileable`).
        view: also write the viewer page (:func:`svbrdf.runtime.outputs.viewer.write_viewer`).
        force: overwrite existing files.
        refine: fit the preview's specular and roughness to the photo, kept where the photo's held-out blocks say
            it helps (:func:`svbrdf.trainer.refine.refine`, torch).
        iters: the refine's fitting steps (None: :data:`svbrdf.trainer.refine.ITERS`).
        quality: ``"auto"``: the refine's fit stops when it stops improving; None: ``iters`` steps.
        quiet: no refine progress bar.
        post: the corrections around the network (:class:`~svbrdf.runtime.post.PostProcess`).
        upsampling: how a photo longer than 512 px gets its maps (:class:`~svbrdf.runtime.inference.guided.Upsampling`:
            the network at 512 px and the photo's detail; ``svbrdf-preview --network-size``).
    """

    model: Optional[str] = None
    threads: Optional[int] = None
    fov: Optional[float] = None
    normal: str = "opengl"
    format: str = "png"
    max_size: int = DEFAULT_MAX_SIZE
    tile: int = DEFAULT_TILE
    target: str = "generic"
    maps: Tuple[str, ...] = MAP_NAMES
    relief: Optional[Tuple[str, ...]] = None
    ao_strength: float = AO_STRENGTH
    tileable: bool = False
    view: bool = False
    force: bool = False
    refine: bool = False
    iters: Optional[int] = None
    quality: Optional[str] = None
    quiet: bool = False
    post: PostProcess = field(default_factory=PostProcess)
    upsampling: Upsampling = field(default_factory=Upsampling)

    def __post_init__(self) -> None:
        object.__setattr__(self, "maps", select_maps(self.maps))
        if self.relief is None:
            relief = RELIEF_NAMES if self.maps == MAP_NAMES else ()
        else:
            relief = (self.relief,) if isinstance(self.relief, str) else tuple(self.relief)
        if any(n not in RELIEF_NAMES for n in relief):
            raise SvbrdfError(f"unknown relief map in {relief!r}; valid names: {', '.join(RELIEF_NAMES)}")
        if relief and "normal" not in self.maps:
            raise SvbrdfError("the height and AO maps need the normal map: add 'normal' to maps")
        object.__setattr__(self, "relief", tuple(n for n in RELIEF_NAMES if n in relief))

    @classmethod
    def from_mapping(cls, values: Any) -> "PhotoOptions":
        """The options among ``values`` (a mapping, or an object such as an ``argparse.Namespace``); other keys
        are ignored."""
        get = values.get if isinstance(values, dict) else (lambda k, d=None: getattr(values, k, d))
        missing = object()
        kwargs = {}
        for f in fields(cls):
            v = get(f.name, missing)
            if v is not missing:
                kwargs[f.name] = v
        return cls(**kwargs)

    def replace(self, **changes) -> "PhotoOptions":
        from dataclasses import replace

        return replace(self, **changes)

    def render_config(self, session: PreviewSession):
        """The session's render configuration with ``fov`` when given."""
        config = session.render_config
        return config if self.fov is None else config.replace(fov_deg=self.fov)


def _refine(refine, image, session, config, options: "PhotoOptions", name: str):
    """The preview of ``image`` ((H, W, 3) linear), then ``refine`` (:func:`svbrdf.trainer.refine.refine`) with the
    photo's ``config`` (its field of view); returns the Maps, the refined ones or the preview
    (``meta["refine"]["kept"]`` says which)."""
    from ..progress import Progress

    with warnings.catch_warnings():  # the photo itself was checked (and named) by the caller
        warnings.simplefilter("ignore", ImageWarning)
        preview = estimate(image, session, max_size=options.max_size, tile=options.tile, maps=MAP_NAMES,
                           post=options.post, upsampling=options.upsampling, fov_deg=config.fov_deg)
    bar = None

    def progress(step, total, error):  # the Progress is made at the first step, when the length is known
        nonlocal bar
        if bar is None:
            bar = Progress(total, f"refine {name}", quiet=options.quiet, initial=step - 1)
        bar.update(step, rmse=f"{error:.4f}")

    try:
        return refine(image, preview, config, quality=options.quality or "fixed", iters=options.iters,
                      threads=options.threads, callback=progress)
    finally:
        if bar is not None:
            bar.close()


def process_photo(photo: Path, options: PhotoOptions, session: PreviewSession, config=None,
                  refine: Optional[Callable] = None, name: Optional[str] = None, later: bool = False):
    """The texture set of one photo file with ``options``: the preview, or the refine with ``refine`` (see
    :func:`svbrdf.runtime.inference.refine.load_refine`). The one per-photo path of ``svbrdf-preview`` and
    ``svbrdf-batch`` (each builds its :class:`PhotoOptions` from its arguments).

    Args:
        photo: the photo file (PNG, JPEG, TIFF, EXR, ...; read as linear RGB).
        options: what to compute (:class:`PhotoOptions`; ``refine`` needs ``refine``).
        session: the loaded model (:func:`~svbrdf.runtime.inference.session.load_session`).
        config: the :class:`~svbrdf.runtime.core.render_config.RenderConfig` of the maps and the relit panel
            (default: :meth:`PhotoOptions.render_config` of the session).
        refine: :func:`svbrdf.trainer.refine.refine`, for ``options.refine``.
        name: the photo's name in the refine's progress bar (default: the file name).
        later: leave the relief and the relit panel to :func:`write_maps`, which computes them while the maps'
            files are written (the maps come without their relief, the panel as a function that renders it).

    Returns:
        ``(maps, relit, detail)``: the :class:`~svbrdf.runtime.core.maps.Maps` (the requested maps, at the processed
        size, ``render_config`` = ``config``), the relit panel (sRGB (h, 3 w, 3), None without all four maps) and a
        short report (``"model 0.41 s"``, ``"refined (100 it): held-out error ..."``, ...).

    Raises:
        SvbrdfError: the photo cannot be read or processed; with ``options.tileable``, maps smaller than
            :data:`~svbrdf.runtime.post.tileable.MIN_SIZE` a side (the message names ``photo``).
    """
    from ..outputs.texture_set import relit_panel

    if config is None:
        config = options.render_config(session)
    camera = photo_camera(photo, options.fov, config.fov_deg)
    config = config.replace(fov_deg=camera["fov_deg"])
    if options.refine:
        if refine is None:
            raise ValueError("options.refine needs the refine function (svbrdf.runtime.inference.refine.load_refine)")
        image = read_image(photo, max_size=options.max_size)
        warn_if_greyscale(image, str(photo))
        maps = _refine(refine, image, session, config, options, name or photo.name)
        record = maps.meta["refine"]
        if record["kept"] == "refined":
            detail = f"refined ({record['iterations']} it): held-out error {record['heldout_rmse_refined']:.3f} " \
                     f"vs the preview's {record['heldout_rmse_preview']:.3f}"
        else:
            detail = f"refine kept the preview: held-out error {record['heldout_rmse_refined']:.3f} vs the " \
                     f"preview's {record['heldout_rmse_preview']:.3f}"
            if record["reason"] == "burn-in":
                detail += f", but its burn-in {record['burn_in_refined']:.4f} is above the preview's " \
                          f"{record['burn_in_preview']:.4f}"
        # The refine fits (and renders) every map; only the requested ones are written.
        maps = maps.subset(options.maps)
        maps.meta.update(source=str(photo), model={"path": str(session.path), "sha256": session.info.sha256},
                         maps=list(options.maps))
    else:
        maps = estimate(photo, session, max_size=options.max_size, tile=options.tile, maps=options.maps,
                        post=options.post, upsampling=options.upsampling, fov_deg=config.fov_deg)
        tiles = maps.meta["tiles"]
        detail = f"model {maps.meta['timings']['infer']:.2f} s" + (f", {tiles} tiles" if tiles > 1 else "")
    maps.render_config = config
    maps.meta["camera"] = camera
    if options.tileable:
        from ..post.tileable import make_tileable

        try:
            maps = make_tileable(maps)
        except SvbrdfError as exc:  # a photo too small for it: say which one
            raise SvbrdfError(f"{photo}: --tileable: {exc}") from None
        worst = [s["after"] for s in maps.meta["tileable"]["join"].values() if s["after"] is not None]
        detail += f", tileable (join score {max(worst):.2f})" if worst else ", tileable"
    if later:
        return maps, functools.partial(relit_panel, maps, config) if maps.complete else None, detail
    # The relief (height and AO from the normals) and the relit panel need only the final maps: on two threads (numpy
    # leaves the GIL in their large operations; at 1024 px the relief takes 0.09 s and the panel 0.15 s on their own).
    relit_job = None
    with ThreadPoolExecutor(1) as pool:
        if maps.complete:
            relit_job = pool.submit(relit_panel, maps, config)  # at its display size (block means)
        if options.relief:
            maps = _with_relief(maps, options)
    relit = relit_job.result() if relit_job is not None else None
    return maps, relit, detail


def process_capture(folder: Path, options: PhotoOptions, session: PreviewSession, capture, config=None,
                    progress: Optional[Callable[[int, float], None]] = None):
    """One texture set fitted to every view of a calibrated multi-view flash capture (``svbrdf-preview
    --capture``; :mod:`svbrdf.trainer.capture`, passed as ``capture`` by
    :func:`svbrdf.runtime.inference.refine.load_capture`): the views' previews averaged, then fitted to all
    views at once, in the capture's plane frame.

    Returns:
        ``(maps, relit, detail)`` as :func:`process_photo` (``later``): the maps carry ``meta["capture"]`` and the
        capture's ``camera`` (the field of view of its mean camera height, ``fov_source`` ``"calibration"``).

    Raises:
        SvbrdfError: no calibration in ``folder``, none of its views on disk, a view photo on disk that the
            calibration does not list, views of different sizes or not square, or a view that cannot be read (one
            line naming the file).
    """
    from ..outputs.texture_set import relit_panel

    folder = Path(folder)
    if not folder.is_dir():
        raise SvbrdfError(f"{folder}: --capture needs a folder of views (NN.png) and their calibration")
    calib = capture.read_calibration(folder)
    if calib is None:
        raise SvbrdfError(f"{folder}: not a calibrated capture (no parameters.json or optim.json beside the views)")
    unlisted = sorted(p.name for p in folder.iterdir() if p.stem.isdigit() and int(p.stem) not in calib.views
                      and int(p.stem) not in calib.missing and capture.view_file(folder, int(p.stem)) == p)
    if unlisted:
        raise SvbrdfError(f"{folder}: {', '.join(unlisted)} {'is' if len(unlisted) == 1 else 'are'} not in "
                          f"{calib.path.name} (it lists views {', '.join(str(i) for i in sorted(calib.views))}): a view "
                          f"without its camera and light cannot be fitted; add it to the calibration or move it away")
    with warnings.catch_warnings(record=True) as caught:  # said once for all the views, not once per view
        warnings.simplefilter("always")
        photos = {i: read_image(capture.view_file(folder, i), max_size=options.max_size) for i in sorted(calib.views)}
    said: dict = {}
    for w in caught:
        said.setdefault(str(w.message).split(": ", 1)[-1], []).append(w)
    for text, ws in said.items():
        message = ws[0].message if len(ws) == 1 else f"{folder}: {len(ws)} views: {text}"
        warnings.warn(message if isinstance(message, Warning) else ws[0].category(message), stacklevel=2)
    sizes = {p.shape[:2] for p in photos.values()}
    if len(sizes) > 1:
        raise SvbrdfError(f"{folder}: the views are of different sizes ({', '.join(f'{w}x{h}' for h, w in sorted(sizes))}); "
                          f"a capture's views are rectified to one square of the plane")
    (h, w), = sizes
    if h != w:
        raise SvbrdfError(f"{folder}: the views are {w}x{h} px, not square: {calib.path.name} gives the camera and "
                          f"light over one square of the plane {calib.width_cm:g} cm wide, which a view shows whole")
    previews = [estimate(p, session, max_size=options.max_size, tile=options.tile, post=options.post,
                         upsampling=options.upsampling) for p in photos.values()]
    prior = capture.average_maps(previews)
    fitted = capture.fit_capture(photos, calib, prior, iters=options.iters or capture.ITERS,
                                 threads=options.threads, callback=progress)
    fov = capture.capture_fov(calib)
    config = (config or options.render_config(session)).replace(fov_deg=fov)
    maps = fitted.subset(options.maps) if options.maps != MAP_NAMES else fitted
    maps.render_config = config
    maps.meta.update(source=str(folder), model={"path": str(session.path), "sha256": session.info.sha256},
                     maps=list(options.maps),
                     camera={"fov_deg": round(fov, 3), "fov_source": "calibration",
                             "how": f"{calib.path.name}: the mean camera height over the {calib.width_cm:g} cm width"})
    if options.tileable:
        from ..post.tileable import make_tileable

        try:
            maps = make_tileable(maps)
        except SvbrdfError as exc:
            raise SvbrdfError(f"{folder}: --tileable: {exc}") from None
    detail = (f"{len(photos)} views fitted together, {fitted.meta['capture']['iterations']} it "
              f"(photo error {fitted.meta['capture']['loss']:.4f})")
    return maps, functools.partial(relit_panel, maps, config) if maps.complete else None, detail


#: The photo's long side (pixels) at which :func:`photo_camera` estimates the field of view from the fall-off.
CAMERA_ESTIMATE_SIZE = 256


def photo_camera(photo: Path, fov: Optional[float], default: float, image: Optional[np.ndarray] = None) -> dict:
    """The camera of ``photo`` for every physical step (the relit panel, the viewer, the refine's renderer):
    ``{"fov_deg", "fov_source", "how"}``, the field of view across the photo's width, from the first of

    1. ``fov`` (``"option"``);
    2. the file's EXIF record (``"exif"``, :func:`svbrdf.runtime.io.exif.exif_camera`; an absurd record is a
       warning and goes on to 3.);
    3. the flash's fall-off in the photo (``"estimated"``, :func:`svbrdf.runtime.core.falloff.estimate_fov` on the
       photo at :data:`CAMERA_ESTIMATE_SIZE` px, or on ``image`` when given), where the estimate is reliable;
    4. ``default`` (the model's, ``"default"``; ``how`` says why the estimate was not used).

    In cases 3 and 4 the fit also says where the flash was (``FovEstimate.out_of_frame``), recorded as
    ``"highlight"`` (``"out of frame"`` or ``"absent"``: no fall-off at all); a highlight out of frame is also one
    :class:`ImageWarning` naming the photo and the camera assumed. Its maps are made as any other's.

    Args:
        photo: the photo file.
        fov: ``--fov`` (degrees) or None.
        default: the model's field of view (degrees).
        image: the photo already read (linear (H, W, 3), any size), to save reading it again.

    Raises:
        ImageError: the photo cannot be read (step 3 reads it; one line naming the file).
    """
    if fov is not None:
        return {"fov_deg": float(fov), "fov_source": "option", "how": "--fov"}
    from ..core.falloff import estimate_fov
    from ..io.exif import exif_camera

    exif = exif_camera(photo)
    if exif is not None:
        return {"fov_deg": round(exif.fov_deg, 3), "fov_source": "exif", "how": exif.how}
    if image is None:
        with warnings.catch_warnings():  # the photo itself is read (and its problems said) by the caller
            warnings.simplefilter("ignore", ImageWarning)
            image = read_image(photo, max_size=CAMERA_ESTIMATE_SIZE)
    elif max(image.shape[:2]) > 2 * CAMERA_ESTIMATE_SIZE:
        image = resize_long_side(image, CAMERA_ESTIMATE_SIZE)
    try:
        found, why = estimate_fov(image), ""
    except ValueError as exc:  # a photo too small for the grid
        found, why = None, str(exc)
    if found is not None and found.reliable:
        camera = {"fov_deg": round(found.fov_deg, 3), "fov_source": "estimated",
                  "how": f"the flash's fall-off ({found.cells[0]} of {found.cells[1]} cells, fall-off "
                         f"{found.contrast:.1f} sigma, foot point ({found.centre[0]:.2f}, {found.centre[1]:.2f}))"}
    else:
        why = found.reason if found is not None else why
        camera = {"fov_deg": float(default), "fov_source": "default",
                  "how": f"the model's training camera (no EXIF focal length; no estimate from the fall-off: {why})"}
    if found is not None and found.out_of_frame:
        camera["highlight"] = found.out_of_frame
    if camera.get("highlight") == "out of frame":
        warnings.warn(ImageWarning(f"{photo}: the flash highlight is out of frame; the maps assume a camera of "
                                   f"{camera['fov_deg']:.1f} deg ({camera['fov_source']}) with the flash above the "
                                   f"photo's centre"), stacklevel=2)
    return camera


def _with_relief(maps: Maps, options: PhotoOptions) -> Maps:
    """``maps`` with the relief ``options`` ask for, timed in their meta; errors name the photo."""
    t = time.perf_counter()
    try:
        maps = maps.with_relief(tileable=options.tileable, maps=options.relief, ao_strength=options.ao_strength)
    except SvbrdfError as exc:
        raise SvbrdfError(f"{maps.meta.get('source', '<maps>')}: {exc}") from None
    maps.meta.setdefault("timings", {})["relief"] = time.perf_counter() - t
    return maps


def write_maps(maps: Maps, relit: Union[None, np.ndarray, Callable[[], np.ndarray]], out_dir: Path, name: str,
               options: PhotoOptions, extra_meta: dict) -> dict:
    """Write ``maps`` (and ``relit``) as the texture set ``name`` in ``out_dir`` for ``options.target`` (all or
    nothing, :mod:`svbrdf.runtime.outputs.texture_set`), and with ``options.view`` its viewer page
    (:func:`svbrdf.runtime.outputs.viewer.write_viewer`); returns the written paths by role. Maps without the relief
    ``options`` ask for (:func:`process_photo` with ``later``) get it here: for the project's own layout while the
    maps' files are written, for a target first; ``relit`` may be a function that renders the panel."""
    from ..outputs.texture_set import write_texture_set

    relief = functools.partial(_with_relief, options=options) if options.relief and maps.relief is None else None
    if options.target != "generic":
        from ..outputs.targets import write_target

        if relief is not None:
            maps = relief(maps)
        paths = write_target(maps, out_dir, name, options.target, force=options.force, extra_meta=extra_meta,
                             relit=relit() if callable(relit) else relit)
        if options.view:  # the page relights the maps themselves, whatever layout the target's files have
            from ..outputs.viewer import VIEWER_FILE, write_maps_viewer

            paths["viewer"] = write_maps_viewer(maps, out_dir / VIEWER_FILE.format(name=name), name=name,
                                                force=options.force)
        return paths
    paths = write_texture_set(maps, out_dir, name, normal=options.normal, fmt=options.format,
                              force=options.force, extra_meta=extra_meta, relit=relit, relief=relief)
    if options.view:
        from ..outputs.viewer import write_viewer

        paths["viewer"] = write_viewer(paths["sidecar"], force=options.force)
    return paths
