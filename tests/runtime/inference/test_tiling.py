"""Overlapping tiles and their blend (svbrdf.runtime.inference.tiling)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from svbrdf.runtime.inference.tiling import ramp_weights, tile_boxes, tile_starts, tile_weights, tiled_apply


@st.composite
def layouts(draw):
    tile = draw(st.integers(1, 40))
    overlap = draw(st.integers(0, tile // 2))
    length = draw(st.integers(1, 150))
    return length, tile, overlap


@settings(max_examples=300, deadline=None)
@given(layouts())
def test_tile_starts_cover_the_axis(layout):
    length, tile, overlap = layout
    starts = tile_starts(length, tile, overlap)
    n = min(tile, length)
    assert starts[0] == 0 and starts[-1] + n == length  # first at the origin, last aligned to the border
    assert starts == sorted(set(starts))
    for a, b in zip(starts, starts[1:]):
        assert b - a <= tile - overlap  # neighbours overlap by at least `overlap`
    covered = np.zeros(length, int)
    for s in starts:
        covered[s:s + n] += 1
    assert covered.min() >= 1


@settings(max_examples=200, deadline=None)
@given(layouts(), st.integers(1, 60))
def test_weights_are_positive_and_identity_is_exact(layout, width):
    height, tile, overlap = layout
    rng = np.random.default_rng(height * 1000 + width)
    image = rng.random((height, width, 2), dtype=np.float32)
    for box in tile_boxes(height, width, tile, overlap):
        wt = tile_weights(box, height, width, overlap)
        assert wt.shape == box[2:] and wt.min() > 0 and wt.max() <= 1
    out = tiled_apply(lambda t: np.concatenate([t, t ** 2 + 1], axis=-1), image, tile, overlap)
    assert out.shape == (height, width, 4) and out.dtype == np.float32
    np.testing.assert_allclose(out[..., :2], image, atol=1e-6, rtol=0)
    np.testing.assert_allclose(out[..., 2:], image ** 2 + 1, atol=1e-6, rtol=0)


def test_ramps_are_a_partition_of_unity_over_an_exact_overlap():
    overlap = 8
    up = ramp_weights(20, overlap, 0)[:overlap]
    down = ramp_weights(20, 0, overlap)[-overlap:]
    np.testing.assert_allclose(up + down, 1.0, atol=1e-6)
    assert np.all(np.diff(up) > 0) and up[0] > 0
    np.testing.assert_array_equal(ramp_weights(20, 0, 0), 1.0)  # image borders: no ramp
    with pytest.raises(ValueError, match="do not fit"):
        ramp_weights(20, 12, 10)


@pytest.mark.parametrize("length,tile,overlap,starts", [(2048, 1024, 64, [0, 512, 1024]), (1536, 1024, 64, [0, 512]),
                                                        (3000, 1024, 64, [0, 672, 1312, 1976]), (100, 40, 8, [0, 32, 60]), (100, 24, 4, [0, 20, 40, 56, 76]), (160, 64, 16, [0, 48, 96])])
def test_windows_are_spread_evenly(length, tile, overlap, starts):
    assert tile_starts(length, tile, overlap) == starts


@pytest.mark.parametrize("length,tile", [(2048, 1024), (1536, 1024), (1100, 1024), (3000, 1024), (95, 32)])
def test_the_blend_ramps_over_the_whole_overlap(length, tile):
    """Each pixel's weights sum to one before normalisation wherever at most two windows overlap, and the ramp
    spans the overlap: a jump between two tiles' levels is spread over the overlap, not over ``overlap`` pixels."""
    overlap = 8
    boxes = tile_boxes(1, length, tile, overlap)
    total = np.zeros(length)
    for box in boxes:
        total[box[1]:box[1] + box[3]] += tile_weights(box, 1, length, overlap)[0]
    starts = [b[1] for b in boxes]
    if all(starts[k] + tile - starts[k + 1] <= tile // 2 for k in range(len(starts) - 1)):
        np.testing.assert_allclose(total, 1.0, atol=1e-6)
    levels = iter(range(len(boxes)))
    out = tiled_apply(lambda t: np.full(t.shape[:2] + (1,), float(next(levels)), np.float32),
                      np.zeros((1, length, 1), np.float32), tile, overlap)[0, :, 0]
    step = np.abs(np.diff(out)).max()
    narrowest = min(starts[k] + tile - starts[k + 1] for k in range(len(starts) - 1))
    assert step <= np.pi / 2 / min(narrowest, tile // 2) + 1e-6  # a raised cosine's steepest step for a jump of 1


def test_boxes_are_row_major_and_clipped():
    assert tile_boxes(10, 25, 10, 2) == [(0, 0, 10, 10), (0, 8, 10, 10), (0, 15, 10, 10)]
    assert tile_boxes(5, 7, 16, 4) == [(0, 0, 5, 7)]


def _box_blur(image, radius):
    """Mean over a (2r+1)^2 window with edge replication: a local operator with seams at tile borders."""
    pad = np.pad(image, ((radius, radius), (radius, radius), (0, 0)), mode="edge")
    h, w = image.shape[:2]
    out = np.zeros_like(image)
    for dy in range(2 * radius + 1):
        for dx in range(2 * radius + 1):
            out += pad[dy:dy + h, dx:dx + w]
    return out / (2 * radius + 1) ** 2


def test_local_operator_matches_untiled_away_from_seams():
    height, width, tile, overlap, radius = 70, 95, 32, 8, 2
    image = np.random.default_rng(1).random((height, width, 3), dtype=np.float32)
    ref = _box_blur(image, radius)
    out = tiled_apply(lambda t: _box_blur(t, radius), image, tile, overlap)
    # A tile's result is exact wherever it is >= radius from its inner edges; a blend of exact values is exact.
    bad = np.zeros((height, width), bool)
    for y0, x0, h, w in tile_boxes(height, width, tile, overlap):
        inner = np.zeros((h, w), bool)
        if y0 > 0:
            inner[:radius] = True
        if y0 + h < height:
            inner[h - radius:] = True
        if x0 > 0:
            inner[:, :radius] = True
        if x0 + w < width:
            inner[:, w - radius:] = True
        bad[y0:y0 + h, x0:x0 + w] |= inner
    assert (~bad).mean() > 0.7
    np.testing.assert_allclose(out[~bad], ref[~bad], atol=1e-6)
    # At the seams the blend stays close to the truth: the wrong tile's weight is small there.
    naive = tiled_apply(lambda t: _box_blur(t, radius), image, tile, 0)
    assert np.abs(out - ref)[bad].mean() < np.abs(naive - ref)[bad].mean()


def test_single_tile_calls_fn_once_on_the_whole_image():
    calls = []
    image = np.ones((20, 30, 3), np.float32)
    tiled_apply(lambda t: calls.append(t.shape) or t, image, 30, 5)
    assert calls == [(20, 30, 3)]


def test_invalid_arguments():
    image = np.zeros((20, 20, 3), np.float32)
    with pytest.raises(ValueError, match="overlap"):
        tiled_apply(lambda t: t, image, 8, 5)
    with pytest.raises(ValueError, match="tile"):
        tile_starts(10, 0, 0)
    with pytest.raises(ValueError, match=r"\(H, W, C\)"):
        tiled_apply(lambda t: t, np.zeros((20, 20), np.float32), 8, 2)
    with pytest.raises(ValueError, match="fn must return"):
        tiled_apply(lambda t: t[:-1], image, 8, 2)


@pytest.mark.parametrize("shape", [(12, 20, 3), (13, 22, 1), (7, 5, 2)])
def test_block_mean_full_and_partial_blocks(shape):
    from svbrdf.runtime.core.filters import block_mean

    a = np.random.default_rng(0).uniform(0, 1, shape).astype(np.float64)
    h, w, c = shape
    k = 4
    full = block_mean(a, k)
    assert full.dtype == np.float32 and full.shape == (h // k, w // k, c)
    np.testing.assert_allclose(full, a[:h // k * k, :w // k * k].reshape(h // k, k, w // k, k, c).mean(axis=(1, 3)),
                               atol=1e-6)
    part = block_mean(a, k, partial=True)
    assert part.shape == (-(-h // k), -(-w // k), c)
    for i in range(part.shape[0]):
        for j in range(part.shape[1]):
            np.testing.assert_allclose(part[i, j], a[i * k:(i + 1) * k, j * k:(j + 1) * k].mean(axis=(0, 1)), atol=1e-6)
    assert block_mean(a, 1).dtype == np.float32 and block_mean(a, 1).shape == shape


@pytest.mark.parametrize("k", [2, 3, 8, 17])
@pytest.mark.parametrize("c", [1, 3, 4])
def test_block_mean_adds_in_the_order_of_one_reduction(k, c):
    """The block's columns added slice by slice give the bits of numpy's reduction over that axis (what the
    post-processing was tuned with), full and partial blocks."""
    from svbrdf.runtime.core.filters import block_mean

    a = np.random.default_rng(k * c).uniform(-1, 2, (5 * k + 3, 4 * k + 1, c)).astype(np.float32)
    bh, bw = a.shape[0] // k, a.shape[1] // k
    rows = a[:bh * k, :bw * k].reshape(bh, k, bw * k * c).sum(axis=1, dtype=np.float32)
    want = rows.reshape(bh, bw, k, c).sum(axis=2) / np.float32(k * k)
    np.testing.assert_array_equal(block_mean(a, k), want)
    bh, bw = -(-a.shape[0] // k), -(-a.shape[1] // k)
    padded = np.zeros((bh * k, bw * k, c), np.float32)
    padded[:a.shape[0], :a.shape[1]] = a
    sums = padded.reshape(bh, k, bw * k * c).sum(axis=1, dtype=np.float32).reshape(bh, bw, k, c).sum(axis=2)
    counts = (np.minimum(k, a.shape[0] - k * np.arange(bh)).astype(np.float32)[:, None, None]
              * np.minimum(k, a.shape[1] - k * np.arange(bw)).astype(np.float32)[None, :, None])
    np.testing.assert_array_equal(block_mean(a, k, partial=True), sums / counts)


def test_box_mean_is_the_window_mean_with_edges_repeated():
    from svbrdf.runtime.core.filters import box_mean

    x = np.random.default_rng(0).uniform(0, 1, (9, 11, 2))
    r = 2
    padded = np.pad(x, ((r, r), (r, r), (0, 0)), mode="edge")
    want = np.stack([[padded[i:i + 2 * r + 1, j:j + 2 * r + 1].mean(axis=(0, 1)) for j in range(11)]
                     for i in range(9)])
    got = box_mean(x, r)
    assert got.shape == x.shape and got.dtype == np.float64
    np.testing.assert_allclose(got, want, atol=1e-12)
