"""svbrdf.runtime: the light side of the toolkit (numpy + onnxruntime + OpenImageIO, never torch).

Public API::

    from svbrdf.runtime import load_session, estimate
    session = load_session()              # packaged model, or SVBRDF_MODEL, or a path
    maps = estimate("photo.jpg", session) # -> Maps (numpy arrays; see svbrdf.runtime.maps)
    maps.save("out/", "photo")

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
    "Maps": ".maps",
    "RenderConfig": ".render",
    "render": ".render",
    "read_image": ".imageio",
    "write_image": ".imageio",
    "load_session": ".session",
    "estimate": ".session",
    "PreviewSession": ".session",
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
    from .errors import ImageError, ModelError, SvbrdfError
    from .imageio import read_image, write_image
    from .maps import Maps
    from .render import RenderConfig, render
    from .session import PreviewSession, estimate, load_session
