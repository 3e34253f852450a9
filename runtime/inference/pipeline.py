"""The per-photo pipeline: photo -> :class:`~svbrdf.runtime.core.maps.Maps` (:func:`estimate`); no torch. The
options of the CLIs and the photo -> texture set path are the layer above (:mod:`svbrdf.runtime.workflow`).

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
   does not grow with the file's size (:func:`~svbrdf.runtime.io.images.read_image`; on the guided path
   :func:`~svbrdf.runtime.inference.reading.read_streamed`);
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
   nearly grey base colour for every material (docs/decisions/008-photo-colour.md);
6. remove the smooth radial trend around the photo's flash highlight from the base colour, specular and roughness
   (:func:`svbrdf.runtime.post.flash_trend.remove_flash_trend`, :attr:`PostProcess.flash_trend`; first the highlight fill, :attr:`PostProcess.highlight_fill`): what the network left of the
   highlight and the fall-off (docs/decisions/004-flash-trend-removal.md); the base colour's trend as one
   brightness gain for its three channels (its hue kept), then its coarse colours made the photo's
   (:func:`svbrdf.runtime.post.photo_colour.local_colour`);
7. make the specular one level, its median (:func:`svbrdf.runtime.post.flash_trend.uniform_specular`,
   :attr:`PostProcess.uniform_specular`): its spatial variation is noise by measurement.
"""

from __future__ import annotations

import os
import time
import warnings
from typing import Callable, Iterable, Optional, Union

import numpy as np

from ..core.maps import N_CHANNELS, SLICES, Maps, select_maps
from ..errors import ImageError, SvbrdfError
from ..io.images import ImageWarning
from ..io.process import check_memory
from ..post import PostProcess
from ..post import apply as apply_post
from ..post.flash_trend import even_lighting
from .guided import Upsampling, guided_upsample, luminance, network_photo
from .manifest import MIN_SIZE
from .reading import read_photo, read_streamed, warn_if_greyscale
from .session import PreviewSession, load_session
from .tiling import DEFAULT_OVERLAP, tile_boxes, tiled_apply

#: Long side (pixels) larger photos are downsized to, and the tile size of the tiled inference.
DEFAULT_MAX_SIZE = 2048
DEFAULT_TILE = 1024

__all__ = ["estimate", "DEFAULT_MAX_SIZE", "DEFAULT_TILE", "DEFAULT_OVERLAP", "Upsampling"]


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
    fov_deg: Union[None, float, Callable[[np.ndarray], float]] = None,
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
        fov_deg: the photo's field of view across its width, degrees
            (:func:`~svbrdf.runtime.workflow.camera.photo_camera`): the camera of the corrections that model the
            flash (the highlight's shoulder) and of the returned ``render_config``; None: the session's (the
            model's training camera); or a function of the photo as read (linear (h, w, 3), at most the network's
            size: the block means of a larger photo) that returns it, called once, so that a camera found from the
            pixels needs no second read (:func:`~svbrdf.runtime.workflow.camera.image_camera`).

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
        ImageWarning: a greyscale photo (:func:`~svbrdf.runtime.inference.reading.warn_if_greyscale`); a photo
            downsized to ``max_size`` (files of any size are read in strips:
            :func:`~svbrdf.runtime.io.images.read_image`).
    """
    if max_size < MIN_SIZE or tile < MIN_SIZE or not 0 <= 2 * overlap <= tile:
        raise ValueError(f"need max_size >= {MIN_SIZE}, tile >= {MIN_SIZE} and 0 <= 2 * overlap <= tile; "
                         f"got max_size={max_size}, tile={tile}, overlap={overlap}")
    names = None if maps is None else select_maps(maps)
    timings = {}
    t = time.perf_counter()
    info = None if isinstance(photo, np.ndarray) else check_memory(photo, max_size)  # the one header read
    streamed = None if info is None else read_streamed(photo, info, max_size, upsampling)
    if streamed is not None:  # a large photo file: only its block means and luminance are read into memory
        timings["read"], timings["resize"] = time.perf_counter() - t, 0.0
        return _estimate_guided(str(photo), streamed, timings, session, names, tile, overlap, post, upsampling,
                                fov_deg)
    name, image, (in_h, in_w) = read_photo(photo, max_size, info)
    if min(in_h, in_w) < MIN_SIZE:
        raise ImageError(f"{name}: image is {in_w}x{in_h} pixels; the model needs at least {MIN_SIZE}x{MIN_SIZE}")
    timings["read"] = time.perf_counter() - t
    if session is None:
        session = load_session(maps=names)
    names = names or session.maps
    graph = session.graph_for(names)

    t = time.perf_counter()
    warn_if_greyscale(image, name)  # the photo is already downsized (by read_photo)
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
    if callable(fov_deg):
        fov_deg = fov_deg(image)
    config = session.render_config if fov_deg is None else session.render_config.replace(fov_deg=float(fov_deg))
    out = apply_post(Maps.unpack(packed, meta, maps=names, render_config=config).clipped(), image,
                     post)
    timings["post"] = time.perf_counter() - t
    out.meta["timings"] = timings
    return out


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

