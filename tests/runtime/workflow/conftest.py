"""Fixtures of the per-photo workflow's tests (svbrdf.runtime.workflow)."""

import numpy as np
import pytest

from svbrdf.runtime.io.images import write_image


def _photo(h=40, w=56, seed=3):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    base = 0.3 + 0.1 * np.sin(xx / 3.0)[..., None] * np.array([1.0, 0.8, 0.6], np.float32)
    flash = 0.6 * np.exp(-((yy - h / 2) ** 2 + (xx - w / 2) ** 2) / (2 * 8.0 ** 2))[..., None]
    return (base + flash + rng.normal(0, 0.01, (h, w, 3))).clip(0, 1).astype(np.float32)


@pytest.fixture
def wood(tmp_path):
    """A 56 x 40 flash photo (16-bit PNG) in ``tmp_path``."""
    path = tmp_path / "wood.png"
    write_image(path, _photo(), bits=16)
    return path
