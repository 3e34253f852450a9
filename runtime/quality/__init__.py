"""Label-free quality scores: the highlight burn-in of a set of maps (:mod:`.burn_in`), the base colour's foreign
colours (:mod:`.colour_check`) and the height's flash dome (:mod:`.relief_check`)."""

from .colour_check import COLOUR_METRICS, chroma_distance, foreign_colour  # noqa: E402,F401  (foreign colours)
from .relief_check import RELIEF_METRICS, relief_radial  # noqa: E402,F401  (the height's flash dome)
