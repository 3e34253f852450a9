"""The packaged preview model (svbrdf.models): what a new user gets from `svbrdf-preview` without options."""

import json
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from svbrdf.runtime.core.colour import linear_to_srgb
from svbrdf.runtime.io.images import read_image
from svbrdf.runtime.inference.manifest import find_checkpoint, find_model, sha256_file
from svbrdf.runtime.inference.pipeline import estimate
from svbrdf.runtime.inference.session import load_session

EXAMPLE = Path(str(resources.files("svbrdf.runtime"))) / "examples" / "carved_wood.png"
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
#: Mean chroma (max - min of the sRGB base colour) a greyscale photo may come out with (issue: under 0.02).
NEUTRAL_CHROMA = 0.02


@pytest.fixture(scope="module")
def session():
    return load_session(threads=1)


def test_manifest_names_the_procedural_prior_and_its_checkpoint():
    info = find_model()
    assert info.source in ("packaged", "env")
    if info.source != "packaged":
        pytest.skip("SVBRDF_MODEL overrides the packaged model")
    training = info.manifest["training"]
    assert training["stage"] == "prior"
    ckpt = find_checkpoint(info)
    assert sha256_file(ckpt) == info.manifest["checkpoint"]["sha256"]
    assert ckpt.stat().st_size < 20e6 and info.path.stat().st_size < 20e6  # "tens of MB at most" in all


def test_a_greyscale_photo_gives_a_neutral_base_colour(session):
    img = read_image(EXAMPLE)[..., :3]
    grey = np.repeat((img * LUMA).sum(-1, keepdims=True), 3, axis=-1).astype(np.float32)
    with pytest.warns(UserWarning, match="greyscale photo"):  # the runtime says the model invents the colour
        maps = estimate(grey, session)
    srgb = linear_to_srgb(np.clip(maps.diffuse, 0.0, 1.0))
    chroma = float((srgb.max(-1) - srgb.min(-1)).mean())
    assert chroma < NEUTRAL_CHROMA, chroma
