"""PostProcess: the post-processing choices as one frozen settings object whose defaults are the shipped behaviour."""

import dataclasses

import pytest

from svbrdf.runtime.post import EVEN_LIGHTING_WIDTH, PostProcess


def test_the_defaults_are_every_correction_as_shipped():
    post = PostProcess()
    assert post.even_lighting == EVEN_LIGHTING_WIDTH == 0.25
    assert post.colour_from_photo and post.highlight_fill and post.fill_patches
    assert post.flash_trend and post.uniform_specular


def test_it_is_frozen_and_changed_by_copy():
    post = PostProcess()
    with pytest.raises(dataclasses.FrozenInstanceError):
        post.flash_trend = False
    off = post.replace(flash_trend=False)
    assert post.flash_trend and not off.flash_trend and off.uniform_specular
    assert PostProcess.off() == PostProcess(even_lighting=None, colour_from_photo=False, highlight_fill=False,
                                            flash_trend=False, uniform_specular=False)


@pytest.mark.parametrize("width", [-0.1, 1.5])
def test_an_even_lighting_width_out_of_range_is_refused(width):
    with pytest.raises(ValueError, match="even_lighting must be None or in"):
        PostProcess(even_lighting=width)


def test_no_module_level_switch_is_left_in_the_runtime():
    import svbrdf.runtime.inference.session as session
    import svbrdf.runtime.post.highlight_fill as hf

    for name in ("COLOUR_FROM_PHOTO", "FLASH_TREND", "UNIFORM_SPECULAR", "HIGHLIGHT_FILL", "EVEN_LIGHTING",
                 "CPU_MEM_ARENA"):
        assert not hasattr(session, name), name
    assert not hasattr(hf, "PATCHES")
