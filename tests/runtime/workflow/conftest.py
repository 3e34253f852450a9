"""Fixtures of the per-photo workflow's tests (svbrdf.runtime.workflow)."""

import pytest

from svbrdf.runtime.io.images import write_image


@pytest.fixture
def wood(tmp_path, small_flash_photo):
    """A 56 x 40 flash photo (16-bit PNG) in ``tmp_path``."""
    path = tmp_path / "wood.png"
    write_image(path, small_flash_photo(), bits=16)
    return path
