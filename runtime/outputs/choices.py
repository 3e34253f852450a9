"""The names a user chooses among, one table each, shared by the API and the command lines.

Light on purpose (no OpenImageIO, onnxruntime or torch), so that ``svbrdf-preview --help`` and
``svbrdf-train --help`` list the choices without loading the modules that implement them.

* :data:`TARGETS`: the texture-set presets of :mod:`svbrdf.runtime.outputs.targets` (``--target``), in the order shown
  to users; :data:`svbrdf.runtime.outputs.targets.PRESETS` has one entry per name.
* Normal-map conventions: the API names are :data:`svbrdf.runtime.core.maps.SUPPORTED_NORMAL_CONVENTIONS`
  (``"opengl"``, ``"dx"``); :data:`NORMAL_ALIASES` lists the other spellings the command line accepts
  (:func:`normal_convention`).
"""

from __future__ import annotations

from typing import Mapping, Tuple

from ..core.maps import SUPPORTED_NORMAL_CONVENTIONS

#: Target names, in the order shown to users.
TARGETS: Tuple[str, ...] = ("generic", "gltf", "blender", "unreal", "unity", "usd", "mtlx", "ambientcg")

#: Other spellings of a normal-map convention -> its API name.
NORMAL_ALIASES: Mapping[str, str] = {"gl": "opengl"}


def normal_convention(name: str) -> str:
    """The API name of a normal-map convention given by its API name or an alias (``"gl"`` -> ``"opengl"``).

    Other names are returned unchanged, for the caller to refuse (argparse ``choices``, or
    :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set`).
    """
    return NORMAL_ALIASES.get(name, name)


__all__ = ["TARGETS", "NORMAL_ALIASES", "SUPPORTED_NORMAL_CONVENTIONS", "normal_convention"]
