"""The label-free highlight burn-in score (svbrdf.runtime.burn_in): hand-made fields with known answers."""

import numpy as np
import pytest

from svbrdf.runtime import burn_in as bi
from svbrdf.runtime.maps import Maps
from svbrdf.runtime.render import ZHAO, render


def _flat_maps(n=48, diffuse=None, roughness=0.4, specular=0.05, seed=0):
    rng = np.random.default_rng(seed)
    d = rng.uniform(0.2, 0.6, (n, n, 3)) if diffuse is None else np.broadcast_to(diffuse, (n, n, 3))
    normal = np.zeros((n, n, 3))
    normal[..., 2] = 1.0
    return Maps(diffuse=np.array(d, np.float32), specular=np.full((n, n, 1), specular, np.float32),
                roughness=np.full((n, n, 1), roughness, np.float32), normal=np.array(normal, np.float32))


def test_burn_in_of_bright_disc_constant_and_stationary_flat_maps():
    n = 128
    yy, xx = np.mgrid[0:n, 0:n]
    r = np.hypot(yy + 0.5 - n / 2, xx + 0.5 - n / 2) / n
    disc = np.where(r < 0.1, 1.0, 0.2)
    assert bi.burn_in(disc) > 1.0
    assert bi.burn_in(-disc) < -1.0  # signed: a dip under the highlight is negative
    assert bi.burn_in(np.full((n, n), 0.37)) == 0.0
    noise = np.random.default_rng(1).uniform(0, 1, (n, n))
    assert abs(bi.burn_in(noise)) < 0.15
    # Off-centre disc: invisible from the image centre, found at its own centre.
    off = np.where(np.hypot(yy + 0.5 - 30, xx + 0.5 - 90) / n < 0.1, 1.0, 0.2)
    assert bi.burn_in(off, centre=(30, 90)) > 1.0
    assert bi.burn_in(off, centre=(30, 90)) > 3 * abs(bi.burn_in(off))


def test_burn_in_scores_and_highlight_centre():
    m = _flat_maps(n=64)
    scores = bi.burn_in_scores(m)
    assert set(scores) == set(bi.BURN_METRICS) | {"burn_in"}
    assert scores["burn_specular"] == 0.0 and scores["burn_normal"] == 0.0
    assert scores["burn_in"] == pytest.approx(np.mean([abs(scores[k]) for k in bi.BURN_METRICS]))
    # A flash photo with the light off-centre: the highlight centre follows the light.
    shiny = _flat_maps(n=64, diffuse=0.2, roughness=0.2, specular=0.5)
    d = ZHAO.camera_distance
    photo = render(shiny, (0.4, 0.4, d), ZHAO)  # +x right, +y up: the upper right quadrant
    row, col = bi.highlight_centre(photo)
    assert row < 32 and col > 32


def test_photo_burn_in_finds_the_highlight_and_scales_down_large_maps():
    n = 1200  # above SCORE_MAX_SIDE: scored on a block-averaged copy
    m = _flat_maps(n=n, diffuse=0.3)
    yy, xx = np.mgrid[0:n, 0:n]
    cy, cx = 400.0, 700.0
    bump = np.exp(-((yy + 0.5 - cy) ** 2 + (xx + 0.5 - cx) ** 2) / (2 * (0.08 * n) ** 2))
    burnt = Maps(**{**dict(m.items()), "diffuse": (0.3 + 0.5 * bump[..., None]).repeat(3, -1).astype(np.float32)})
    photo = (0.2 + 0.6 * bump[..., None]).repeat(3, -1)  # brightest where the maps are burnt
    out = bi.photo_burn_in(burnt, photo)
    assert out["centre"][0] == pytest.approx(cy, abs=0.03 * n) and out["centre"][1] == pytest.approx(cx, abs=0.03 * n)
    assert out["burn_diffuse"] > 1.0 and out["burn_specular"] == 0.0
    clean = bi.photo_burn_in(m, photo)
    assert abs(clean["burn_diffuse"]) < 0.15
    with pytest.raises(ValueError):
        bi.photo_burn_in(m, photo[:10])
