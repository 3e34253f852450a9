"""process_capture: the refusals of a multi-view capture before any fit (svbrdf.runtime.workflow.capture)."""

import numpy as np
import pytest

from svbrdf.runtime.io.images import write_image

pytest.importorskip("onnxruntime")
from svbrdf.runtime.workflow.capture import process_capture  # noqa: E402
from svbrdf.runtime.workflow.options import PhotoOptions  # noqa: E402


def _fake_capture():
    from types import SimpleNamespace

    from svbrdf.trainer.bench.datasets import capture_view_file, read_capture_calibration

    return SimpleNamespace(read_calibration=read_capture_calibration, view_file=capture_view_file)


def _calibrated(folder, n=3, size=(32, 32)):
    import json

    folder.mkdir()
    for i in range(n):
        write_image(folder / f"{i:02d}.png", np.full((*size, 3), 0.4, np.float32), bits=8, srgb_encode=True)
    (folder / "parameters.json").write_text(json.dumps({
        "image_size": 10.0, "idx": list(range(n)), "camera_pos": [[0.0, 0.0, 11.0]] * n}))
    return folder


def test_a_capture_view_the_calibration_does_not_list_is_refused(tmp_path):
    from svbrdf.runtime.errors import SvbrdfError

    cap = _calibrated(tmp_path / "cap")
    write_image(cap / "07.png", np.full((32, 32, 3), 0.4, np.float32), bits=8, srgb_encode=True)
    with pytest.raises(SvbrdfError, match=r"cap: 07.png is not in parameters.json \(it lists views 0, 1, 2\)") as err:
        process_capture(cap, PhotoOptions(), None, _fake_capture())
    assert "\n" not in str(err.value)


def test_capture_views_that_are_not_square_are_refused(tmp_path):
    from svbrdf.runtime.errors import SvbrdfError

    cap = _calibrated(tmp_path / "cap", size=(32, 48))
    with pytest.raises(SvbrdfError, match="the views are 48x32 px, not square: parameters.json gives") as err:
        process_capture(cap, PhotoOptions(), None, _fake_capture())
    assert "\n" not in str(err.value)


def test_a_calibration_listing_a_view_twice_is_refused(tmp_path):
    import json

    from svbrdf.runtime.errors import SvbrdfError

    cap = _calibrated(tmp_path / "cap")
    (cap / "parameters.json").write_text(json.dumps({"image_size": 10.0, "idx": [0, 1, 1],
                                                      "camera_pos": [[0.0, 0.0, 11.0]] * 3}))
    with pytest.raises(SvbrdfError, match="parameters.json: idx lists view 1 more than once") as err:
        process_capture(cap, PhotoOptions(), None, _fake_capture())
    assert "\n" not in str(err.value)
