"""runtime.tileable: a texture set with a gradient across it (no wrap) made tileable: seams like the interior,
maps registered, ranges, unit normals and value statistics kept; scores and errors."""

import numpy as np
import pytest

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.tileable import histogram_distance, make_tileable, seam_scores


def _ramp_maps(n=96, seed=3) -> Maps:
    """Noise textures on a left-to-right / top-to-bottom ramp: the wrap of every map is a visible seam."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n] / n
    tex = rng.random((n, n))
    diffuse = np.clip(0.2 + 0.5 * xx[..., None] * np.array([1, 0.8, 0.6]) + 0.1 * tex[..., None], 0, 1)
    rough = np.clip(0.2 + 0.6 * yy + 0.1 * tex, 0, 1)[..., None]
    spec = np.clip(0.04 + 0.1 * xx * yy, 0, 1)[..., None]
    normal = np.stack([0.3 * (tex - 0.5), 0.3 * (yy - 0.5), np.ones_like(tex)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return Maps(diffuse=diffuse.astype(np.float32), specular=spec.astype(np.float32),
                roughness=rough.astype(np.float32), normal=normal.astype(np.float32))


def test_seam_scores_see_a_wrap():
    m = _ramp_maps()
    assert seam_scores(m.diffuse)["x"] > 5  # the ramp's jump across the wrap
    noise = np.random.default_rng(0).random((64, 64, 1))
    assert 0.5 < seam_scores(noise)["max"] < 2  # a wrap between two independent columns: like the interior
    assert seam_scores(np.ones((20, 20, 1)))["max"] is None


def test_make_tileable_cut():
    m = _ramp_maps()
    t = make_tileable(m)
    assert t.shape == m.shape
    for name, a in t.items():
        assert seam_scores(a)["max"] <= 1.2 * 1.0 + 0.5, name  # like any interior neighbour pair, within noise
        assert seam_scores(a)["max"] < seam_scores(getattr(m, name))["max"]
    assert np.allclose(np.linalg.norm(t.normal, axis=-1), 1, atol=1e-4)
    for name in ("diffuse", "specular", "roughness"):
        a = getattr(t, name)
        assert a.min() >= 0 and a.max() <= 1
        assert histogram_distance(getattr(m, name), a) < 0.05
    info = t.meta["tileable"]
    assert info["method"] == "cut" and set(info["seam"]) == {"diffuse", "specular", "roughness", "normal"}
    # Registered: every output pixel of every map comes from the same input pixel.
    t2, src = make_tileable(m, return_source=True)
    rows, cols = src[..., 0], src[..., 1]
    for name, a in t2.items():
        assert np.allclose(a, getattr(m, name)[rows, cols], atol=1e-6)


def test_make_tileable_errors():
    with pytest.raises(SvbrdfError):
        make_tileable(_ramp_maps(), method="mirror")
    with pytest.raises(SvbrdfError):
        make_tileable(_ramp_maps(n=8))
