"""The procedural stream as flash photos (trainer/prior/photos.py): the photo model, crops, the batched stream, the
shares of flat, near-black and coarse-relief materials, and no GPU wait in a batch."""

import numpy as np
import pytest
import torch

from svbrdf.runtime.core.colour import linear_to_srgb
from svbrdf.runtime.core.maps import SLICES
from svbrdf.trainer.device import to_device
from svbrdf.trainer.prior import PriorConfig, PriorTrainer, prior_preset, sample_batch, simulate_photos, \
    view_light_directions
from svbrdf.trainer.prior.config import override
from svbrdf.trainer.procedural import sample_materials

pytestmark = pytest.mark.usefixtures("one_thread")


def _assert_the_validation_batch_ignores(cfg, name):
    """The validation batch of ``cfg`` with the share ``name`` at 0.9 is the one at ``cfg``'s: it never has them."""
    base = PriorTrainer(cfg, device="cpu", threads=1).eval_set()
    other = PriorTrainer(override(cfg, {name: 0.9}), device="cpu", threads=1).eval_set()
    assert all(torch.equal(x, y) for x, y in zip(base, other))


def test_simulated_photos_are_8bit_clipped_and_reproducible(tiny):
    cfg = tiny()
    maps, _ = sample_materials(3, 64, torch.Generator().manual_seed(1))
    a, ma, draws = simulate_photos(maps, cfg, torch.Generator().manual_seed(2))
    b, mb, _ = simulate_photos(maps, cfg, torch.Generator().manual_seed(2))
    assert a.shape == (3, 3, 64, 64) and torch.equal(a, b) and torch.equal(ma, maps)
    assert a.min() >= 0 and a.max() <= 1
    codes = linear_to_srgb(a.numpy()) * 255.0
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-2)  # stored as 8-bit sRGB (float32 round trip)
    for d in draws:
        assert cfg.photos.fov_deg[0] <= d["fov_deg"] <= cfg.photos.fov_deg[1]
        assert abs(d["light"][0]) <= cfg.photos.light_offset and abs(d["light"][1]) <= cfg.photos.light_offset
        assert cfg.photos.camera["ev"][0] <= d["camera"]["ev"] <= cfg.photos.camera["ev"][1]
    c, mc, _ = simulate_photos(maps, cfg, torch.Generator().manual_seed(3), crop=32)
    assert c.shape == (3, 3, 32, 32) and mc.shape == (3, 8, 32, 32)
    assert not torch.equal(c, a[..., :32, :32]) or not torch.equal(mc, maps[..., :32, :32])


def test_flash_photo_is_brightest_near_the_centre_on_a_flat_glossy_material(tiny):
    maps = torch.zeros(1, 8, 64, 64)
    maps[:, SLICES["diffuse"]] = 0.2
    maps[:, SLICES["specular"]] = 0.04
    maps[:, SLICES["roughness"]] = 0.3
    maps[:, SLICES["normal"]] = torch.tensor([0.0, 0.0, 1.0]).view(1, 3, 1, 1)
    dark = tiny({"photos.camera": {"ev": (0, 0), "vignetting": (0, 0), "shot": (0, 0), "read": (0, 0)}})
    photo, _, draws = simulate_photos(maps, dark, torch.Generator().manual_seed(0))
    lum = photo[0].mean(0)
    centre, corner = lum[24:40, 24:40].mean(), lum[:8, :8].mean()
    assert centre > 2 * corner  # highlight and inverse-square fall-off


def test_sample_batch_mixes_crops_and_whole_photos(tiny):
    cfg = tiny({"optim.batch": 2, "photos.crop_share": 0.5})
    rng = torch.Generator().manual_seed(0)
    kinds = set()
    for _ in range(8):
        photos, maps, info = sample_batch(cfg, rng)
        assert photos.shape == (2, 3, 32, 32) and maps.shape == (2, 8, 32, 32)
        kinds.add(info["crop"])
    assert kinds == {True, False}


def test_view_light_directions_honour_the_grazing_range_and_mirror_every_other_pair(tiny):
    rng = torch.Generator().manual_seed(3)
    deg = lambda d: torch.rad2deg(torch.acos(d[..., 2]))  # noqa: E731
    graze = view_light_directions(20, tiny({"losses.grazing_share": 1.0}), rng)
    assert graze.shape == (20, 2, 3) and torch.allclose(graze.norm(dim=-1), torch.ones(20, 2))
    assert deg(graze).min() >= 60.0 - 1e-4 and deg(graze).max() <= 75.0 + 1e-4
    steep = view_light_directions(20, tiny({"losses.grazing_share": 0.0}), rng)
    assert deg(steep).max() < 60.0
    mirrored = graze[1::2]
    assert torch.allclose(mirrored[:, 1, :2], -mirrored[:, 0, :2]) and torch.allclose(mirrored[:, 1, 2],
                                                                                      mirrored[:, 0, 2])


def test_batched_photos_follow_the_same_photo_model(tiny_v2):
    cfg = tiny_v2({"photos.crop_share": 0.0})
    photos, maps, info = sample_batch(cfg, torch.Generator().manual_seed(4))
    assert photos.shape == (2, 3, 32, 32) and maps.shape == (2, 8, 32, 32)
    assert photos.min() >= 0 and photos.max() <= 1 and len(info["draws"]) == 2
    codes = linear_to_srgb(photos.numpy()) * 255.0
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-2)  # 8-bit sRGB like the numpy camera
    again, _, _ = sample_batch(cfg, torch.Generator().manual_seed(4))
    assert torch.equal(photos, again)
    crops, cmaps, _ = sample_batch(tiny_v2({"photos.crop_share": 1.0}), torch.Generator().manual_seed(4))
    assert crops.shape == (2, 3, 32, 32) and cmaps.shape == (2, 8, 32, 32)


def test_batched_crops_are_photographed_alone_and_equal_crops_of_the_whole_photos(tiny_v2):
    """A crop batch renders only its windows, with their positions in the whole photo (flash geometry) and in the
    frame (vignetting): without noise, each crop equals the same window of the whole photograph."""
    from svbrdf.trainer.prior import draw_materials, simulate_photos_batched

    quiet = {k: (v if k in ("ev", "vignetting", "white") else (0.0, 0.0))
             for k, v in prior_preset("v2").photos.camera.items()}
    cfg = tiny_v2({"photos.crop_share": 1.0, "photos.camera": quiet, "optim.batch": 3})
    maps, _, crop = draw_materials(cfg, torch.Generator().manual_seed(8))
    assert crop and maps.shape[-1] == 64
    crops, cmaps, draws = simulate_photos_batched(maps, cfg, torch.Generator().manual_seed(9), crop=32)
    whole, _, wdraws = simulate_photos_batched(maps, cfg, torch.Generator().manual_seed(9))
    assert crops.shape == (3, 3, 32, 32) and cmaps.shape == (3, 8, 32, 32) and draws == wdraws
    assert any(d["camera"]["vignetting"] > 0 for d in draws)
    for i in range(3):  # where the window is: the maps are gathered exactly
        hits = [(y, x) for y in range(33) for x in range(33) if torch.equal(maps[i, :, y:y + 32, x:x + 32], cmaps[i])]
        assert len(hits) == 1
        y, x = hits[0]
        ref = whole[i, :, y:y + 32, x:x + 32]
        assert (crops[i] - ref).abs().max() < 1e-2 and (crops[i] - ref).abs().mean() < 1e-4  # (8-bit rounding)


def test_a_roll_off_range_is_drawn_per_photo_alike_in_both_streams_and_none_leaves_the_stream_as_it_was(tiny_v2):
    """``photos.camera["white"]`` (the highlight roll-off): left out or (1, 1), nothing is drawn for it (a run's stream as
    before it existed); a range draws it last per photo, the same in the photo-by-photo and the batched stream."""
    from svbrdf.trainer.prior import draw_materials, simulate_photos, simulate_photos_batched

    old = prior_preset("v2").to_dict()
    old["photos"]["camera"].pop("white")
    assert PriorConfig.from_dict(old).photos.camera["white"] == (1.0, 1.0)  # a checkpoint from before
    assert PriorConfig.from_dict({"camera": old["photos"]["camera"]}).photos.camera["white"] == (1.0, 1.0)  # flat
    quiet = {k: (v if k in ("ev", "vignetting") else (0.0, 0.0)) for k, v in prior_preset("v2").photos.camera.items()}
    lin = tiny_v2({"photos.crop_share": 0.0, "photos.camera": {**quiet, "white": (1.0, 1.0)}, "optim.batch": 3})
    rolled = override(lin, {"photos.camera": {**quiet, "white": (2.0, 4.0)}})
    maps, _, _ = draw_materials(lin, torch.Generator().manual_seed(3))
    maps = maps.clone()
    maps[:, 0:3] = 1.0  # a bright white material under the flash: the centre clips
    a, _, da = simulate_photos_batched(maps, lin, torch.Generator().manual_seed(5))
    b, _, db = simulate_photos_batched(maps, rolled, torch.Generator().manual_seed(5))
    _, _, d1 = simulate_photos_batched(maps[:1], rolled, torch.Generator().manual_seed(5))
    s, _, ds = simulate_photos(maps[:1], rolled, torch.Generator().manual_seed(5))  # (its later draws interleave)
    assert [d["camera"]["white"] for d in da] == [1.0] * 3
    assert all(2.0 <= d["camera"]["white"] <= 4.0 for d in db) and d1 == ds
    assert da[0]["camera"]["ev"] == db[0]["camera"]["ev"]  # white is drawn after the others
    assert float((a >= 1.0).float().mean()) > float((b >= 1.0).float().mean())  # fewer clipped pixels
    s_lin, _, _ = simulate_photos(maps[:1], lin, torch.Generator().manual_seed(5))
    assert float((s_lin >= 1.0).float().mean()) > float((s >= 1.0).float().mean())  # the numpy camera's roll-off
    with pytest.raises(ValueError):
        tiny_v2({"photos.camera": {**quiet, "white": (0.5, 2.0)}})


def test_flat_share_makes_the_chosen_materials_flat_and_none_leaves_the_stream_as_it_was(tiny_v2):
    """``materials.flat_share`` (materials without relief): the chosen materials' normals are (0, 0, 1), everything else of
    theirs and the other materials as drawn; at 0 nothing is drawn for it; the validation batch never has them."""
    from svbrdf.trainer.prior import draw_materials, flatten_normals

    cfg = tiny_v2({"photos.crop_share": 0.0, "optim.batch": 12})
    flat = override(cfg, {"materials.flat_share": 0.5})
    a, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    g = torch.Generator().manual_seed(7)
    b, _, _ = draw_materials(flat, g)
    after_flat = torch.rand(3, generator=g)
    g0 = torch.Generator().manual_seed(7)
    draw_materials(cfg, g0)
    torch.rand(12, generator=g0)  # the flat share's one draw per material, made after the materials
    assert torch.equal(after_flat, torch.rand(3, generator=g0))
    sl = SLICES["normal"]
    up = torch.tensor([0.0, 0.0, 1.0])[None, :, None, None]
    is_flat = (b[:, sl] == up).flatten(1).all(1)
    was_flat = (a[:, sl] == up).flatten(1).all(1)
    assert not was_flat.any() and 0 < int(is_flat.sum()) < 12  # seed 7: some of the 12, not all
    assert torch.equal(b[~is_flat], a[~is_flat]) and torch.equal(b[:, :sl.start], a[:, :sl.start])
    a2, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    assert torch.equal(a, a2)  # share 0: the stream of a run before it existed
    chosen = torch.tensor([True, False] * 6)
    c = flatten_normals(a, chosen)
    assert (c[chosen][:, sl] == up).all() and torch.equal(c[~chosen], a[~chosen])
    assert flatten_normals(a, torch.zeros(12, dtype=torch.bool)) is a
    _assert_the_validation_batch_ignores(cfg, "materials.flat_share")
    with pytest.raises(ValueError):
        tiny_v2({"materials.flat_share": 1.0})


def test_coarse_share_adds_a_smooth_relief_to_the_chosen_materials_and_none_leaves_the_stream_as_it_was(tiny_v2):
    """``materials.coarse_share`` (a coarse relief on top of a material's own): the chosen materials' normals change and get
    a coarse band (their slopes blurred keep more of their variance than before, on average), every other channel and material
    as drawn; at 0 nothing is drawn for it; the validation batch never has them."""
    from svbrdf.trainer.bench.metrics import gaussian_blur
    from svbrdf.trainer.prior import add_coarse_relief, draw_materials
    from svbrdf.trainer.procedural import PARAMS

    cfg = tiny_v2({"photos.crop_share": 0.0, "optim.batch": 12, "photos.size": 64})
    a, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    b, _, _ = draw_materials(override(cfg, {"materials.coarse_share": 0.5}), torch.Generator().manual_seed(7))
    sl = SLICES["normal"]
    changed = (b[:, sl] != a[:, sl]).flatten(1).any(1)
    assert 0 < int(changed.sum()) < 12  # seed 7: some of the 12, not all
    assert torch.equal(b[~changed], a[~changed]) and torch.equal(b[:, :sl.start], a[:, :sl.start])
    assert torch.allclose(b[:, sl].norm(dim=1), torch.ones(()), atol=1e-5) and bool((b[:, sl][:, 2] > 0).all())

    def coarse_fraction(n):  # share of the slope variance left after a blur of sigma 4 px
        s = (-n[:2] / n[2:]).double().numpy()
        s = s - s.mean(axis=(1, 2), keepdims=True)
        return sum(float(np.var(gaussian_blur(c, 4.0))) for c in s) / sum(float(np.var(c)) for c in s)

    rise = [coarse_fraction(b[i, sl]) - coarse_fraction(a[i, sl]) for i in torch.nonzero(changed).flatten().tolist()]
    assert float(np.mean(rise)) > 0.05 and min(rise) > -0.01
    # the added relief alone (on flat normals) has a mean tilt within the drawn range
    flat = a.clone()
    flat[:, sl] = torch.tensor([0.0, 0.0, 1.0])[None, :, None, None]
    c = add_coarse_relief(flat, torch.ones(12, dtype=torch.bool), torch.Generator().manual_seed(3))
    tilt = torch.rad2deg(torch.acos(c[:, sl][:, 2].clamp(-1, 1))).flatten(1).mean(1)
    lo, hi = PARAMS["coarse_tilt_deg"]
    assert bool((tilt > 0.5 * lo).all()) and bool((tilt < 1.5 * hi).all())
    assert add_coarse_relief(a, torch.zeros(12, dtype=torch.bool), torch.Generator()) is a
    g, g0 = torch.Generator().manual_seed(7), torch.Generator().manual_seed(7)
    draw_materials(override(cfg, {"materials.coarse_share": 0.0}), g)
    draw_materials(cfg, g0)
    assert torch.equal(torch.rand(3, generator=g), torch.rand(3, generator=g0))  # share 0: no draw
    _assert_the_validation_batch_ignores(cfg, "materials.coarse_share")
    with pytest.raises(ValueError):
        tiny_v2({"materials.coarse_share": 1.5})


def test_black_share_darkens_chosen_dielectrics_only_and_none_leaves_the_stream_as_it_was(tiny_v2):
    """``materials.black_share`` (near-black dielectrics): a chosen dielectric's base colour is scaled to a mean within
    :data:`BLACK_LEVEL`, its other maps and every other material as drawn, a metal never; at 0 nothing is drawn
    for it; the validation batch never has them."""
    from svbrdf.trainer.prior import BLACK_LEVEL, blacken_dielectrics, draw_materials

    cfg = tiny_v2({"photos.crop_share": 0.0, "optim.batch": 12})
    a, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    g = torch.Generator().manual_seed(7)
    b, _, _ = draw_materials(override(cfg, {"materials.black_share": 0.5}), g)
    after = torch.rand(3, generator=g)
    g0 = torch.Generator().manual_seed(7)
    draw_materials(cfg, g0)
    torch.rand(12, generator=g0), torch.rand(12, generator=g0)  # the choice and the level, after the materials
    assert torch.equal(after, torch.rand(3, generator=g0))
    d = SLICES["diffuse"]
    changed = ~(b[:, d] == a[:, d]).flatten(1).all(1)
    assert 0 < int(changed.sum()) < 12  # seed 7: some of the 12
    assert torch.equal(b[:, d.stop:], a[:, d.stop:]) and torch.equal(b[~changed], a[~changed])
    means = b[changed][:, d].mean((1, 2, 3))
    assert (means <= BLACK_LEVEL[1] * 1.0001).all()
    a2, _, _ = draw_materials(cfg, torch.Generator().manual_seed(7))
    assert torch.equal(a, a2)  # share 0: the stream of a run before it existed
    metal = a.clone()
    metal[:, SLICES["specular"]] = 0.8  # every material a metal: none is darkened
    every = torch.ones(12, dtype=torch.bool)
    assert torch.equal(blacken_dielectrics(metal, every, torch.full((12,), 0.001)), metal)
    dielectric = a.clone()
    dielectric[:, SLICES["specular"]] = 0.04
    dark = blacken_dielectrics(dielectric, every, torch.full((12,), 0.005))
    torch.testing.assert_close(dark[:, d].mean((1, 2, 3)),
                               torch.minimum(torch.full((12,), 0.005), dielectric[:, d].mean((1, 2, 3))))
    assert blacken_dielectrics(a, torch.zeros(12, dtype=torch.bool), torch.ones(12)) is a
    _assert_the_validation_batch_ignores(cfg, "materials.black_share")
    with pytest.raises(ValueError):
        tiny_v2({"materials.black_share": 1.0})


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_cuda_stream_stays_on_the_device_and_trains(tiny_v2):
    cfg = tiny_v2({"optim.bf16": True})
    rng = torch.Generator().manual_seed(0)
    sample_batch(cfg, rng, device="cuda")
    torch.cuda.set_sync_debug_mode("error")  # any read-back from the GPU raises
    try:
        photos, maps, _ = sample_batch(cfg, rng, device="cuda")
    finally:
        torch.cuda.set_sync_debug_mode("default")
    assert photos.is_cuda and maps.is_cuda
    cpu_maps, _ = sample_materials(2, 64, torch.Generator().manual_seed(5))
    gpu_maps, _ = sample_materials(2, 64, torch.Generator().manual_seed(5), device="cuda")
    torch.testing.assert_close(gpu_maps.cpu(), cpu_maps, atol=1e-3, rtol=0)  # one stream on every device
    trainer = PriorTrainer(cfg, device="cuda")
    trainer.run()
    assert trainer.step == cfg.optim.iters and trainer.bf16


@pytest.mark.integration
def test_the_v2_batch_and_loss_never_make_a_gpu_wait(meta_training_steps):
    # The GPU chunks counted 73 host synchronisations per batch (git show bc3896e:./docs/benchmarks/prior-v2/README.md):
    # each one stops the host until the GPU has run everything queued, so the batch cannot be built while the network
    # trains. Checked on the CPU by taking training steps on the meta device.
    infos = meta_training_steps(override(prior_preset("v2"), {"materials.flat_share": 0.5}))  # flat too
    assert {i["crop"] for i in infos} == {True, False}  # crops of larger photos and whole photos


def test_the_host_read_probe_sees_what_it_looks_for(host_reads):
    x = torch.zeros(4, 4, device="meta")
    with host_reads() as probe:
        x.sum().item()
        x[0, 0] = 1.0
        x.nonzero()
        torch.ones(2).to("meta")
        to_device(torch.ones(2), "meta")
    assert [f.split(" at ")[0] for f in probe.found] == [
        "_local_scalar_dense", "a Python scalar written into a device tensor", "nonzero",
        "a host-to-device copy outside to_device"], probe.found
