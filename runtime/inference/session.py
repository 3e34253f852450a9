"""onnxruntime sessions on an exported generator (no torch): :func:`load_session` -> :class:`PreviewSession`.

::

    session = load_session()                     # model lookup: see svbrdf.runtime.inference.manifest
    maps = estimate("photo.jpg", session)        # svbrdf.runtime.inference.pipeline

The session keeps onnxruntime's CPU memory arena (``cpu_mem_arena=True``): without it every intermediate
tensor is fresh memory from the system and the one pass of a preview pays its page faults. Every pass ends by
handing the arena's memory back (onnxruntime's arena shrinkage, :meth:`PreviewSession.run`), so the passes of a
tiled photo (tiles of several shapes) do not pile up arena chunks. Decision:
docs/decisions/012-onnx-memory-arena.md.
"""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path
from typing import Iterable, Optional, Tuple, Union

import numpy as np

from ..core.maps import N_CHANNELS, select_maps
from ..core.render_config import ZHAO, RenderConfig
from ..errors import ModelError, SvbrdfError
from ..post.settings import EVEN_LIGHTING_WIDTH
from .manifest import (
    INPUT_NAME, MANIFEST_SCHEMA, OUTPUT_NAME, PARTS, PRIOR_STAGE, ModelInfo, check_layout, find_model,
    recorded_even_lighting,
)

#: Name of the complete graph (both decoders) among :attr:`PreviewSession.loaded` and ``meta["model"]["graph"]``.
FULL = "full"

__all__ = ["PreviewSession", "load_session", "FULL"]


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
    :data:`~svbrdf.runtime.inference.manifest.PARTS`, each created on first use (:meth:`graph_for` picks the graph for a
    set of maps). The graph the session's default ``maps`` need is created at once, so a file onnxruntime
    cannot load fails here.

    Args:
        info: the located model (:func:`svbrdf.runtime.inference.manifest.find_model`).
        threads: intra-op threads (default: every core this process may run on).
        maps: the maps :func:`estimate` computes by default (:func:`~svbrdf.runtime.core.maps.select_maps`;
            default all four).
        cpu_mem_arena: use onnxruntime's CPU memory arena (module docstring; the preview-speed benchmark's
            'before' is False).

    Attributes:
        info: :class:`~svbrdf.runtime.inference.manifest.ModelInfo` (path, sha256, manifest, note).
        maps: the default maps, in :data:`~svbrdf.runtime.core.maps.MAP_NAMES` order.
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
                 maps: Union[None, str, Iterable[str]] = None, *, cpu_mem_arena: bool = True):
        self.info = info
        self.cpu_mem_arena = bool(cpu_mem_arena)
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
        so.enable_cpu_mem_arena = self.cpu_mem_arena
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
            if self.cpu_mem_arena:
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
        """:meth:`input_lighting` with the runtime's default for a stage one that records nothing (v1):
        :data:`~svbrdf.runtime.post.flash_trend.EVEN_LIGHTING_WIDTH`."""
        return self.input_lighting(EVEN_LIGHTING_WIDTH)

    def input_lighting(self, default: Optional[float] = EVEN_LIGHTING_WIDTH) -> Optional[float]:
        """The width of :func:`~svbrdf.runtime.post.flash_trend.even_lighting` the network is shown the photo at
        (``None``: the photo as it is), from what the model was trained on.

        A model fine-tuned on a photo (any stage but ``"prior"``) saw what its ``train_config.even_lighting``
        says (absent or 0, as in every export before it existed and in the paper's presets: the photo itself). A
        stage one (``"prior"``, or no training record) learned on flash photos as they are; it is shown what its
        ``network_input`` record says (:func:`~svbrdf.runtime.inference.manifest.recorded_even_lighting`, chosen by
        measurement when it was shipped), and without one (v1) evenly lit at ``default``
        (:attr:`svbrdf.runtime.post.PostProcess.even_lighting`, docs/decisions/007-network-input-lighting.md;
        ``None`` or 0: the photo as it is); its ``train_config`` is the
        fine-tune preset meant for it, not its own input.
        """
        training = self.metadata.get("training") or {}
        if training.get("stage") in (None, PRIOR_STAGE):
            recorded = recorded_even_lighting(self.metadata)
            return (recorded if recorded is not None else default) or None
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
            (H, W, 8) float32 packed maps (layout of :mod:`svbrdf.runtime.core.maps`), not yet clipped; a part graph
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
                 maps: Union[None, str, Iterable[str]] = None, *, cpu_mem_arena: bool = True) -> PreviewSession:
    """Find, verify and load a model (lookup order in :mod:`svbrdf.runtime.inference.manifest`).

    ``maps`` (default all) are the maps :func:`estimate` computes by default; only the graph they need is
    loaded now (a part graph for the maps of one decoder, when the model has it), others on first use.
    ``cpu_mem_arena``: onnxruntime's CPU memory arena (:class:`PreviewSession`; True is faster).

    Raises:
        SvbrdfError: unknown map names (checked first).
        ModelError: no model, missing file, sha256/manifest mismatch, or a file onnxruntime cannot load.
    """
    maps = select_maps(maps)
    return PreviewSession(find_model(model), threads=threads, maps=maps, cpu_mem_arena=cpu_mem_arena)
