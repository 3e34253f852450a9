"""The label-free highlight burn-in score (svbrdf.runtime.quality.burn_in): hand-made fields with known answers."""

import numpy as np
import pytest

from svbrdf.runtime.quality import burn_in as bi
from svbrdf.runtime.core.maps import Maps
from svbrdf.runtime.core.render import ZHAO, render


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
    assert set(scores) == set(bi.BURN_METRICS) | set(bi.RING_METRICS) | {"burn_in"}
    assert scores["burn_specular"] == 0.0 and scores["burn_normal"] == 0.0
    assert scores["ring_specular"] == 0.0 and scores["ring_normal"] == 0.0
    per_map = [max(abs(scores[f"burn_{n}"]), bi.RING_WEIGHT * scores[f"ring_{n}"])
               for n in ("diffuse", "specular", "roughness", "normal")]
    assert scores["burn_in"] == pytest.approx(max(per_map))
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


def _rings(n, centre, period=0.08, amp=0.1, noise=0.0, seed=0):
    yy, xx = np.mgrid[0:n, 0:n]
    r = np.hypot(yy + 0.5 - centre[0], xx + 0.5 - centre[1]) / n
    g = 0.5 + amp * np.cos(2 * np.pi * r / period)
    return g + noise * np.random.default_rng(seed).standard_normal((n, n))


def test_ring_score_sees_rings_that_the_disc_score_misses():
    n = 256
    rings = _rings(n, (n / 2, n / 2), noise=0.05)
    # Concentric rings whose disc and ring means nearly agree: b is small, the ring score is large.
    assert abs(bi.burn_in(rings)) < 0.3
    assert bi.ring_score(rings) > 0.5
    # A stationary texture, a constant, and a near-constant field (a flat normal map's n_z) score ~0.
    noise = 0.5 + 0.1 * np.random.default_rng(2).standard_normal((n, n))
    assert bi.ring_score(noise) < 0.02
    assert bi.ring_score(np.full((n, n), 0.3)) == 0.0
    tiny = _rings(n, (n / 2, n / 2), amp=1e-4)
    assert bi.ring_score(tiny) < 1e-3
    # Rings a little off the highlight centre are still found (the centre search); far away they are not.
    off = _rings(n, (n / 2 + 8, n / 2 - 8), noise=0.05)
    assert bi.ring_score(off) > 0.5
    far = _rings(n, (40, 40), noise=0.05)
    assert bi.ring_score(far) < 0.5 * bi.ring_score(off)


def test_ring_score_radial_share_is_a_variance_share():
    n = 64
    yy, xx = np.mgrid[0:n, 0:n]
    r = np.hypot(yy + 0.5 - n / 2, xx + 0.5 - n / 2) / n
    assert bi.radial_share(r, (n / 2, n / 2)) > 0.95  # a purely radial field
    stripes = np.sin(xx / 3.0)  # structure that does not follow the distance
    assert 0.0 <= bi.radial_share(stripes, (n / 2, n / 2)) < 0.25


def test_burn_in_counts_rings_and_the_worst_map():
    n = 128
    m = _flat_maps(n=n, diffuse=0.3)
    rough = _rings(n, (n / 2, n / 2), amp=0.15, noise=0.02)[..., None].astype(np.float32)
    ringed = Maps(**{**dict(m.items()), "roughness": rough})
    s = bi.burn_in_scores(ringed)
    assert s["ring_roughness"] > 0.5
    assert s["burn_in"] == pytest.approx(bi.RING_WEIGHT * s["ring_roughness"])
    # The constant specular and flat normal maps (score 0) do not dilute it: the worst map counts.
    assert s["burn_in"] > 1.0
    assert bi.burn_in_scores(m)["burn_in"] < 0.2


def test_ring_score_is_the_best_radial_share_of_its_search_to_the_last_bit():
    """The ring score sums every centre of its search at once (one gather, one bincount); the reference is
    radial_share centre by centre, as the score was computed before (issue 54): equal, not close."""
    rng = np.random.default_rng(3)
    for shape, centre in [((128, 128), None), ((96, 128), (30.2, 70.9)), ((40, 50), (13.0, 20.5)),
                          ((256, 200), (100.0, 90.0))]:
        field = rng.random(shape).astype(np.float32) + np.hypot(*np.mgrid[:shape[0], :shape[1]]) / 100
        g, (cy, cx) = field, centre or (shape[0] / 2.0, shape[1] / 2.0)
        k = max(1, -(-max(shape) // bi.RING_MAX_SIDE))
        if k > 1:
            from svbrdf.runtime.core.filters import block_mean

            g, cy, cx = block_mean(field[..., None], k)[..., 0], cy / k, cx / k
        sd = float(g.std())
        w = g.shape[1]
        steps = np.arange(-round(bi.RING_SEARCH * bi.RING_BINS), round(bi.RING_SEARCH * bi.RING_BINS) + 1) * (w / bi.RING_BINS)
        best = max(bi.radial_share(g, (cy + dy, cx + dx)) for dy in steps for dx in steps)
        weight = sd * sd / (sd * sd + bi.BURN_EPS * bi.BURN_EPS)
        assert bi.ring_score(field, centre) == float(best * weight)
