"""Preview inference with onnxruntime: photo -> :class:`~svbrdf.runtime.maps.Maps` (no torch).

::

    session = load_session()                     # model lookup: see svbrdf.runtime.manifest
    maps = estimate("photo.jpg", session)        # Maps, linear, OpenGL normals, meta with timings
    normal = estimate("photo.jpg", session, maps=["normal"]).normal   # runs only the normal decoder

Pipeline of :func:`estimate`:

1. read the photo with :func:`svbrdf.runtime.imageio.read_image` (linear float32) or take an array;
2. if its long side exceeds ``max_size``, downsize it (and warn) with OpenImageIO ``ImageBufAlgo.resize`` and
   the ``"blackman-harris"`` filter (:data:`~svbrdf.runtime.imageio.RESIZE_FILTER`): a non-negative kernel, so a
   linear photo stays >= 0 and a flash highlight does not ring into negative values as with the default
   lanczos3. A file at least twice ``max_size`` is read in strips averaged over pixel blocks first, so memory
   does not grow with the file's size (:func:`~svbrdf.runtime.imageio.read_image`);
3. divide the photo by its own smooth lighting (:func:`svbrdf.runtime.flash_trend.even_lighting`,
   :data:`EVEN_LIGHTING`): the network sees the material evenly lit, not the flash's fall-off and broad highlight
   (what the model records decides: :attr:`PreviewSession.even_lighting`; a stage one shipped with
   ``network_input`` "photo" sees the photo as it is); run the model on that (the full graph, or the part graph
   of the one decoder the requested maps need: see :meth:`PreviewSession.graph_for`) in one pass when the image
   fits in one ``tile`` x ``tile`` window, else in overlapping tiles blended with
   :func:`svbrdf.runtime.tiling.tiled_apply` (memory bounded by one tile's inference). The generator uses
   instance normalisation, so tiles see their own statistics: expect differences from a single pass that are small
   for stationary materials but not only at the seams;
4. clip every requested map to its range and renormalise the (blended) normals (:meth:`Maps.clipped`);
5. give the base colour the photo's colour balance (:func:`photo_colour`, :data:`COLOUR_FROM_PHOTO`): the
   generator's instance normalisation hides a photo's overall colour from it, and the learned stage one predicts a
   nearly grey base colour for every material (docs/benchmarks/prior/README.md, "Colour");
6. remove the smooth radial trend around the photo's flash highlight from the base colour, specular and roughness
   (:func:`svbrdf.runtime.flash_trend.remove_flash_trend`, :data:`FLASH_TREND`): what the network left of the
   highlight and the fall-off (docs/benchmarks/accuracy/README.md, "Now");
7. make the specular one level, its median (:func:`svbrdf.runtime.flash_trend.uniform_specular`,
   :data:`UNIFORM_SPECULAR`): its spatial variation is noise by measurement.

The session keeps onnxruntime's CPU memory arena (:data:`CPU_MEM_ARENA`). Without it every intermediate
tensor is fresh memory from the system and the one pass of a preview pays its page faults: on the 2-core
machine of docs/benchmarks/preview-speed, a 1024 px pass of the v1 model takes 1.0 s with the arena and
1.4 s without (a first pass in a fresh process). Every pass ends by handing the arena's memory back
(onnxruntime's arena shrinkage, :meth:`PreviewSession.run`): without that, the passes of a tiled photo (tiles
of several shapes) piled up arena chunks, and a 2048 x 1536 photo peaked at 1511 MiB instead of 837 MiB
(docs/benchmarks/large-photos).
"""

from __future__ import annotations

import json
import math
import os
import time
import warnings
from pathlib import Path
from typing import Iterable, Optional, Tuple, Union

import numpy as np

from .flash_trend import EVEN_LIGHTING_WIDTH, even_lighting, postprocess
from .errors import ImageError, ModelError, SvbrdfError
from .imageio import RESIZE_FILTER, ImageWarning, image_info, read_image, resize_long_side
from .maps import N_CHANNELS, SLICES, Maps, select_maps
from .manifest import (
    INPUT_NAME, MANIFEST_SCHEMA, MIN_SIZE, OUTPUT_NAME, PARTS, PRIOR_STAGE, ModelInfo, check_layout, find_model,
    recorded_even_lighting,
)
from .render import ZHAO, RenderConfig
from .tiling import DEFAULT_OVERLAP, block_mean, tile_boxes, tiled_apply

#: Long side (pixels) larger photos are downsized to, and the tile size of the tiled inference.
DEFAULT_MAX_SIZE = 2048
DEFAULT_TILE = 1024
#: Use onnxruntime's CPU memory arena (see the module docstring; the preview-speed benchmark's 'before' is False).
CPU_MEM_ARENA = True
#: Name of the complete graph (both decoders) among :attr:`PreviewSession.loaded` and ``meta["model"]["graph"]``.
FULL = "full"

__all__ = ["PreviewSession", "load_session", "estimate", "resize_long_side", "RESIZE_FILTER",
           "DEFAULT_MAX_SIZE", "DEFAULT_TILE", "DEFAULT_OVERLAP", "FULL", "CPU_MEM_ARENA", "warn_if_greyscale"]


def _first_line(exc: BaseException) -> str:
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    return lines[0][:200] if lines else type(exc).__name__


def _cpu_count() -> int:
    """Cores this process may run on (the affinity mask, as the trainer counts them)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


class PreviewSession:
    """onnxruntime sessions on an exported generator, with what its manifest says about it.

    A session may hold up to three onnxruntime sessions: the full graph and the part graphs of
    :data:`~svbrdf.runtime.manifest.PARTS`, each created on first use (:meth:`graph_for` picks the graph for a
    set of maps). The graph the session's default ``maps`` need is created at once, so a file onnxruntime
    cannot load fails here.

    Args:
        info: the located model (:func:`svbrdf.runtime.manifest.find_model`).
        threads: intra-op threads (default: every core this process may run on).
        maps: the maps :func:`estimate` computes by default (:func:`~svbrdf.runtime.maps.select_maps`;
            default all four).

    Attributes:
        info: :class:`~svbrdf.runtime.manifest.ModelInfo` (path, sha256, manifest, note).
        maps: the default maps, in :data:`~svbrdf.runtime.maps.MAP_NAMES` order.
        metadata: the manifest, or the metadata embedded in the ONNX file when there is no manifest.
        render_config: :class:`RenderConfig` the model was trained with (``ZHAO`` if unrecorded).
        providers: onnxruntime execution providers in use.
        threads: intra-op thread count.

    Raises:
        ModelError: onnxruntime cannot load the file, the graph is not ``image (1,3,H,W) -> maps (1,8,H,W)``,
            a model without manifest carries no svbrdf metadata / a different map layout / is a part graph,
            or a part file does not match the manifest.
        SvbrdfError: unknown map names.
    """

    def __init__(self, info: ModelInfo, threads: Optional[int] = None,
                 maps: Union[None, str, Iterable[str]] = None):
        self.info = info
        self.threads = int(threads or _cpu_count())
        self.maps = select_maps(maps)
        self.providers: list = []
        self._sessions: dict = {}  # graph name (FULL or a part) -> onnxruntime session, created on first use
        self._noted = False
        if info.manifest is not None:
            self.metadata = info.manifest
        else:
            self.metadata = self._embedded_metadata(self._session(FULL))
            check_layout(self.metadata, str(info.path))
        try:
            recorded_even_lighting(self.metadata)  # a bad record fails here, at load
        except ModelError as exc:
            raise ModelError(f"{info.path}: {exc}") from None
        try:
            render = self.metadata.get("render_config")
            self.render_config = RenderConfig(**render) if render else ZHAO
        except (TypeError, ValueError) as exc:
            raise ModelError(f"{info.path}: invalid render_config in the model metadata ({exc})") from None
        self._session(self.graph_for(self.maps))

    def _session(self, graph: str):
        if graph in self._sessions:
            return self._sessions[graph]
        import onnxruntime as ort

        path = self.info.path if graph == FULL else self.info.verify_part(graph)
        so = ort.SessionOptions()
        so.enable_cpu_mem_arena = CPU_MEM_ARENA
        so.intra_op_num_threads = self.threads
        so.inter_op_num_threads = 1
        so.log_severity_level = 3  # errors only: ORT's warnings are not actionable for a user
        cuda = "CUDAExecutionProvider" in ort.get_available_providers()
        providers = ["CUDAExecutionProvider", "CPUExecutionProvider"] if cuda else ["CPUExecutionProvider"]
        try:
            session = ort.InferenceSession(str(path), so, providers=providers)
        except Exception as exc:  # onnxruntime raises its own pybind classes (InvalidProtobuf, Fail, ...)
            raise ModelError(f"{path}: onnxruntime cannot load the model ({_first_line(exc)})") from None
        inputs, outputs = session.get_inputs(), session.get_outputs()
        if ([i.name for i in inputs] != [INPUT_NAME] or [o.name for o in outputs] != [OUTPUT_NAME]
                or len(inputs[0].shape) != 4):
            raise ModelError(
                f"{path}: not an svbrdf generator (expected input {INPUT_NAME!r} (1, 3, H, W) and output "
                f"{OUTPUT_NAME!r}, got {[i.name for i in inputs]} -> {[o.name for o in outputs]})"
            )
        self.providers = session.get_providers()
        self._sessions[graph] = session
        return session

    def _run_options(self):
        """Every pass hands the arena's memory back when it ends (onnxruntime's arena shrinkage): the arena
        speeds up the pass, and a tiled photo's passes of several shapes do not pile up chunks."""
        if self.__dict__.get("_run_opts") is None:
            import onnxruntime as ort

            opts = ort.RunOptions()
            if CPU_MEM_ARENA:
                opts.add_run_config_entry("memory.enable_memory_arena_shrinkage", "cpu:0")
            self._run_opts = opts
        return self._run_opts

    def _embedded_metadata(self, session) -> dict:
        props = session.get_modelmeta().custom_metadata_map
        try:
            meta = {k: json.loads(v) for k, v in props.items()}
        except ValueError:
            meta = {}
        if meta.get("schema") != MANIFEST_SCHEMA:
            raise ModelError(
                f"{self.info.path}: no manifest and no svbrdf metadata in the file; re-export it with svbrdf-export"
            )
        if meta.get("part"):
            raise ModelError(f"{self.info.path}: a part graph ({', '.join(meta['part'].get('maps') or [])} only); "
                             f"pass the full model file")
        return meta

    @property
    def path(self) -> Path:
        return self.info.path

    @property
    def even_lighting(self) -> Optional[float]:
        """The width of :func:`~svbrdf.runtime.flash_trend.even_lighting` the network is shown the photo at
        (``None``: the photo as it is), from what the model was trained on.

        A model fine-tuned on a photo (any stage but ``"prior"``) saw what its ``train_config.even_lighting``
        says (absent or 0, as in every export before it existed and in the paper's presets: the photo itself). A
        stage one (``"prior"``, or no training record) learned on flash photos as they are; it is shown what its
        ``network_input`` record says (:func:`~svbrdf.runtime.manifest.recorded_even_lighting`, chosen by
        measurement when it was shipped), and without one (v1) evenly lit at :data:`EVEN_LIGHTING`, which measured
        better for v1 (docs/benchmarks/refine-detail/flat-input/); its ``train_config`` is the fine-tune preset
        meant for it, not its own input.
        """
        training = self.metadata.get("training") or {}
        if training.get("stage") in (None, PRIOR_STAGE):
            recorded = recorded_even_lighting(self.metadata)
            return (recorded if recorded is not None else EVEN_LIGHTING) or None
        return float((training.get("train_config") or {}).get("even_lighting") or 0.0) or None

    @property
    def loaded(self) -> Tuple[str, ...]:
        """Graphs created so far (``"full"`` and/or part names), in creation order."""
        return tuple(self._sessions)

    def graph_for(self, maps: Union[None, str, Iterable[str]] = None) -> str:
        """The cheapest graph that computes ``maps`` (default: the session's): the part whose maps include
        them all when the model has its file, else ``"full"`` (also for maps of both decoders: one encoder pass
        then costs less than two parts)."""
        want = set(self.maps if maps is None else select_maps(maps))
        part = next((p for p, names in PARTS.items() if want <= set(names)), None)
        if part is None or part not in self.info.parts or not self.info.part_path(part).is_file():
            return FULL
        return part

    def _fallback_note(self, maps: Tuple[str, ...], graph: str) -> None:
        """Warn once per session when a subset runs the full graph only because the part graph is missing."""
        if self._noted or graph != FULL or not any(set(maps) <= set(n) for n in PARTS.values()):
            return
        self._noted = True
        why = "was exported without part graphs" if not self.info.parts else "has its part graph file missing"
        warnings.warn(f"{self.info.path.name} {why}: computing all maps to return {', '.join(maps)} "
                      f"(re-export it with svbrdf-export to run only the decoder needed)", stacklevel=3)

    def run(self, image: np.ndarray, maps: Union[None, str, Iterable[str]] = None) -> np.ndarray:
        """One forward pass of the graph :meth:`graph_for` ``maps`` picks.

        Args:
            image: (H, W, 3) float32 linear RGB, H, W >= 8.
            maps: the maps wanted (default: the session's).

        Returns:
            (H, W, 8) float32 packed maps (layout of :mod:`svbrdf.runtime.maps`), not yet clipped; a part graph
            leaves the channels of the other maps NaN.
        """
        names = self.maps if maps is None else select_maps(maps)
        graph = self.graph_for(names)
        self._fallback_note(names, graph)
        session = self._session(graph)
        h, w = image.shape[:2]
        x = np.ascontiguousarray(image.transpose(2, 0, 1)[None], dtype=np.float32)
        try:
            y = session.run([OUTPUT_NAME], {INPUT_NAME: x}, self._run_options())[0]
        except Exception as exc:  # onnxruntime's RuntimeException / allocation failures
            raise SvbrdfError(f"{self.info.path}: inference failed on a {w}x{h} input ({_first_line(exc)})") from None
        if y.shape != (1, N_CHANNELS, h, w):
            raise ModelError(f"{self.info.path}: model returned {y.shape} for a {w}x{h} input")
        return y[0].transpose(1, 2, 0)


def load_session(model: Union[str, os.PathLike, None] = None, threads: Optional[int] = None,
                 maps: Union[None, str, Iterable[str]] = None) -> PreviewSession:
    """Find, verify and load a model (lookup order in :mod:`svbrdf.runtime.manifest`).

    ``maps`` (default all) are the maps :func:`estimate` computes by default; only the graph they need is
    loaded now (a part graph for the maps of one decoder, when the model has it), others on first use.

    Raises:
        SvbrdfError: unknown map names (checked first).
        ModelError: no model, missing file, sha256/manifest mismatch, or a file onnxruntime cannot load.
    """
    maps = select_maps(maps)
    return PreviewSession(find_model(model), threads=threads, maps=maps)


#: Give the preview's base colour the photo's colour balance (:func:`photo_colour`): the generator normalises its
#: features per image (instance normalisation), so it cannot see a photo's overall colour and predicts a nearly grey
#: base colour for every material (docs/benchmarks/prior/README.md, "Colour").
COLOUR_FROM_PHOTO = True
#: The preview's maps lose their smooth radial trend around the photo's flash highlight
#: (:func:`svbrdf.runtime.flash_trend.remove_flash_trend`): what the network left of the highlight and fall-off.
FLASH_TREND = True
#: The preview's specular map is one level per photo, its median (:func:`svbrdf.runtime.flash_trend.uniform_specular`):
#: its spatial variation measured as noise (docs/benchmarks/accuracy/README.md, "Now").
UNIFORM_SPECULAR = True
#: The region of a clipped flash highlight and its shoulder is filled with the material's own maps from elsewhere
#: (:func:`svbrdf.runtime.highlight_fill.fill_highlight`): no disc, no blob (docs/benchmarks/highlight-fill/,
#: docs/benchmarks/refine-detail/lobe-and-rings/).
HIGHLIGHT_FILL = True
#: The network sees the photo divided by its own smooth lighting (:func:`svbrdf.runtime.flash_trend.even_lighting`,
#: a low pass of this standard deviation, a fraction of the width; ``None`` or 0: the photo as it is). The flash's
#: fall-off and the broad part of its highlight are then not in the network's input, so it cannot paint them into
#: the maps (docs/benchmarks/refine-detail/flat-input/). For a stage one that records no ``network_input`` of its
#: own (v1); a fine-tuned model is shown what it was trained on (:attr:`PreviewSession.even_lighting`).
EVEN_LIGHTING: Optional[float] = EVEN_LIGHTING_WIDTH
#: :func:`photo_colour` takes its mean colours from a block-mean copy no longer than this (they are global statistics;
#: at 1024 px the full-size quantile alone cost 0.1 s).
COLOUR_MAX_SIDE = 256
#: Pixels whose luminance is above this quantile of the photo's are left out of :func:`photo_colour` (the flash
#: highlight is the light's colour, not the material's).
COLOUR_QUANTILE = 0.9


def photo_colour(diffuse: np.ndarray, photo: np.ndarray) -> np.ndarray:
    """The diffuse albedo with its mean colour balance set to the photo's, luminance kept.

    Over the photo's pixels that are not clipped and not in its brightest ``1 - COLOUR_QUANTILE`` (the
    highlight; pixels of a block-mean copy no longer than :data:`COLOUR_MAX_SIDE`), the per-channel gains
    ``g_c = (p_c / mean(p)) / (d_c / mean(d))`` (p, d: mean photo and diffuse colour there, linear) multiply the
    diffuse; a grey photo keeps a grey base colour, a base colour already balanced like the photo is unchanged.

    Args:
        diffuse: (H, W, 3) linear diffuse albedo in [0, 1].
        photo: (H, W, 3) linear photo the maps were estimated from, same size.

    Returns:
        (H, W, 3) float32 linear diffuse in [0, 1].
    """
    k = max(1, math.ceil(max(photo.shape[:2]) / COLOUR_MAX_SIDE))  # the statistics of a block-mean copy
    small_photo, small_diffuse = block_mean(photo, k), block_mean(diffuse, k)
    lum = small_photo.mean(axis=-1)
    keep = (small_photo.max(axis=-1) < 0.98) & (lum <= np.quantile(lum, COLOUR_QUANTILE)) & (lum > 1e-4)
    if keep.sum() < 64:
        return diffuse
    p = small_photo[keep].mean(axis=0).astype(np.float64)
    d = small_diffuse[keep].mean(axis=0).astype(np.float64)
    if p.min() <= 1e-6 or d.min() <= 1e-6:
        return diffuse
    gains = (p / p.mean()) / (d / d.mean())
    return np.clip(diffuse * gains.astype(np.float32), 0.0, 1.0)


#: Largest channel spread (linear) of a photo taken as greyscale by :func:`warn_if_greyscale`.
GREY_TOLERANCE = 1.0 / 512


def warn_if_greyscale(image: np.ndarray, name: str) -> bool:
    """Warn (:class:`~svbrdf.runtime.imageio.ImageWarning`) when an (H, W, 3) photo has no colour: a one-channel
    file (read as R = G = B) or three channels equal within :data:`GREY_TOLERANCE`. The model then invents the
    colour of the diffuse and specular maps. Returns whether it warned."""
    grey = all(float(np.abs(image[..., c] - image[..., 1]).max()) <= GREY_TOLERANCE for c in (0, 2))
    if grey:
        warnings.warn(ImageWarning(f"{name}: greyscale photo (no colour); the model invents the colour of the "
                                   f"diffuse and specular maps"), stacklevel=2)
    return grey


def _as_image(photo: Union[str, os.PathLike, np.ndarray], max_size: int) -> tuple:
    """``(name, (H, W, 3) linear image with long side <= max_size, (height, width) before downsizing)``."""
    if isinstance(photo, np.ndarray):
        name = "<array>"
        if photo.ndim != 3 or photo.shape[-1] != 3:
            raise ImageError(f"{name}: expected an (H, W, 3) linear RGB array, got shape {photo.shape}")
        image = np.asarray(photo, dtype=np.float32)
        if not np.all(np.isfinite(image)):
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
    info = image_info(photo)
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
) -> Maps:
    """SVBRDF maps of one flash photo: all four, or only ``maps`` (running only the decoder they need).

    Args:
        photo: image file path, or an (H, W, 3) float32 **linear** RGB array; at least 8 x 8 pixels.
        session: a loaded :class:`PreviewSession` (default: :func:`load_session` with the default lookup).
        max_size: longer photos are downsized so their long side is ``max_size`` (see the module docstring).
        tile: images whose long side (after downsizing) exceeds ``tile`` are processed in ``tile`` x ``tile``
            windows; ``tile >= 8``.
        overlap: overlap of neighbouring windows, ``0 <= 2 * overlap <= tile``.
        maps: the maps to compute, names of :data:`~svbrdf.runtime.maps.MAP_NAMES` (or aliases; see
            :func:`~svbrdf.runtime.maps.select_maps`); default: the session's ``maps`` (all four unless the
            session was loaded for a subset). The maps of one decoder (``roughness``/``normal`` or
            ``diffuse``/``specular``) run that decoder's part graph when the model has it; a model exported
            without parts runs the full graph and warns once (``UserWarning``).

    Returns:
        :class:`Maps` at the processed size with the requested maps (the others ``None``): diffuse (H, W, 3)
        linear [0, 1], specular and roughness (H, W, 1) [0, 1], normal (H, W, 3) unit OpenGL. ``meta`` holds
        ``source``, ``model`` (path, sha256, verified, ``graph``: ``"full"`` or the part that ran), ``maps``
        (the names computed), ``input_size`` and ``size`` ([H, W]), ``resized``, ``tiles``, ``tile``,
        ``overlap``, ``threads``, ``timings`` (seconds for ``read``, ``resize``, ``infer``, ``post``) and
        ``burn_in``: the label-free highlight burn-in of the maps returned
        (:func:`svbrdf.runtime.burn_in.photo_burn_in`; ``burn_in["burn_in"]`` is the headline, the worst map's
        disc or ring score, 0.1-0.3 for a stationary material, higher when the flash stayed in the maps), ``burn_in_model`` the same of
        the network's maps before the flash trend was removed (:data:`FLASH_TREND`; what the skip rule of
        ``--quality auto`` reads), ``flash_trend`` what was removed and ``uniform_specular`` the specular level
        (:data:`UNIFORM_SPECULAR`). ``render_config`` is the
        session's (the model's training renderer).

    Raises:
        ImageError: unreadable photo, bad array, or an image smaller than 8 px (before or after downsizing).
        ModelError: no usable model (when ``session`` is None), or a part file that does not match the manifest.
        SvbrdfError: unknown map names, or the model returned NaN/Inf maps (float photos with absurd values, near
            the float32 limit).
        ValueError: invalid ``max_size``, ``tile`` or ``overlap``.

    Warns:
        ImageWarning: a greyscale photo (:func:`warn_if_greyscale`); a photo downsized to ``max_size`` (files of
            any size are read in strips: :func:`~svbrdf.runtime.imageio.read_image`).
    """
    if max_size < MIN_SIZE or tile < MIN_SIZE or not 0 <= 2 * overlap <= tile:
        raise ValueError(f"need max_size >= {MIN_SIZE}, tile >= {MIN_SIZE} and 0 <= 2 * overlap <= tile; "
                         f"got max_size={max_size}, tile={tile}, overlap={overlap}")
    names = None if maps is None else select_maps(maps)
    timings = {}
    t = time.perf_counter()
    name, image, (in_h, in_w) = _as_image(photo, max_size)
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

    t = time.perf_counter()
    width = session.even_lighting
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
    out = Maps.unpack(packed, meta, maps=names, render_config=session.render_config).clipped()
    if COLOUR_FROM_PHOTO and out.diffuse is not None:
        out = out._with({**dict(out.items()), "diffuse": photo_colour(out.diffuse, image)})
    out = postprocess(out, image, flash_trend=FLASH_TREND, specular_level=UNIFORM_SPECULAR,
                      highlight_fill=HIGHLIGHT_FILL)
    timings["post"] = time.perf_counter() - t
    out.meta["timings"] = timings
    return out
