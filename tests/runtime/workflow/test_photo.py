"""process_photo: the one per-photo path of both CLIs (svbrdf.runtime.workflow.photo)."""

import pytest

pytest.importorskip("onnxruntime")
from svbrdf.runtime.post import PostProcess  # noqa: E402
from svbrdf.runtime.workflow.options import PhotoOptions  # noqa: E402
from svbrdf.runtime.workflow.photo import process_photo  # noqa: E402


def test_process_photo_with_options(session, wood):
    path = wood
    maps, relit, detail = process_photo(path, PhotoOptions(), session)
    assert maps.complete and relit.shape == (40, 3 * 56, 3) and detail.startswith("model")  # h x 3w, sRGB
    only, none, _ = process_photo(path, PhotoOptions(maps=("normal",)), session)
    assert only.names == ("normal",) and none is None
    bare, _, _ = process_photo(path, PhotoOptions(post=PostProcess.off()), session)
    assert bare.meta["even_lighting"] is None
    with pytest.raises(ValueError, match="needs the refine function"):
        process_photo(path, PhotoOptions(refine=True), session)

