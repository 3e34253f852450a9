"""Preview inference with onnxruntime: photo -> :class:`~svbrdf.runtime.maps.Maps` (no torch).

::

    session = load_session()                     # model lookup: see svbrdf.runtime.models
    maps = estimate("photo.jpg", session)        # Maps, linear, OpenGL normals, meta with timings

Pipeline of :func:`estimate`:

1. read the photo with :func:`svbrdf.runtime.imageio.read_image` (linear float32) or take an array;
2. if its long side exceeds ``max_size``, downsize it with OpenImageIO ``ImageBufAlgo.resize`` and the
   ``"blackman-harris"`` filter (:data:`RESIZE_FILTER`): a non-negative kernel, so a linear photo stays >= 0
   and a flash highlight does not ring into negative values as with the default lanczos3;
3. run the model in one pass when the image fits in one ``tile`` x ``tile`` window, else in overlapping
   tiles blended with :func:`svbrdf.runtime.tiling.tiled_apply` (memory bounded by one tile's inference).
   The generator uses instance normalisation, so tiles see their own statistics: expect differences from a
   single pass that are small for stationary materials but not only at the seams;
4. clip every map to its range and renormalise the (blended) normals (:meth:`Maps.clipped`).

The session uses ``enable_cpu_mem_arena=False``: the default arena roughly doubles peak memory at large
sizes for no speed gain (measured in the platform notes).
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Optional, Union

import numpy as np

from .errors import ImageError, ModelError, SvbrdfError
from .maps import N_CHANNELS, Maps
from .models import INPUT_NAME, MANIFEST_SCHEMA, MIN_SIZE, OUTPUT_NAME, ModelInfo, check_layout, find_model
from .render import ZHAO, RenderConfig
from .tiling import tile_boxes, tiled_apply

#: OpenImageIO filter used to downsize photos larger than ``max_size``.
RESIZE_FILTER = "blackman-harris"
DEFAULT_MAX_SIZE = 2048
DEFAULT_TILE = 1024
DEFAULT_OVERLAP = 64

__all__ = ["PreviewSession", "load_session", "estimate", "resize_long_side", "RESIZE_FILTER",
           "DEFAULT_MAX_SIZE", "DEFAULT_TILE", "DEFAULT_OVERLAP"]


def _first_line(exc: BaseException) -> str:
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    return lines[0][:200] if lines else type(exc).__name__


def _cpu_count() -> int:
    """Cores this process may run on (the affinity mask, as the trainer counts them)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


class PreviewSession:
    """An onnxruntime session on an exported generator, with what its manifest says about it.

    Args:
        info: the located model (:func:`svbrdf.runtime.models.find_model`).
        threads: intra-op threads (default: every core this process may run on).

    Attributes:
        info: :class:`~svbrdf.runtime.models.ModelInfo` (path, sha256, manifest, note).
        metadata: the manifest, or the metadata embedded in the ONNX file when there is no manifest.
        render_config: :class:`RenderConfig` the model was trained with (``ZHAO`` if unrecorded).
        providers: onnxruntime execution providers in use.
        threads: intra-op thread count.

    Raises:
        ModelError: onnxruntime cannot load the file, the graph is not ``image (1,3,H,W) -> maps (1,8,H,W)``,
            or a model without manifest carries no svbrdf metadata / a different map layout.
    """

    def __init__(self, info: ModelInfo, threads: Optional[int] = None):
        import onnxruntime as ort

        self.info = info
        self.threads = int(threads or _cpu_count())
        so = ort.SessionOptions()
        so.enable_cpu_mem_arena = False
        so.intra_op_num_threads = self.threads
        so.inter_op_num_threads = 1
        so.log_severity_level = 3  # errors only: ORT's warnings are not actionable for a user
        cuda = "CUDAExecutionProvider" in ort.get_available_providers()
        providers = ["CUDAExecutionProvider", "CPUExecutionProvider"] if cuda else ["CPUExecutionProvider"]
        try:
            self._session = ort.InferenceSession(str(info.path), so, providers=providers)
        except Exception as exc:  # onnxruntime raises its own pybind classes (InvalidProtobuf, Fail, ...)
            raise ModelError(f"{info.path}: onnxruntime cannot load the model ({_first_line(exc)})") from None
        self.providers = self._session.get_providers()

        inputs, outputs = self._session.get_inputs(), self._session.get_outputs()
        if ([i.name for i in inputs] != [INPUT_NAME] or [o.name for o in outputs] != [OUTPUT_NAME]
                or len(inputs[0].shape) != 4):
            raise ModelError(
                f"{info.path}: not an svbrdf generator (expected input {INPUT_NAME!r} (1, 3, H, W) and output "
                f"{OUTPUT_NAME!r}, got {[i.name for i in inputs]} -> {[o.name for o in outputs]})"
            )
        if info.manifest is not None:
            self.metadata = info.manifest
        else:
            self.metadata = self._embedded_metadata()
            check_layout(self.metadata, str(info.path))
        try:
            render = self.metadata.get("render_config")
            self.render_config = RenderConfig(**render) if render else ZHAO
        except (TypeError, ValueError) as exc:
            raise ModelError(f"{info.path}: invalid render_config in the model metadata ({exc})") from None

    def _embedded_metadata(self) -> dict:
        props = self._session.get_modelmeta().custom_metadata_map
        try:
            meta = {k: json.loads(v) for k, v in props.items()}
        except ValueError:
            meta = {}
        if meta.get("schema") != MANIFEST_SCHEMA:
            raise ModelError(
                f"{self.info.path}: no manifest and no svbrdf metadata in the file; re-export it with svbrdf-export"
            )
        return meta

    @property
    def path(self) -> Path:
        return self.info.path

    def run(self, image: np.ndarray) -> np.ndarray:
        """One forward pass.

        Args:
            image: (H, W, 3) float32 linear RGB, H, W >= 8.

        Returns:
            (H, W, 8) float32 packed maps (layout of :mod:`svbrdf.runtime.maps`), not yet clipped.
        """
        h, w = image.shape[:2]
        x = np.ascontiguousarray(image.transpose(2, 0, 1)[None], dtype=np.float32)
        try:
            y = self._session.run([OUTPUT_NAME], {INPUT_NAME: x})[0]
        except Exception as exc:  # onnxruntime's RuntimeException / allocation failures
            raise SvbrdfError(f"{self.info.path}: inference failed on a {w}x{h} input ({_first_line(exc)})") from None
        if y.shape != (1, N_CHANNELS, h, w):
            raise ModelError(f"{self.info.path}: model returned {y.shape} for a {w}x{h} input")
        return y[0].transpose(1, 2, 0)


def load_session(model: Union[str, os.PathLike, None] = None, threads: Optional[int] = None) -> PreviewSession:
    """Find, verify and load a model (lookup order in :mod:`svbrdf.runtime.models`).

    Raises:
        ModelError: no model, missing file, sha256/manifest mismatch, or a file onnxruntime cannot load.
    """
    return PreviewSession(find_model(model), threads=threads)


def resize_long_side(image: np.ndarray, max_size: int) -> np.ndarray:
    """Downsize an (H, W, C) float32 image so its long side is ``max_size`` (aspect kept, sides rounded).

    Uses OpenImageIO ``ImageBufAlgo.resize`` with :data:`RESIZE_FILTER`; returns ``image`` itself when it is
    already small enough.
    """
    import OpenImageIO as oiio

    h, w, c = image.shape
    if max(h, w) <= max_size:
        return image
    scale = max_size / max(h, w)
    nh, nw = max(1, round(h * scale)), max(1, round(w * scale))
    src = oiio.ImageBuf(oiio.ImageSpec(w, h, c, oiio.FLOAT))
    src.set_pixels(oiio.ROI(), np.ascontiguousarray(image, dtype=np.float32))
    dst = oiio.ImageBufAlgo.resize(src, filtername=RESIZE_FILTER, roi=oiio.ROI(0, nw, 0, nh, 0, 1, 0, c))
    if dst.has_error:
        raise ImageError(f"cannot resize a {w}x{h} image to {nw}x{nh} ({_first_line(dst.geterror())})")
    return np.asarray(dst.get_pixels(oiio.FLOAT), dtype=np.float32).reshape(nh, nw, c)


def _as_image(photo: Union[str, os.PathLike, np.ndarray]) -> tuple:
    if isinstance(photo, np.ndarray):
        name = "<array>"
        if photo.ndim != 3 or photo.shape[-1] != 3:
            raise ImageError(f"{name}: expected an (H, W, 3) linear RGB array, got shape {photo.shape}")
        image = np.asarray(photo, dtype=np.float32)
        if not np.all(np.isfinite(image)):
            raise ImageError(f"{name}: image has NaN/Inf values")
        return name, image
    from .imageio import read_image

    return str(photo), read_image(photo)


def estimate(
    photo: Union[str, os.PathLike, np.ndarray],
    session: Optional[PreviewSession] = None,
    *,
    max_size: int = DEFAULT_MAX_SIZE,
    tile: int = DEFAULT_TILE,
    overlap: int = DEFAULT_OVERLAP,
) -> Maps:
    """SVBRDF maps of one flash photo (all four maps: the graph computes them in one pass).

    Args:
        photo: image file path, or an (H, W, 3) float32 **linear** RGB array; at least 8 x 8 pixels.
        session: a loaded :class:`PreviewSession` (default: :func:`load_session` with the default lookup).
        max_size: longer photos are downsized so their long side is ``max_size`` (see the module docstring).
        tile: images whose long side (after downsizing) exceeds ``tile`` are processed in ``tile`` x ``tile``
            windows; ``tile >= 8``.
        overlap: overlap of neighbouring windows, ``0 <= 2 * overlap <= tile``.

    Returns:
        :class:`Maps` at the processed size: diffuse (H, W, 3) linear [0, 1], specular and roughness (H, W, 1)
        [0, 1], normal (H, W, 3) unit OpenGL. ``meta`` holds ``source``, ``model`` (path, sha256, verified),
        ``input_size`` and ``size`` ([H, W]), ``resized``, ``tiles``, ``tile``, ``overlap``, ``threads``,
        ``timings`` (seconds for ``read``, ``resize``, ``infer``, ``post``) and ``render_config``.

    Raises:
        ImageError: unreadable photo, bad array, or an image smaller than 8 px (before or after downsizing).
        ModelError: no usable model (when ``session`` is None).
        SvbrdfError: the model returned NaN/Inf maps (float photos with absurd values, near the float32 limit).
        ValueError: invalid ``max_size``, ``tile`` or ``overlap``.
    """
    if max_size < MIN_SIZE or tile < MIN_SIZE or not 0 <= 2 * overlap <= tile:
        raise ValueError(f"need max_size >= {MIN_SIZE}, tile >= {MIN_SIZE} and 0 <= 2 * overlap <= tile; "
                         f"got max_size={max_size}, tile={tile}, overlap={overlap}")
    timings = {}
    t = time.perf_counter()
    name, image = _as_image(photo)
    in_h, in_w = image.shape[:2]
    if min(in_h, in_w) < MIN_SIZE:
        raise ImageError(f"{name}: image is {in_w}x{in_h} pixels; the model needs at least {MIN_SIZE}x{MIN_SIZE}")
    timings["read"] = time.perf_counter() - t
    if session is None:
        session = load_session()

    t = time.perf_counter()
    image = resize_long_side(image, max_size)
    h, w = image.shape[:2]
    if min(h, w) < MIN_SIZE:
        raise ImageError(f"{name}: {in_w}x{in_h} downsized to {w}x{h} is below {MIN_SIZE} px; raise max_size")
    timings["resize"] = time.perf_counter() - t

    t = time.perf_counter()
    packed = tiled_apply(session.run, image, tile, overlap)
    timings["infer"] = time.perf_counter() - t
    if not np.isfinite(packed).all():  # e.g. float photos near the float32 limit overflow inside the graph
        raise SvbrdfError(f"{name}: the model returned NaN/Inf maps (photo values up to {float(image.max()):.3g}; "
                          f"expected linear RGB of order 1)")

    t = time.perf_counter()
    meta = {
        "source": name,
        "model": {"path": str(session.path), "sha256": session.info.sha256, "verified": session.info.verified},
        "input_size": [in_h, in_w],
        "size": [h, w],
        "resized": (h, w) != (in_h, in_w),
        "tiles": len(tile_boxes(h, w, tile, overlap)),
        "tile": tile,
        "overlap": overlap,
        "threads": session.threads,
        "render_config": session.render_config.to_dict(),
    }
    maps = Maps.unpack(packed, meta).clipped()
    timings["post"] = time.perf_counter() - t
    maps.meta["timings"] = timings
    return maps
