"""How one photo becomes a texture set: :class:`PhotoOptions`, the options both CLIs share (``svbrdf-preview``,
``svbrdf-batch``), with the shipped defaults."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, Optional, Tuple

from ..core.maps import MAP_NAMES, select_maps
from ..core.relief import AO_STRENGTH, RELIEF_NAMES
from ..errors import SvbrdfError
from ..inference.guided import Upsampling
from ..inference.pipeline import DEFAULT_MAX_SIZE, DEFAULT_TILE
from ..inference.session import PreviewSession
from ..post import PostProcess

__all__ = ["PhotoOptions"]


@dataclass(frozen=True)
class PhotoOptions:
    """How one photo becomes a texture set: the options both CLIs share (``svbrdf-preview``, ``svbrdf-batch``; built
    from their arguments by :func:`svbrdf.runtime.cli.options.photo_options`), with the shipped defaults.

    Attributes:
        model: ONNX model path (None: ``$SVBRDF_MODEL``, else the packaged model).
        threads: CPU threads (None: every core).
        fov: camera field of view across the photo width, degrees (None: each photo's EXIF record, else the model's;
            :func:`~svbrdf.runtime.workflow.camera.photo_camera`).
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
