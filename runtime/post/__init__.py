"""Corrections applied around the network, in order: the photo evenly lit for the network
(:func:`~svbrdf.runtime.post.flash_trend.even_lighting`), then on the maps: the photo's colour balance
(:mod:`~svbrdf.runtime.post.photo_colour`), the highlight fill (:mod:`~svbrdf.runtime.post.highlight_fill`), the
flash-trend removal and one specular level (:mod:`~svbrdf.runtime.post.flash_trend`). What runs is one settings
object, :class:`PostProcess`, passed as an argument (``estimate(..., post=PostProcess(flash_trend=False))``);
:func:`apply` runs the map steps. :mod:`~svbrdf.runtime.post.tileable` (seamless maps) is asked for separately.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .settings import EVEN_LIGHTING_WIDTH, PostProcess

if TYPE_CHECKING:  # pragma: no cover
    import numpy as np

    from ..core.maps import Maps

__all__ = ["PostProcess", "EVEN_LIGHTING_WIDTH", "apply"]


def apply(maps: "Maps", photo: "np.ndarray", post: PostProcess = PostProcess()) -> "Maps":
    """The network's maps with the corrections ``post`` asks for, in order: :func:`photo_colour` (the base colour's
    balance), then :func:`~svbrdf.runtime.post.flash_trend.postprocess` (highlight fill, flash trend, one specular
    level, and the burn-in scores before and after).

    Args:
        maps: the network's texture set (H, W), clipped to the maps' ranges (diffuse linear [0, 1]).
        photo: (H, W, 3) linear RGB photo the maps were estimated from (as read, not evenly lit).
        post: the settings.

    Returns:
        A new :class:`~svbrdf.runtime.core.maps.Maps` with ``meta["burn_in"]`` and ``meta["burn_in_model"]``
        (and ``meta["highlight_fill"]``, ``meta["flash_trend"]``, ``meta["uniform_specular"]`` for the steps that ran).
    """
    from .flash_trend import postprocess
    from .photo_colour import photo_colour

    if post.colour_from_photo and maps.diffuse is not None:
        maps = maps._with({**dict(maps.items()), "diffuse": photo_colour(maps.diffuse, photo)})
    return postprocess(maps, photo, flash_trend=post.flash_trend, specular_level=post.uniform_specular,
                       highlight_fill=post.highlight_fill, patches=post.fill_patches)
