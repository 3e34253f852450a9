"""PhotoOptions: the options both CLIs share (svbrdf.runtime.workflow.options)."""

import argparse

import pytest

from svbrdf.runtime.post import PostProcess

pytest.importorskip("onnxruntime")
from svbrdf.runtime.workflow.options import PhotoOptions  # noqa: E402


def test_photo_options_from_parsed_arguments_keep_only_their_fields():
    args = argparse.Namespace(maps=("normal",), tile=512, verbose=True, photos=["x.png"], out=None, force=True)
    options = PhotoOptions.from_mapping(args)
    assert options.maps == ("normal",) and options.tile == 512 and options.force
    assert options.post == PostProcess() and options.max_size == 2048
    assert PhotoOptions.from_mapping({"maps": ["basecolor", "normal"]}).maps == ("diffuse", "normal")
    with pytest.raises(Exception, match="unknown map"):
        PhotoOptions(maps=("shininess",))

