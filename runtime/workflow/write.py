"""Writing one photo's maps: :func:`write_maps`, the texture set of ``options.target`` and, with ``options.view``,
its viewer page."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Callable, Union

import numpy as np

from ..core.maps import Maps
from .options import PhotoOptions
from .photo import _with_relief

__all__ = ["write_maps"]


def write_maps(maps: Maps, relit: Union[None, np.ndarray, Callable[[], np.ndarray]], out_dir: Path, name: str,
               options: PhotoOptions, extra_meta: dict) -> dict:
    """Write ``maps`` (and ``relit``) as the texture set ``name`` in ``out_dir`` for ``options.target`` (all or
    nothing, :mod:`svbrdf.runtime.outputs.texture_set`), and with ``options.view`` its viewer page
    (:func:`svbrdf.runtime.outputs.viewer.write_viewer`); returns the written paths by role. Maps without the relief
    ``options`` ask for (:func:`~svbrdf.runtime.workflow.photo.process_photo` with ``later``) get it here: for the project's own layout while the
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
