"""svbrdf.runtime: the light side of the toolkit (numpy + onnxruntime + OpenImageIO + isal, never torch).

Public API::

    from svbrdf.runtime import PostProcess, estimate, load_session, with_relief, write_texture_set
    session = load_session()              # packaged model, or SVBRDF_MODEL, or a path
    maps = estimate("photo.jpg", session) # -> Maps (numpy arrays; see svbrdf.runtime.core.maps)
    write_texture_set(maps, "out/", "photo")
    write_texture_set(with_relief(maps), "out/", "photo", force=True)  # + photo_height.png, photo_ao.png
    bare = estimate("photo.jpg", session, post=PostProcess.off())  # the network's maps, no correction

The package is organised by role: ``core`` (maps, renderer, colour), ``io`` (image files, process tuning),
``inference`` (model, sessions, photo -> maps), ``post`` (corrections around the network, :class:`PostProcess`), ``quality``
(label-free scores), ``outputs`` (texture sets, targets, viewer), ``workflow`` (the per-photo path of the CLIs:
:class:`PhotoOptions`, :func:`process_photo`), ``batch`` (material libraries) and ``cli``.

Heavy modules are imported lazily (PEP 562) so that ``import svbrdf.runtime`` stays cheap.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

try:
    from importlib.metadata import version as _version

    __version__ = _version("svbrdf")
except Exception:  # pragma: no cover - running from a source tree without an install
    __version__ = "0.0.0+local"

_LAZY = {
    "Maps": ".core.maps",
    "Relief": ".core.relief",
    "relief_maps": ".core.relief",
    "with_relief": ".core.relief",
    "RenderConfig": ".core.render",
    "render": ".core.render",
    "read_image": ".io.images",
    "write_image": ".io.images",
    "write_texture_set": ".outputs.texture_set",
    "load_session": ".inference.session",
    "PreviewSession": ".inference.session",
    "estimate": ".inference.pipeline",
    "process_photo": ".workflow.photo",
    "PhotoOptions": ".workflow.options",
    "PostProcess": ".post.settings",
    "SvbrdfError": ".errors",
    "ImageError": ".errors",
    "ModelError": ".errors",
}

__all__ = sorted(_LAZY) + ["__version__"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if TYPE_CHECKING:  # pragma: no cover
    from .core.maps import Maps
    from .core.relief import Relief, relief_maps, with_relief
    from .core.render import RenderConfig, render
    from .errors import ImageError, ModelError, SvbrdfError
    from .inference.pipeline import estimate
    from .inference.session import PreviewSession, load_session
    from .io.images import read_image, write_image
    from .outputs.texture_set import write_texture_set
    from .post.settings import PostProcess
    from .workflow.options import PhotoOptions
    from .workflow.photo import process_photo
