"""JSON values without NaN: what the project's JSON writers pass to ``json.dumps(..., allow_nan=False)``."""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

__all__ = ["finite_json"]


def finite_json(obj: Any) -> Any:
    """``obj`` with every non-finite float as ``None``, through nested mappings (keys made ``str``), lists and
    tuples (made lists); numpy scalars (floating, integer) become Python numbers first. Other values are returned
    as they are."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): finite_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_json(v) for v in obj]
    if isinstance(obj, (np.floating, np.integer)):
        return finite_json(obj.item())
    return obj
