"""write_maps: one photo's texture set and viewer page (svbrdf.runtime.workflow.write)."""

import numpy as np
import pytest

pytest.importorskip("onnxruntime")
from svbrdf.runtime.workflow.options import PhotoOptions  # noqa: E402
from svbrdf.runtime.workflow.photo import process_photo  # noqa: E402
from svbrdf.runtime.workflow.write import write_maps  # noqa: E402


@pytest.mark.parametrize("target", ["generic", "gltf"])
def test_relief_and_panel_left_to_the_writers_give_the_same_files(session, tmp_path, wood, target):
    path = wood
    options = PhotoOptions(target=target)
    now = process_photo(path, options, session)
    maps, relit, _ = process_photo(path, options, session, later=True)
    assert now[0].relief is not None and maps.relief is None and callable(relit)
    np.testing.assert_array_equal(relit(), now[1])
    a = write_maps(now[0], now[1], tmp_path / "a", "wood", options, {})
    b = write_maps(maps, relit, tmp_path / "b", "wood", options, {})
    assert list(a) == list(b) and {"sidecar", "relit"} <= set(a) and ("height" in a or "orm" in a)
    for role in a:
        if role != "sidecar":
            assert a[role].read_bytes() == b[role].read_bytes(), role
    assert "relief" in maps.meta["timings"]  # timed while the maps were written

