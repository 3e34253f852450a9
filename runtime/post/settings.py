"""The post-processing choices of a preview, as one settings object: :class:`PostProcess`.

Pure Python (no numpy): the CLIs and the trainer can name the settings without loading the corrections.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

__all__ = ["PostProcess", "EVEN_LIGHTING_WIDTH"]

#: The width of the low pass of :func:`even_lighting` that the preview (:attr:`PostProcess.even_lighting`)
#: and the default refine (``even_lighting`` of the ``fast`` preset) use, a fraction of the photo width: it takes
#: out the flash's broad fall-off and part of its highlight. Decision: docs/decisions/007-network-input-lighting.md.
EVEN_LIGHTING_WIDTH = 0.25


@dataclass(frozen=True)
class PostProcess:
    """What the runtime does around the network, in this order (the defaults are the shipped behaviour; the
    decisions named below are pages of docs/decisions/).

    Attributes:
        even_lighting: the network sees the photo divided by its own smooth lighting
            (:func:`svbrdf.runtime.post.flash_trend.even_lighting`, a low pass of this standard deviation, a
            fraction of the width; ``None`` or 0: the photo as it is). The flash's fall-off and the broad part of
            its highlight are then not in the network's input, so it cannot paint them into the maps
            (007-network-input-lighting.md). For a stage one that records no ``network_input`` of
            its own (v1); a model with a record is shown what it was trained on
            (:meth:`svbrdf.runtime.inference.session.PreviewSession.input_lighting`).
        colour_from_photo: give the base colour the photo's colour balance
            (:func:`svbrdf.runtime.post.photo_colour.photo_colour`): the generator normalises its features per
            image (instance normalisation), so it cannot see a photo's overall colour and predicts a nearly grey
            base colour for every material (008-photo-colour.md).
        highlight_fill: fill the region of a clipped flash highlight and its shoulder with the material's own
            maps from elsewhere (:func:`svbrdf.runtime.post.highlight_fill.fill_highlight`): no disc, no blob
            (006-highlight-fill.md).
        fill_patches: a large highlight is filled patch by patch (False: always one copy).
        flash_trend: remove the maps' smooth radial trend around the photo's flash highlight
            (:func:`svbrdf.runtime.post.flash_trend.remove_flash_trend`, 004-flash-trend-removal.md): what the
            network left of the highlight and fall-off (the base colour's as one gain per pixel, its hue kept); then
            the base colour's coarse colours are made the photo's
            (:func:`svbrdf.runtime.post.photo_colour.local_colour`: the casts the photo does not show go, and with
            them most of the overall balance comes from the photo, with or without ``colour_from_photo``).
        uniform_specular: one specular level per photo, its median
            (:func:`svbrdf.runtime.post.flash_trend.uniform_specular`): its spatial variation measured as noise
            (005-uniform-specular.md).
    """

    even_lighting: Optional[float] = EVEN_LIGHTING_WIDTH
    colour_from_photo: bool = True
    highlight_fill: bool = True
    fill_patches: bool = True
    flash_trend: bool = True
    uniform_specular: bool = True

    def __post_init__(self) -> None:
        if self.even_lighting is not None and not 0.0 <= float(self.even_lighting) <= 1.0:
            raise ValueError(f"even_lighting must be None or in [0, 1] (a fraction of the width), "
                             f"got {self.even_lighting}")

    def replace(self, **changes) -> "PostProcess":
        """A copy with ``changes`` (field name -> value)."""
        return replace(self, **changes)

    @classmethod
    def off(cls) -> "PostProcess":
        """No correction at all: the network's maps of the photo as it is."""
        return cls(even_lighting=None, colour_from_photo=False, highlight_fill=False, flash_trend=False,
                   uniform_specular=False)
