"""The example-photo tool (svbrdf.trainer.tools.example_photo): a seeded procedural flash photo with a clipped
highlight, written as 8-bit sRGB, never over an existing file."""

import numpy as np

from svbrdf.runtime.quality.burn_in import highlight_centre
from svbrdf.runtime.io.images import read_image
from svbrdf.trainer.tools import example_photo


def test_a_seeded_flash_photo_with_a_clipped_highlight(tmp_path, capsys):
    out = tmp_path / "ex.png"
    assert example_photo.main(["--size", "64", "--ev", "1.5", "--out", str(out)]) == 0
    photo = read_image(out)
    assert photo.shape == (64, 64, 3)
    assert (photo.max(axis=-1) >= 0.98).any()  # the highlight clips at this exposure
    cy, cx = highlight_centre(photo)
    assert abs(cy - 32) < 12 and abs(cx - 32) < 12  # flash on the lens axis: the highlight at the centre
    again = example_photo.make_photo("leather", 1002, 64, 1.5)
    np.testing.assert_allclose(again, example_photo.make_photo("leather", 1002, 64, 1.5))  # seeded
    assert example_photo.main(["--size", "64", "--out", str(out)]) == 2  # exists: refused without --force
    assert "exists" in capsys.readouterr().err
    assert example_photo.main(["--size", "64", "--family", "nope", "--out", str(tmp_path / "x.png")]) == 2
