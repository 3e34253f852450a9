"""runtime.core.relief: height from normals (analytic fields recovered, slopes agree, across the wrap too), ambient
occlusion (flat = 1, pits darker than plateaus, follows the hollows, a V-groove against its closed form), input
errors, tiny and odd-sized maps."""

import numpy as np
import pytest

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.core.relief import (
    AO_RADIUS, ambient_occlusion, denormalise, height_from_normals, normal_slopes, normalise, slope_correlation,
)


def _normals(dh_dcol: np.ndarray, dh_drow: np.ndarray) -> np.ndarray:
    """Unit OpenGL normals of a height (pixel units) with the given derivatives along columns (right) and rows
    (down): the slope up the image is -dh/drow, so n ~ (-dh/dcol, +dh/drow, 1)."""
    n = np.stack([-dh_dcol, dh_drow, np.ones_like(dh_dcol)], axis=-1)
    return (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)


def _sines(h=96, w=128):
    """A periodic sum of sines (pixel units, amplitude a few px) and its analytic normals."""
    i, j = np.mgrid[0:h, 0:w].astype(np.float64)
    a, b = 2 * np.pi / w, 2 * np.pi / h
    hp = 3 * np.sin(2 * a * j) * np.cos(b * i) + 2 * np.cos(3 * b * i) + 1.5 * np.sin(a * j + 2 * b * i)
    dc = 6 * a * np.cos(2 * a * j) * np.cos(b * i) + 1.5 * a * np.cos(a * j + 2 * b * i)
    dr = -3 * b * np.sin(2 * a * j) * np.sin(b * i) - 6 * b * np.sin(3 * b * i) + 3 * b * np.cos(a * j + 2 * b * i)
    return hp, _normals(dc, dr)


def _bump(h=80, w=112):
    """A non-periodic field: an off-centre Gaussian bump on a tilted plane (pixel units), and its normals."""
    i, j = np.mgrid[0:h, 0:w].astype(np.float64)
    g = np.exp(-((j - 70) ** 2 + (i - 30) ** 2) / (2 * 12.0 ** 2))
    hp = 8 * g + 0.05 * j - 0.08 * i
    dc = 8 * g * (-(j - 70) / 12.0 ** 2) + 0.05
    dr = 8 * g * (-(i - 30) / 12.0 ** 2) - 0.08
    return hp, _normals(dc, dr)


def _blur(a: np.ndarray, sigma: float) -> np.ndarray:
    """Periodic Gaussian blur by FFT."""
    fy = np.fft.fftfreq(a.shape[0])[:, None]
    fx = np.fft.rfftfreq(a.shape[1])[None, :]
    return np.fft.irfft2(np.fft.rfft2(a) * np.exp(-2 * (np.pi * sigma) ** 2 * (fx ** 2 + fy ** 2)), s=a.shape)


def _corr(a, b):
    a = np.ravel(a) - np.mean(a)
    b = np.ravel(b) - np.mean(b)
    return float(a @ b / np.sqrt((a @ a) * (b @ b)))


# ------------------------------------------------------------------------------------------------ height

@pytest.mark.parametrize("tileable", [True, False])
def test_periodic_sines_recovered_up_to_a_constant(tileable):
    hp, n = _sines()
    w = hp.shape[1]
    height, scale = height_from_normals(n, tileable=tileable, low_cut=0)  # the plain integration (1-2 cycles here)
    assert height.dtype == np.float32 and height.shape == hp.shape
    assert abs(float(height.mean())) < 1e-7  # mean level removed
    err_px = np.abs(height * w - (hp - hp.mean())).max()
    # amplitude ~6.5 px; the pair-averaged slopes' discretisation error is ~1e-3 relative at 32+ px per period
    assert err_px < 0.03, err_px
    assert scale == pytest.approx(2 * np.abs(height).max())
    c = slope_correlation(height, n, tileable=tileable)
    assert min(c["x"], c["y"]) > 0.999
    if tileable:
        assert min(c["wrap_x"], c["wrap_y"]) > 0.999


def test_non_periodic_bump_on_a_tilted_plane():
    hp, n = _bump()
    w = hp.shape[1]
    height, _ = height_from_normals(n, low_cut=0)  # Neumann: the tilt is kept, nothing wraps
    err_px = np.abs(height * w - (hp - hp.mean())).max()
    assert err_px < 0.05, err_px  # range ~14 px
    c = slope_correlation(height, n)
    assert min(c["x"], c["y"]) > 0.999
    # a periodic solve of the same map has to drop the tilt and bend the bump: visibly worse, but still integrates
    periodic, _ = height_from_normals(n, tileable=True, low_cut=0)
    assert np.abs(periodic * w - (hp - hp.mean())).max() > 10 * err_px


def test_units_width_and_normalised_map():
    """Heights are in map widths: the same material at twice the resolution (the same normals, sampled twice as
    densely: slopes are rise over run, resolution-free) gets the same heights and scale."""
    hp, n = _sines(64, 64)
    height, scale = height_from_normals(n, tileable=True)
    i, j = np.mgrid[0:128, 0:128] / 2.0  # the 64-px field's coordinates, twice as dense
    a, b = 2 * np.pi / 64, 2 * np.pi / 64
    dc = (6 * a * np.cos(2 * a * j) * np.cos(b * i) + 1.5 * a * np.cos(a * j + 2 * b * i))
    dr = (-3 * b * np.sin(2 * a * j) * np.sin(b * i) - 6 * b * np.sin(3 * b * i) + 3 * b * np.cos(a * j + 2 * b * i))
    height2, scale2 = height_from_normals(_normals(dc, dr), tileable=True)  # derivatives per 64-px pixel
    assert scale2 == pytest.approx(scale, rel=0.01)
    assert np.abs(height2[::2, ::2] - height).max() < 0.01 * scale
    h01, s = normalise(height)
    assert s == pytest.approx(scale) and h01.dtype == np.float32
    assert 0.0 <= h01.min() and h01.max() <= 1.0 and max(h01.max() - 0.5, 0.5 - h01.min()) == pytest.approx(0.5)
    assert float(h01.mean()) == pytest.approx(0.5, abs=1e-6)  # mid-grey = the mean level
    assert np.abs(denormalise(h01, s) - height).max() < 1e-6


def test_flat_normal_map_gives_flat_height_and_open_ao():
    n = np.zeros((33, 47, 3), np.float32)
    n[..., 2] = 1
    for tileable in (False, True):
        height, scale = height_from_normals(n, tileable=tileable)
        assert np.all(height == 0) and scale == 0.0
        h01, s = normalise(height)
        assert np.all(h01 == 0.5) and s == 0.0
        assert np.all(ambient_occlusion(height, tileable=tileable) == 1.0)
        assert np.all(ambient_occlusion(h01, s, tileable=tileable) == 1.0)


def test_real_like_noise_slopes_agree():
    """A noisy (not curl-free) normal map: the height matches its integrable part; slopes still agree well."""
    rng = np.random.default_rng(5)
    hp = _blur(rng.normal(size=(128, 160)), 3.0) * 40  # smooth random relief, pixel units
    gr, gc = np.gradient(hp)
    n = _normals(gc + 0.02 * rng.normal(size=gc.shape), gr + 0.02 * rng.normal(size=gr.shape))
    for tileable in (False, True):
        c = slope_correlation(height_from_normals(n, tileable=tileable)[0], n, tileable=tileable)
        assert min(c["x"], c["y"]) >= 0.8, c
        if tileable:
            assert min(c["wrap_x"], c["wrap_y"]) >= 0.8, c


def test_steep_and_degenerate_normals():
    n = np.zeros((4, 5, 3), np.float32)
    n[..., 2] = 1
    n[1, 2] = (1.0, 0.0, 0.0)  # horizontal: clamped to the steepest slope
    n[2, 3] = (0.0, -0.6, -0.8)  # into the surface, tilted: clamped too
    p, q = normal_slopes(n, max_slope=10)
    assert p[1, 2] == pytest.approx(-10) and q[1, 2] == 0
    assert q[2, 3] == pytest.approx(10) and p[2, 3] == 0
    n[0, 0] = 0.0  # zero-length
    with pytest.raises(SvbrdfError, match=r"1 zero-length normal\(s\) \(first at row 0, column 0\)"):
        height_from_normals(n)
    p, q = normal_slopes(n, zero="flat")
    assert p[0, 0] == 0 and q[0, 0] == 0
    height, _ = height_from_normals(n, zero="flat")
    assert np.isfinite(height).all()


def test_unit_takes_the_slopes_of_the_normals_as_written():
    """zero="unit": each strip made unit as the writers make it (z clamped at 0, a zero vector flat), the same bits
    as normalising the whole map first; any length accepted."""
    from svbrdf.runtime.core.maps import normalize_normals

    rng = np.random.default_rng(5)
    n = rng.normal(size=(70, 45, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 0.2
    n[3, 4] = 0.0  # zero-length
    n[40, 7, 2] = -0.5  # into the surface
    n *= np.float32(2.5)  # components beyond [-1, 1]
    for got, want in zip(normal_slopes(n, zero="unit"), normal_slopes(normalize_normals(n), zero="error")):
        np.testing.assert_array_equal(got, want)
    for tileable in (False, True):
        np.testing.assert_array_equal(height_from_normals(n, zero="unit", tileable=tileable)[0],
                                      height_from_normals(normalize_normals(n), tileable=tileable)[0])
    with pytest.raises(SvbrdfError, match="expected 'error', 'flat' or 'unit'"):
        normal_slopes(n, zero="repair")


@pytest.mark.parametrize("bad, match", [
    (np.zeros((4, 5)), r"expected an \(H, W, 3\) array"),
    (np.zeros((4, 5, 4)), r"expected an \(H, W, 3\) array"),
    (np.zeros((0, 5, 3)), r"expected an \(H, W, 3\) array"),
    (np.full((4, 5, 3), 32768, np.uint16), "expected decoded float normals"),
    (np.full((4, 5, 3), 3.0), "expected decoded unit normals"),
])
def test_bad_normal_maps(bad, match):
    with pytest.raises(SvbrdfError, match=match):
        height_from_normals(bad)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_normals(value):
    n = np.zeros((6, 7, 3), np.float32)
    n[..., 2] = 1
    n[4, 5, 1] = value
    with pytest.raises(SvbrdfError, match=r"1 pixel\(s\) are NaN or infinite \(first at row 4, column 5\)"):
        height_from_normals(n)


def test_bad_heights_and_sizes():
    n = np.zeros((6, 7, 3), np.float32)
    n[..., 2] = 1
    with pytest.raises(SvbrdfError, match=r"height is 7x5 px but the normal map is 7x6 px"):
        slope_correlation(np.zeros((5, 7)), n)
    with pytest.raises(SvbrdfError, match="NaN or infinite"):
        ambient_occlusion(np.full((4, 4), np.nan))
    with pytest.raises(SvbrdfError, match=r"expected an \(H, W\) array"):
        ambient_occlusion(np.zeros((4, 4, 3)))
    with pytest.raises(SvbrdfError, match="directions=6"):
        ambient_occlusion(np.zeros((4, 4)), directions=6)
    with pytest.raises(SvbrdfError, match="radius"):
        ambient_occlusion(np.zeros((4, 4)), radius=-1)
    with pytest.raises(SvbrdfError, match="height scale"):
        ambient_occlusion(np.zeros((4, 4)), scale=float("nan"))
    with pytest.raises(SvbrdfError, match="zero="):
        height_from_normals(n, zero="ignore")


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1), (2, 3), (7, 5)])
@pytest.mark.parametrize("tileable", [False, True])
def test_tiny_maps(shape, tileable):
    rng = np.random.default_rng(1)
    n = rng.normal(size=shape + (3,)) * 0.2
    n[..., 2] = 1
    height, scale = height_from_normals(n, tileable=tileable)
    assert height.shape == shape and np.isfinite(height).all() and scale >= 0
    ao = ambient_occlusion(height, tileable=tileable)
    assert ao.shape == shape and ao.dtype == np.float32 and np.all((0 <= ao) & (ao <= 1))
    if shape[1] == 1:  # a 1-pixel-wide map: only vertical slopes exist
        i = np.arange(shape[0], dtype=np.float64)
        n1 = _normals(np.zeros((shape[0], 1)), 0.3 * np.ones((shape[0], 1)))  # h_px = 0.3 i: a ramp down
        h1, _ = height_from_normals(n1, low_cut=0)
        assert np.allclose(h1[:, 0] * 1, 0.3 * (i - i.mean()), atol=1e-5)
        assert np.allclose(height_from_normals(n1)[0], h1, atol=1e-5)  # a tilt the normals show: kept
        faint = _normals(np.zeros((shape[0], 1)), 0.003 * np.ones((shape[0], 1)))  # a faint bias: taken out
        assert np.abs(height_from_normals(faint)[0]).max() < 1e-7


# ------------------------------------------------------------------------------------------------ AO

def test_ao_planes_are_open():
    i, j = np.mgrid[0:64, 0:80].astype(np.float32)
    for plane in (0.3 * j - 0.7 * i, np.full((64, 80), 5.0, np.float32)):
        ao = ambient_occlusion(plane / 80)  # pixel units -> map widths
        assert np.abs(ao - 1).max() < 1e-5


def test_ao_pit_darker_than_plateau():
    i, j = np.mgrid[0:96, 0:96].astype(np.float64)
    pit = -10 * np.exp(-((i - 48) ** 2 + (j - 48) ** 2) / (2 * 4.0 ** 2))  # 10 px deep, pixel units
    ao = ambient_occlusion(pit / 96, radius=16 / 96)
    assert ao[48, 48] < 0.8
    assert ao[5, 5] == pytest.approx(1.0, abs=1e-6)  # the plateau far from the pit
    assert ao[48, 48] == ao.min()
    # the same relief as a bump: its top is open (up to the bilinear upsampling of the coarse levels, which
    # leaks a trace of the bump's foot)
    assert ambient_occlusion(-pit / 96, radius=16 / 96)[48, 48] > 0.995


def test_ao_sees_walls_beyond_the_finest_samples():
    """The flat floor of a wide round well (radius 10 px, 10 px deep): the nearest wall is 10 px away, far
    beyond the finest level's 1-2 px samples; the coarser levels must see it (the wall subtends ~45 deg)."""
    i, j = np.mgrid[0:128, 0:128].astype(np.float64)
    well = np.where(np.hypot(i - 64, j - 64) < 10, -10.0, 0.0)
    ao = ambient_occlusion(well / 128, radius=32 / 128)
    assert ao[64, 64] < 0.85
    assert ao[5, 5] == pytest.approx(1.0, abs=1e-6)


def test_ao_v_groove_against_the_closed_form():
    """At the bottom of a long 90-degree V-groove the cosine-weighted visible fraction is sin(45 deg) = 0.707;
    the 8-direction estimate: (2 x cos^2 45 deg + 4 x 1 / (1 + 1/2) + 2 x 1) / 8 = 0.708."""
    i, j = np.mgrid[0:64, 0:65].astype(np.float32)
    groove = np.abs(j - 32)  # walls at 45 deg, pixel units
    ao = ambient_occlusion(groove / 65, radius=8 / 65, tileable=True)
    assert ao[20, 32] == pytest.approx((2 * 0.5 + 4 / 1.5 + 2) / 8, abs=1e-4)
    assert ao[20, 32] == pytest.approx(np.sin(np.pi / 4), abs=0.01)
    assert ao[20, 20] == pytest.approx(1.0, abs=1e-6)  # on a wall: nothing above its own plane in reach


@pytest.mark.parametrize("tileable", [True, False])
def test_ao_follows_the_hollows(tileable):
    rng = np.random.default_rng(2)
    size = 128
    hp = _blur(rng.normal(size=(size, size)), 2.5) * 30  # pixel units
    height = (hp / size).astype(np.float32)
    ao = ambient_occlusion(height, tileable=tileable)
    assert ao.dtype == np.float32 and 0 <= ao.min() and ao.max() <= 1
    sigma = AO_RADIUS * size / 2
    assert _corr(1 - ao, _blur(hp, sigma) - hp) >= 0.3
    assert 0.6 <= float(ao.mean()) < 1.0
    # written and read back through the normalised map and its scale: the same AO (16-bit quantisation aside)
    h01, s = normalise(height)
    q = np.round(h01 * 65535) / 65535
    assert np.abs(ambient_occlusion(q, s, tileable=tileable) - ao).max() < 1e-2


def test_ao_tileable_wraps():
    """A tileable AO of a shifted (rolled) height is the rolled AO: nothing special happens at the border."""
    rng = np.random.default_rng(3)
    hp = _blur(rng.normal(size=(64, 96)), 2.0) * 20
    ao = ambient_occlusion(hp / 96, tileable=True, radius=8 / 96)
    rolled = ambient_occlusion(np.roll(hp, (16, 16), axis=(0, 1)) / 96, tileable=True, radius=8 / 96)
    assert np.abs(np.roll(ao, (16, 16), axis=(0, 1)) - rolled).max() < 1e-5


def test_ao_max_size_levels():
    """Computed on a coarser grid (max_size) the AO keeps its broad shape; 4 directions are allowed."""
    rng = np.random.default_rng(4)
    hp = _blur(rng.normal(size=(128, 128)), 4.0) * 40
    full = ambient_occlusion(hp / 128, tileable=True)
    coarse = ambient_occlusion(hp / 128, tileable=True, max_size=64)
    assert coarse.shape == full.shape
    assert _corr(full, coarse) > 0.8
    four = ambient_occlusion(hp / 128, tileable=True, directions=4)
    assert _corr(full, four) > 0.8


@pytest.mark.parametrize("tileable", [False, True])
def test_threads_give_the_same_relief(monkeypatch, tileable):
    """The DCT passes, the slopes and the AO levels split over threads (slices of rows or columns, runs of strips)
    give the values of one thread, and a zero-length normal is reported at the same place."""
    from svbrdf.runtime.core import relief

    rng = np.random.default_rng(11)
    n = rng.normal(size=(150, 97, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 0.5
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    monkeypatch.setattr(relief, "_THREAD_PIXELS", 1)
    out = {}
    for threads in (1, 3):
        monkeypatch.setattr(relief, "THREADS", threads)
        r = relief.relief_maps(n, tileable=tileable)
        out[threads] = (r.height, r.ao, r.scale)
    assert all(np.array_equal(a, b) for a, b in zip(out[1][:2], out[3][:2])) and out[1][2] == out[3][2]
    n[120, 40] = 0.0
    n[130, 3] = 0.0
    with pytest.raises(SvbrdfError, match=r"2 zero-length normal\(s\) \(first at row 120, column 40\)"):
        relief.height_from_normals(n)


def test_ao_strength_is_the_ao_of_the_scaled_height():
    """strength=k gives the AO of k x the height to the bit (relief_maps passes its AO strength so), and is checked."""
    h = np.random.default_rng(8).normal(size=(60, 70)).astype(np.float32) * 0.01
    np.testing.assert_array_equal(ambient_occlusion(h, strength=8.0), ambient_occlusion(h * np.float32(8.0)))
    for bad in (0.0, -1.0, float("nan"), "deep"):
        with pytest.raises(SvbrdfError, match="strength"):
            ambient_occlusion(h, strength=bad)


@pytest.mark.parametrize("tileable", [False, True])
def test_the_poisson_right_hand_side_is_the_transposed_difference_of_the_pair_slopes(tileable):
    """The height's right-hand side, made strip by strip from the normals, is D^T g of the pair slopes (the pairs
    arriving at a pixel minus those leaving it; no pair across an open border), computed here from whole maps."""
    from svbrdf.runtime.core import relief

    rng = np.random.default_rng(12)
    n = rng.normal(size=(37, 23, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 0.3
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    gx, gy = (g.astype(np.float64) for g in relief._pair_slopes(*normal_slopes(n), tileable))
    if tileable:  # the pair leaving (i, j) is gx[i, j]; the one arriving, gx[i, j - 1] (wrapped)
        want = np.roll(gx, 1, axis=1) - gx + np.roll(gy, 1, axis=0) - gy
    else:
        zx, zy = np.zeros((37, 1)), np.zeros((1, 23))
        want = (np.hstack([zx, gx]) - np.hstack([gx, zx])) + (np.vstack([zy, gy]) - np.vstack([gy, zy]))
    got = relief._slope_divergence(n, relief._inverse_max_slope(relief.MAX_SLOPE), "error", tileable)
    np.testing.assert_allclose(got, want, atol=2e-6)  # 4 float32 steps at the field's largest value (7.5)


@pytest.mark.parametrize("tileable", [False, True])
def test_strip_and_block_sizes_give_the_same_relief(monkeypatch, tileable):
    """The rows per strip of the slopes (each strip with its neighbour rows' slopes) and of the AO's upsampling do
    not change a bit of the relief, and a zero-length normal is reported at the same place."""
    from svbrdf.runtime.core import relief

    rng = np.random.default_rng(13)
    n = rng.normal(size=(61, 45, 3)).astype(np.float32)
    n[..., 2] = np.abs(n[..., 2]) + 0.5
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    out = []
    for strip, block in ((32, 256), (1, 1), (5, 3)):
        monkeypatch.setattr(relief, "_STRIP", strip)
        monkeypatch.setattr(relief, "_UPSAMPLE_BLOCK", block)
        r = relief.relief_maps(n, tileable=tileable)
        out.append((r.height, relief.ambient_occlusion(r.height, tileable=tileable, max_size=16), r.scale))
        bad = n.copy()
        bad[7, 9] = bad[60, 0] = 0.0
        with pytest.raises(SvbrdfError, match=r"2 zero-length normal\(s\) \(first at row 7, column 9\)"):
            relief.height_from_normals(bad, tileable=tileable)
    for other in out[1:]:
        assert all(np.array_equal(a, b) for a, b in zip(out[0][:2], other[:2])) and out[0][2] == other[2]


# ------------------------------------------------------------------------------------ broad relief (issue 67)

def _flash_dome(h=96, w=128, centre=(38.0, 75.0), texture=True, seed=3, tilt=0.006):
    """Normals of a flat material photographed under a flash: a stationary texture (periodic blurred noise, RMS slope
    0.04, as the network's normals) plus the faint radial tilt the flash leaves (a Gaussian dome 0.35 W wide,
    steepest slope ``tilt``, off-centre); returns the normals, the texture's height (pixel units) and the distance
    of each pixel to the centre."""
    i, j = np.mgrid[0:h, 0:w].astype(np.float64)
    tex = _blur(np.random.default_rng(seed).normal(size=(h, w)), 2.0) * 0.6 if texture else np.zeros((h, w))
    s = 0.35 * w
    dome = tilt * s * np.sqrt(np.e) * np.exp(-((i + 0.5 - centre[0]) ** 2 + (j + 0.5 - centre[1]) ** 2) / (2 * s * s))
    gr, gc = np.gradient(tex + dome)
    r = np.hypot(i + 0.5 - centre[0], j + 0.5 - centre[1])
    return _normals(gc, gr), tex, r


def test_a_flat_material_under_a_flash_gets_no_dome():
    """The old height was the dome (bright at the flash, dark at the rim); a material's height keeps the texture and
    nothing centred on the flash."""
    from svbrdf.runtime.core.relief import relief_maps

    n, tex, r = _flash_dome()
    height, _ = height_from_normals(n)
    assert abs(_corr(height, r)) < 0.1, _corr(height, r)
    assert _corr(height, tex) > 0.9, _corr(height, tex)
    written = relief_maps(n, maps="height")
    assert abs(_corr(written.height, r)) < 0.1 and written.low_cut == 1.5
    info = written.info()["height"]
    assert info["low_cut"] == 1.5 and info["broad_taken"] == 1.0 and "broader than the map" in info["method"]
    plain, _ = height_from_normals(n, low_cut=0)  # the plain least-squares height: the dome dominates it
    assert _corr(plain, r) < -0.6 and _corr(plain, tex) < 0.7, (_corr(plain, r), _corr(plain, tex))
    # nothing but the faint tilt (a smooth glossy surface): flat, not a dome
    bare, _, r = _flash_dome(texture=False, tilt=0.002)
    flat = height_from_normals(bare)[0]
    assert flat.std() < 0.15 * height_from_normals(bare, low_cut=0)[0].std()  # what is left: a rim at the border


def test_genuine_relief_keeps_its_slopes():
    """Relief the normals show is kept: a field of bumps and pits loses only its broadest part (its slopes agree
    with the normals as before); relief broader than that, which the normals clearly show (sines of 1 to 2 cycles,
    a lone pit on a small map), is kept as the plain integration's."""
    from svbrdf.runtime.core.relief import relief_maps

    rng = np.random.default_rng(8)
    hp = _blur(rng.normal(size=(128, 160)), 4.0) * 60  # many bumps, a few px deep
    gr, gc = np.gradient(hp)
    n = _normals(gc, gr)
    height, _ = height_from_normals(n)
    c = slope_correlation(height, n)
    assert min(c["x"], c["y"]) > 0.99, c
    assert _corr(height, hp) > 0.95
    for hp, n in (_sines(), _bump()):
        plain, scale = height_from_normals(n, low_cut=0)
        np.testing.assert_allclose(height_from_normals(n)[0], plain, atol=1e-4 * scale)
        assert relief_maps(n, maps="height").broad_taken == 0.0


@pytest.mark.parametrize("tileable", [False, True])
def test_broad_relief_is_taken_out_across_the_wrap_too(tileable):
    """Tileable: the high-pass is periodic, the height still joins across the wrap (its slopes there agree with the
    normals'), and a broad periodic swell is gone."""
    h, w = 96, 128
    i, j = np.mgrid[0:h, 0:w].astype(np.float64)
    tex = _blur(np.random.default_rng(4).normal(size=(h, w)), 2.0) * 0.6
    swell = 0.15 * np.cos(2 * np.pi * j / w + 0.5)  # 1 cycle across, slope 0.007 at most
    hp = tex + swell
    gc = (np.roll(hp, -1, 1) - np.roll(hp, 1, 1)) / 2
    gr = (np.roll(hp, -1, 0) - np.roll(hp, 1, 0)) / 2
    n = _normals(gc, gr)
    height, _ = height_from_normals(n, tileable=tileable)
    assert abs(_corr(height, swell)) < 0.15 and _corr(height, tex) > 0.9
    if tileable:
        c = slope_correlation(height, n, tileable=True)
        assert min(c["wrap_x"], c["wrap_y"]) > 0.95, c
        hpx = height * w
        seam = np.abs(hpx[:, 0] - hpx[:, -1]).mean(), np.abs(hpx[0] - hpx[-1]).mean()
        inner = np.abs(np.diff(hpx, axis=1)).mean(), np.abs(np.diff(hpx, axis=0)).mean()
        assert seam[0] < 1.5 * inner[0] and seam[1] < 1.5 * inner[1], (seam, inner)


def test_low_cut_is_checked_and_zero_is_the_plain_integration():
    from svbrdf.runtime.core.relief import relief_maps

    n, _, _ = _flash_dome(32, 40)
    for bad in (-1, float("nan"), "x"):
        with pytest.raises(SvbrdfError, match="low_cut"):
            height_from_normals(n, low_cut=bad)
        with pytest.raises(SvbrdfError, match="low_cut"):
            relief_maps(n, low_cut=bad)
    plain = relief_maps(n, low_cut=0)
    h01, scale = normalise(height_from_normals(n, low_cut=0)[0])
    assert plain.low_cut == 0.0 and plain.scale == scale and np.array_equal(plain.height, h01)
    assert "broader" not in plain.info()["height"]["method"]


def test_with_relief_is_a_copy_with_the_relief_of_the_normal_map_and_the_method_calls_it():
    from svbrdf.runtime.core.maps import Maps, normalize_normals
    from svbrdf.runtime.core.relief import relief_maps, with_relief
    from svbrdf.runtime.core.render import DESCHAINTRE

    n, _, _ = _flash_dome(32, 40)
    n[3, 5] = 0.0  # zero-length: made (0, 0, 1), as written
    rough = np.full((32, 40, 1), 0.5, np.float32)
    maps = Maps(roughness=rough, normal=n, meta={"source": "x.png"}, render_config=DESCHAINTRE)
    out = with_relief(maps, tileable=True, maps=["height"], ao_strength=2.0)
    assert out is not maps and maps.relief is None and out.names == maps.names
    assert out.roughness is maps.roughness and out.normal is maps.normal  # the same arrays
    assert out.meta == maps.meta and out.meta is not maps.meta and out.render_config is DESCHAINTRE
    want = relief_maps(normalize_normals(n), tileable=True, maps=["height"], ao_strength=2.0)
    assert out.relief.ao is None and out.relief.tileable and out.relief.ao_strength == 2.0
    assert out.relief.scale == want.scale and np.array_equal(out.relief.height, want.height)
    same = maps.with_relief(tileable=True, maps=["height"], ao_strength=2.0)  # the compatibility method
    assert np.array_equal(same.relief.height, out.relief.height) and same.relief.scale == out.relief.scale
    full = with_relief(maps)
    assert full.relief.names == ("height", "ao") and not full.relief.tileable
    with pytest.raises(SvbrdfError, match="need the normal map; this texture set has only roughness"):
        with_relief(Maps(roughness=rough))
    bad = n.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(SvbrdfError, match="NaN or infinite"):
        with_relief(Maps(normal=bad))
