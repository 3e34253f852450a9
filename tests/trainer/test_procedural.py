"""The procedural pretraining materials (svbrdf.trainer.procedural) and their contact sheet tool."""

import numpy as np
import pytest
import torch

from svbrdf.runtime.io.images import read_image
from svbrdf.runtime.core.maps import N_CHANNELS, SLICES
from svbrdf.trainer.models import height_to_normal
from svbrdf.trainer.procedural import FAMILIES, PARAMS, sample_materials
from svbrdf.trainer.tools import contact_sheet


def _gen(seed):
    return torch.Generator().manual_seed(seed)


@pytest.fixture(scope="module")
def big_batch():
    """~240 materials of 48 px from all families (coverage statistics)."""
    torch.set_num_threads(1)
    return sample_materials(240, 48, _gen(123))


def _check_valid(maps):
    assert maps.dtype == torch.float32 and torch.isfinite(maps).all()
    for name in ("diffuse", "specular", "roughness"):
        m = maps[:, SLICES[name]]
        assert m.min() >= 0.0 and m.max() <= 1.0, name
    n = maps[:, SLICES["normal"]]
    assert (n.norm(dim=1) - 1).abs().max() < 1e-4
    assert (n[:, 2] > 0).all()


# ---- shapes, ranges, families ----

@pytest.mark.parametrize("family", FAMILIES)
def test_each_family_valid_and_bumpy(family):
    maps, names = sample_materials(3, 64, _gen(7), [family])
    assert maps.shape == (3, N_CHANNELS, 64, 64) and names == [family] * 3
    _check_valid(maps)
    n = maps[:, SLICES["normal"]]
    # normals come from a non-flat height field: tilted somewhere and not all identical
    assert (n[:, 2] < 0.9999).any(dim=(1, 2)).all()
    assert (n.flatten(2).std(-1) > 1e-3).any(dim=1).all()


def test_every_family_reachable_by_default():
    _, names = sample_materials(60, 16, _gen(3))
    assert set(names) == set(FAMILIES) and len(FAMILIES) >= 10


def test_bad_arguments():
    g = _gen(0)
    with pytest.raises(ValueError, match="unknown famil"):
        sample_materials(2, 32, g, ["tiles", "marble-ish"])
    with pytest.raises(ValueError, match="unknown famil"):
        sample_materials(2, 32, g, [])
    with pytest.raises(ValueError, match="n must be"):
        sample_materials(0, 32, g)
    with pytest.raises(ValueError, match="size must be"):
        sample_materials(2, 7, g)


def test_deterministic_given_generator_state():
    a, na = sample_materials(4, 32, _gen(11))
    b, nb = sample_materials(4, 32, _gen(11))
    c, _ = sample_materials(4, 32, _gen(12))
    assert torch.equal(a, b) and na == nb
    assert not torch.equal(a, c)
    # global RNGs are not used: reseeding them changes nothing, and they are not advanced
    torch.manual_seed(999)
    np.random.seed(999)
    state = torch.get_rng_state()
    d, _ = sample_materials(4, 32, _gen(11))
    assert torch.equal(a, d) and torch.equal(state, torch.get_rng_state())


# ---- statistics over a big batch ----

def test_parameter_box_coverage(big_batch):
    maps, _ = big_batch
    _check_valid(maps)
    d, s, r = (maps[:, SLICES[k]] for k in ("diffuse", "specular", "roughness"))
    for c in range(3):
        assert d[:, c].min() < 0.02 and d[:, c].max() > 0.8
    assert s.min() < 0.03 and s.max() > 0.6
    assert r.min() < 0.1 and r.max() > 0.9
    # per-material means spread too (not only pixel outliers)
    assert r.mean(dim=(1, 2, 3)).min() < 0.3 and r.mean(dim=(1, 2, 3)).max() > 0.8
    assert d.mean(dim=(1, 2, 3)).min() < 0.05 and d.mean(dim=(1, 2, 3)).max() > 0.5


def test_neutral_share(big_batch):
    maps, _ = big_batch
    d = maps[:, SLICES["diffuse"]]
    chroma = (d.amax(1) - d.amin(1)).flatten(1).amax(1)
    share = (chroma == 0).float().mean().item()
    assert 0.2 <= share <= 0.5
    assert (chroma > 0.1).float().mean() > 0.3  # and the rest is really coloured


def test_normal_angle_distribution(big_batch):
    maps, _ = big_batch
    ang = torch.rad2deg(torch.acos(maps[:, SLICES["normal"]][:, 2].clamp(max=1.0))).flatten(1).mean(1)
    assert 5.0 <= ang.mean() <= 15.0
    assert ang.min() < 3.0 and ang.max() > 18.0  # from almost flat to strongly bumpy


def test_specular_and_roughness_follow_classes(big_batch):
    """Few distinct levels: a material's specular is mostly near its 2-3 class values, not free noise."""
    maps, names = big_batch
    s = maps[:, SLICES["specular"]].flatten(1)
    dielectric = s.amax(1) < 0.35
    assert dielectric.float().mean() > 0.5
    # dielectrics sit mostly in 0.02-0.08
    med = s[dielectric].median(dim=1).values
    assert ((med > 0.015) & (med < 0.09)).float().mean() > 0.6


def test_metal_families_dark_diffuse_high_specular():
    maps, _ = sample_materials(12, 48, _gen(5), ["brushed_metal"])
    spec = maps[:, SLICES["specular"]]
    diff = maps[:, SLICES["diffuse"]]
    # the dominant class is metal: where specular is high, diffuse is near black
    metal = spec[:, 0] > 0.45
    assert metal.float().mean() > 0.5
    # (pixels blended at a class edge with a dielectric class are the few exceptions)
    dark = diff.amax(1)[metal] < PARAMS["metal_diffuse_max"] * 1.4  # incl. the mild noise modulation
    assert dark.float().mean() > 0.97


def test_normals_match_height_to_normal_parameterisation():
    """A normal map from height_to_normal has curl-free slopes: recover a height and re-derive the normals."""
    maps, _ = sample_materials(2, 32, _gen(8), ["tiles"])
    n = maps[:, SLICES["normal"]].double()
    # height_to_normal: nx = -s dh/dcol, ny = s dh/drow  ->  integrate along the first row, then down the columns
    gx, gy = -n[:, 0] / n[:, 2], n[:, 1] / n[:, 2]
    h = torch.zeros_like(gx)
    h[:, 0, 1:] = torch.cumsum(gx[:, 0, :-1], dim=-1)
    h[:, 1:, :] = h[:, :1, :] + torch.cumsum(gy[:, :-1, :], dim=-2)
    again = height_to_normal(h[:, None], 1.0)
    # the last row / column of height_to_normal is flat by construction; compare the interior
    assert torch.allclose(again[..., :-1, :-1], n[..., :-1, :-1], atol=1e-5)


def test_speed_8x256_one_thread():
    torch.set_num_threads(1)
    sample_materials(2, 256, _gen(0))  # warm-up (FFT plans, caches)
    import time
    t = time.perf_counter()
    sample_materials(8, 256, _gen(1))
    assert time.perf_counter() - t < 1.0  # budget 0.3 s; loose bound for a shared CI machine


# ---- contact sheet tool ----

def test_contact_sheet_writes_and_refuses_overwrite(tmp_path, capsys):
    out = tmp_path / "sheet.png"
    args = ["--out", str(out), "--per-family", "2", "--size", "16", "--families", "tiles,wood"]
    assert contact_sheet.main(args) == 0
    img = read_image(out)
    gap = contact_sheet.GAP
    assert img.shape == (2 * (16 + gap), 2 * (5 * 16 + gap), 3)
    assert contact_sheet.main(args) == 2
    assert "exists" in capsys.readouterr().err
    assert contact_sheet.main(args + ["--force"]) == 0
    assert contact_sheet.main(["--out", str(tmp_path / "x.png"), "--families", "nope"]) == 2


def test_hsv_conversion_is_kornias():
    kornia = pytest.importorskip("kornia")
    from svbrdf.trainer.procedural import hsv_to_rgb

    hsv = torch.rand(4, 3, 8, 8, generator=torch.Generator().manual_seed(0)) * torch.tensor([2 * np.pi, 1.0, 1.0]).view(1, 3, 1, 1)
    torch.testing.assert_close(hsv_to_rgb(hsv), kornia.color.hsv_to_rgb(hsv), atol=1e-6, rtol=0)


def test_an_explicit_cpu_device_gives_the_same_stream():
    a, fa = sample_materials(3, 32, torch.Generator().manual_seed(9))
    b, fb = sample_materials(3, 32, torch.Generator().manual_seed(9), device="cpu")
    assert fa == fb and torch.equal(a, b)


def _segments_one_box_at_a_time(size, g, n, angle, spread, length, width_px):
    """The scratches' segments rasterised one bounding box at a time (the plain reading of the docstring)."""
    import math

    out = torch.zeros(size, size)
    r = torch.rand(n, 6, generator=g)
    th = angle + spread * torch.randn(n, generator=g)
    for i in range(n):
        cx, cy = float(r[i, 0]) * size, float(r[i, 1]) * size
        half = 0.5 * size * (length[0] + (length[1] - length[0]) * float(r[i, 2]))
        w = width_px[0] + (width_px[1] - width_px[0]) * float(r[i, 3])
        depth = 0.4 + 0.6 * float(r[i, 4])
        dx, dy = math.cos(float(th[i])) * half, math.sin(float(th[i])) * half
        x0, x1 = int(max(0, math.floor(cx - abs(dx) - w - 1))), int(min(size, math.ceil(cx + abs(dx) + w + 2)))
        y0, y1 = int(max(0, math.floor(cy - abs(dy) - w - 1))), int(min(size, math.ceil(cy + abs(dy) + w + 2)))
        if x1 <= x0 or y1 <= y0:
            continue
        ys = torch.arange(y0, y1, dtype=torch.float32)[:, None] + 0.5 - (cy - dy)
        xs = torch.arange(x0, x1, dtype=torch.float32)[None, :] + 0.5 - (cx - dx)
        t = ((xs * 2 * dx + ys * 2 * dy) / (4 * half * half + 1e-9)).clamp(0.0, 1.0)
        m = (1.0 - torch.hypot(xs - t * 2 * dx, ys - t * 2 * dy) / w).clamp(0.0, 1.0) * depth
        out[y0:y1, x0:x1] = torch.maximum(out[y0:y1, x0:x1], m)
    return out


@pytest.mark.parametrize("chunk", [None, 1, 5000])
def test_segments_in_chunks_equal_one_box_at_a_time(monkeypatch, chunk):
    from svbrdf.trainer import procedural

    if chunk is not None:  # one segment per chunk, a few per chunk; None: the shipped budget
        monkeypatch.setattr(procedural, "SEGMENT_CHUNK_PIXELS", chunk)
    for seed, size, n, spread in ((0, 64, 15, 0.05), (1, 100, 40, 1.6), (2, 256, 90, 0.7), (3, 33, 60, 1.2)):
        args = (size, n, 0.3 * seed, spread, PARAMS["scratches_length"], PARAMS["scratches_width_px"])
        got = procedural._segments(args[0], _gen(seed), *args[1:])
        want = _segments_one_box_at_a_time(args[0], _gen(seed), *args[1:])
        assert torch.equal(got, want), (seed, (got - want).abs().max())
        assert 0 < got.max() <= 1 and got.min() == 0


@pytest.mark.parametrize("stones", [True, False])
def test_coarse_height_stones_and_warps(monkeypatch, stones):
    """:func:`coarse_height` (the prior's ``coarse_share``): uneven stones sit at their own levels with grooves
    down to 0 between them; a warp is smooth (its second differences far below its range); the tilt is drawn in
    ``coarse_tilt_deg``; the same generator state gives the same relief."""
    from svbrdf.trainer.procedural import PARAMS, coarse_height

    monkeypatch.setitem(PARAMS, "coarse_stones_p", 1.0 if stones else 0.0)
    lo, hi = PARAMS["coarse_tilt_deg"]
    for seed in range(4):
        h, tilt = coarse_height(64, torch.Generator().manual_seed(seed))
        h2, tilt2 = coarse_height(64, torch.Generator().manual_seed(seed))
        assert torch.equal(h, h2) and tilt == tilt2 and lo <= tilt <= hi
        assert h.shape == (64, 64) and bool(torch.isfinite(h).all())
        spread = float(h.max() - h.min())
        curvature = float((h[2:] - 2 * h[1:-1] + h[:-2]).abs().mean())
        if stones:
            assert float(h.min()) >= 0.0 and float((h < 0.05).float().mean()) > 0.005  # grooves
            assert float((h > 0.25).float().mean()) > 0.5 and float(h.max()) <= 2.0  # the stones' tops
        else:
            assert spread > 0 and curvature < 0.02 * spread
