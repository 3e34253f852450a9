import pytest
import torch
import torch.nn.functional as F

from svbrdf.runtime.core.maps import MAP_NAMES, N_CHANNELS, SLICES
from svbrdf.trainer.models import (
    ARCHS, DISC_PRESETS, GENERATORS, MODEL_PRESETS, Discriminator, DiscriminatorConfig, Features, Generator,
    GeneratorConfig, UNetGenerator, WenGenerator, count_parameters, create_generator, flash_cue, height_to_normal,
    linearise_height, pack_maps,
)


def _conv(cin, cout, k):
    return cin * cout * k * k


def _inorm(c):
    return 2 * c


@pytest.fixture(scope="module")
def tiny():
    torch.manual_seed(0)
    return Generator(MODEL_PRESETS["tiny"]).eval()


# ---- one class per architecture behind one factory ----

def test_every_architecture_has_its_class_behind_the_factory():
    assert set(GENERATORS) == set(ARCHS) and GENERATORS["wen"] is WenGenerator and GENERATORS["unet"] is UNetGenerator
    for arch, cls in GENERATORS.items():
        cfg = GeneratorConfig(width=0.125, decoder_blocks=3, arch=arch)
        for g in (Generator(cfg), create_generator(**cfg.to_dict())):
            assert type(g) is cls and isinstance(g, Generator) and g.arch == arch and g.cfg == cfg
    assert type(Generator()) is WenGenerator and type(create_generator(width=0.125)) is WenGenerator
    with pytest.raises(ValueError, match="arch"):
        create_generator("resnet")
    with pytest.raises(ValueError, match="unknown GeneratorConfig keys"):
        create_generator("unet", depth=3)
    with pytest.raises(ValueError, match="implements arch='wen'"):
        WenGenerator(GeneratorConfig(arch="unet"))


@pytest.mark.parametrize("arch", ARCHS)
def test_every_architecture_keeps_one_contract(arch):
    with torch.random.fork_rng():
        torch.manual_seed(0)
        g = create_generator(arch, width=0.125, decoder_blocks=3).eval()
    x = torch.rand(2, 3, 37, 50)
    with torch.no_grad():
        feats = g.forward_features(x)
        assert isinstance(feats, Features) and feats.size == (40, 56) and feats.context is None
        padded = g.decode(feats)
        assert all(m.shape[-2:] == (40, 56) for m in padded.values())
        pre = g.decoder_outputs("decoder_ds", feats)
        assert pre.shape == (2, 4, 40, 56)
        torch.testing.assert_close(padded["specular"], torch.tanh(pre[:, 3:4] + g.out_offset[5]) * 0.5 + 0.5)
        torch.testing.assert_close(pack_maps(g.decode(feats, size=(37, 50))), g(x))
    # the same parameter names, and in the same order (the optimisers' states follow it), for every architecture
    order = [n.split(".")[0] for n, _ in g.named_parameters()]
    assert sorted(set(order), key=order.index) == ["out_offset", "encoder", "decoder_nr", "decoder_ds"]
    assert [n for n, _ in g.named_children()] == ["encoder", "decoder_nr", "decoder_ds"]
    assert g.takes_context == (arch == "unet")


# ---- parameter counts against the published layer tables (peers.md 1.2, 1.5) ----

def test_paper_parameter_counts():
    g = Generator(MODEL_PRESETS["paper"])
    d = Discriminator(DISC_PRESETS["paper"])
    enc = _conv(3, 9, 5) + _conv(9, 64, 3) + _conv(64, 128, 3) + _conv(128, 256, 3) + _inorm(64 + 128 + 256)
    dec = (_conv(256, 512, 3) + _conv(512, 256, 4) + _conv(256, 256, 4) + _conv(256, 64, 4) + _conv(64, 64, 4)
           + _inorm(512 + 256 + 64))
    disc = (_conv(3, 64, 4) + _conv(64, 128, 4) + _conv(128, 256, 4) + _conv(256, 512, 4) + _conv(512, 1, 4)
            + _inorm(128 + 256 + 512))
    assert count_parameters(g.encoder) == enc
    assert count_parameters(g.decoder_nr) == dec + _conv(64, 2, 3)
    assert count_parameters(g.decoder_ds) == dec + _conv(64, 4, 3)
    assert count_parameters(d) == disc
    # the rounded figures quoted in peers.md (encoder 0.37 M is 0.375 M truncated)
    assert count_parameters(g.encoder) == pytest.approx(0.375e6, rel=0.01)
    assert count_parameters(g.decoder_nr) == pytest.approx(4.65e6, rel=0.01)
    assert count_parameters(g.decoder_ds) == pytest.approx(4.65e6, rel=0.01)
    assert count_parameters(d) == pytest.approx(2.76e6, rel=0.01)


def test_frozen_encoder_flag():
    g = Generator(MODEL_PRESETS["tiny"])
    assert not any(p.requires_grad for p in g.encoder.parameters())
    assert count_parameters(g, trainable_only=True) == count_parameters(g) - count_parameters(g.encoder)
    g2 = Generator(GeneratorConfig(width=0.125, train_encoder=True))
    assert all(p.requires_grad for p in g2.encoder.parameters())


def test_presets_and_config_round_trip():
    assert MODEL_PRESETS["paper"].width == 1.0 and DISC_PRESETS["paper"].width == 1.0
    assert count_parameters(Generator(MODEL_PRESETS["fast"])) < count_parameters(Generator(MODEL_PRESETS["paper"]))
    cfg = GeneratorConfig(width=0.5, height_scale=16.0, train_encoder=True)
    assert GeneratorConfig.from_dict(cfg.to_dict()) == cfg
    dcfg = DiscriminatorConfig(width=0.5, n_layers=3)
    assert DiscriminatorConfig.from_dict(dcfg.to_dict()) == dcfg
    with pytest.raises(ValueError, match="unknown"):
        GeneratorConfig.from_dict({"width": 1.0, "depth": 3})
    with pytest.raises(ValueError):
        GeneratorConfig(width=0)
    with pytest.raises(ValueError):
        DiscriminatorConfig(n_layers=0)


# ---- TF SAME padding parity (peers.md 6, item 2) ----

def test_stride2_conv_pads_bottom_right_only():
    g = Generator(MODEL_PRESETS["tiny"])
    block = g.encoder[2]  # e3: lrelu -> conv3/2 -> IN
    conv = [m for m in block if isinstance(m, torch.nn.Conv2d)][0]
    x = torch.randn(1, conv.in_channels, 12, 10)
    a = F.leaky_relu(x, 0.2)
    out = block[:-1](x)  # without the norm
    assert out.shape == (1, conv.out_channels, 6, 5)
    torch.testing.assert_close(out, F.conv2d(F.pad(a, (0, 1, 0, 1)), conv.weight, stride=2))
    assert not torch.allclose(out, F.conv2d(F.pad(a, (1, 0, 1, 0)), conv.weight, stride=2))  # the side matters


def test_k4_stride1_conv_pads_one_before_two_after():
    g = Generator(MODEL_PRESETS["tiny"])
    block = g.decoder_nr[1][2]  # first 4x4 conv of the first upsampling block
    conv = [m for m in block if isinstance(m, torch.nn.Conv2d)][0]
    x = torch.randn(1, conv.in_channels, 8, 6)
    torch.testing.assert_close(block(x), F.conv2d(F.pad(x, (1, 2, 1, 2)), conv.weight))


# ---- generator outputs ----

@pytest.mark.parametrize("hw", [(32, 32), (33, 45), (17, 64), (8, 8)])
def test_output_size_and_ranges(tiny, hw):
    x = torch.rand(2, 3, *hw)
    with torch.no_grad():
        y = tiny(x)
    assert y.shape == (2, N_CHANNELS, *hw) and y.dtype == torch.float32
    for name in ("diffuse", "specular", "roughness"):
        m = y[:, SLICES[name]]
        assert m.min() >= 0 and m.max() <= 1
    n = y[:, SLICES["normal"]]
    torch.testing.assert_close(n.norm(dim=1), torch.ones(2, *hw))
    assert (n[:, 2] > 0).all()


@pytest.mark.parametrize("blocks", [1, 3])
def test_other_depths_keep_the_size(blocks):
    g = Generator(GeneratorConfig(width=0.125, decoder_blocks=blocks))
    with torch.no_grad():
        assert g(torch.rand(1, 3, 19, 26)).shape == (1, 8, 19, 26)


def test_odd_size_is_replicate_pad_then_crop(tiny):
    x = torch.rand(1, 3, 33, 45)
    xp = F.pad(x, (0, 3, 0, 3), mode="replicate")  # next multiple of 4: 36 x 48
    with torch.no_grad():
        y, yp = tiny(x), tiny(xp)[..., :33, :45]
    for name in ("diffuse", "specular", "roughness"):
        torch.testing.assert_close(y[:, SLICES[name]], yp[:, SLICES[name]])
    # the normal is computed after cropping: equal except on the last row/column (zero difference there)
    n, npad = y[:, SLICES["normal"]], yp[:, SLICES["normal"]]
    torch.testing.assert_close(n[..., :-1, :-1], npad[..., :-1, :-1])
    torch.testing.assert_close(n[:, :, -1, -1], torch.tensor([[0.0, 0.0, 1.0]]))


def test_decode_subsets_run_only_the_needed_decoder(tiny):
    x = torch.rand(1, 3, 24, 20)
    calls = []
    hooks = [getattr(tiny, n).register_forward_hook(lambda m, i, o, n=n: calls.append(n))
             for n in ("decoder_nr", "decoder_ds")]
    try:
        with torch.no_grad():
            full = tiny(x)
            latent = tiny.forward_features(x)
            calls.clear()
            nr = tiny.decode(latent, maps=("normal",))
            assert calls == ["decoder_nr"] and list(nr) == ["normal"]
            calls.clear()
            ds = tiny.decode(latent, maps=("specular", "diffuse"))
            assert calls == ["decoder_ds"] and list(ds) == ["diffuse", "specular"]
    finally:
        for h in hooks:
            h.remove()
    torch.testing.assert_close(nr["normal"], full[:, SLICES["normal"]])
    torch.testing.assert_close(ds["diffuse"], full[:, SLICES["diffuse"]])
    torch.testing.assert_close(pack_maps(tiny.decode(latent)), full)
    with pytest.raises(ValueError, match="unknown maps"):
        tiny.decode(latent, maps=("albedo",))
    with pytest.raises(ValueError, match="missing"):
        pack_maps(nr)


def test_bad_input_shape(tiny):
    with pytest.raises(ValueError, match=r"\(B, 3, H, W\)"):
        tiny(torch.rand(1, 4, 16, 16))


def test_bf16_autocast_outputs_float32(tiny):
    with torch.no_grad(), torch.autocast("cpu", dtype=torch.bfloat16):
        y = tiny(torch.rand(1, 3, 32, 32))
    assert y.dtype == torch.float32 and torch.isfinite(y).all()


def test_gradients_reach_both_decoders_not_the_frozen_encoder():
    g = Generator(MODEL_PRESETS["tiny"])
    g(torch.rand(1, 3, 16, 16)).square().mean().backward()
    assert all(p.grad is None for p in g.encoder.parameters())
    for dec in (g.decoder_nr, g.decoder_ds):
        assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in dec.parameters())


# ---- normal from height ----

def test_height_ramp_to_the_right_tilts_normal_to_minus_x():
    h = torch.linspace(0, 1, 9).expand(1, 1, 5, 9).contiguous()  # slope 1/8 per column
    n = height_to_normal(h, 32.0)
    expected = torch.tensor([-4.0, 0.0, 1.0]) / 17 ** 0.5  # (-32 * 1/8, 0, 1) normalised
    torch.testing.assert_close(n[0, :, 2, 3], expected)
    torch.testing.assert_close(n[0, :, :, -1], torch.tensor([0.0, 0.0, 1.0])[:, None].expand(3, 5))  # last column


def test_height_ramp_down_the_image_tilts_normal_up_the_image():
    h = torch.linspace(0, 1, 9)[:, None].expand(1, 1, 9, 5).contiguous()  # rises towards larger row index
    n = height_to_normal(h, 32.0)
    expected = torch.tensor([0.0, 4.0, 1.0]) / 17 ** 0.5  # OpenGL +y = up the image
    torch.testing.assert_close(n[0, :, 3, 2], expected)
    torch.testing.assert_close(n[0, :, -1, :], torch.tensor([0.0, 0.0, 1.0])[:, None].expand(3, 5))  # last row


def test_height_scale_is_used():
    h = torch.linspace(0, 1, 9).expand(1, 1, 4, 9).contiguous()
    n = height_to_normal(h, 8.0)
    torch.testing.assert_close(n[0, :, 0, 0], torch.tensor([-1.0, 0.0, 1.0]) / 2 ** 0.5)


# ---- discriminator ----

@pytest.mark.parametrize("size,out", [(256, 16), (64, 4)])
def test_discriminator_patch_shape(size, out):
    d = Discriminator(DISC_PRESETS["tiny"])
    assert d(torch.rand(2, 3, size, size)).shape == (2, 1, out, out)


def test_discriminator_first_layer_has_no_norm_and_no_activation():
    d = Discriminator(DISC_PRESETS["tiny"])
    first = list(d.net[0])
    assert [type(m) for m in first] == [torch.nn.Conv2d]
    assert all(m.bias is None for m in d.modules() if isinstance(m, torch.nn.Conv2d))


def test_map_names_are_the_project_layout(tiny):
    with torch.no_grad():
        maps = tiny.decode(tiny.forward_features(torch.rand(1, 3, 16, 16)))
    assert tuple(maps) == MAP_NAMES


@pytest.mark.parametrize("cin,cout,h,w", [(8, 4, 5, 7), (3, 6, 1, 2), (16, 16, 8, 8)])
def test_fused_upsample_conv_is_upsample_then_conv(cin, cout, h, w):
    """The up-blocks' fused nearest-x2 + 4x4 TF-SAME convolution equals the two unfused layers (and grads)."""
    from svbrdf.trainer.models import _up_block, upsample_conv4

    torch.manual_seed(0)
    block = _up_block(cin, cout).double()
    x = torch.randn(2, cin, h, w, dtype=torch.float64, requires_grad=True)
    act, upsample, first, second = block
    want = second(first(upsample(act(x))))
    got = block(x)
    assert got.shape == (2, cout, 2 * h, 2 * w)
    torch.testing.assert_close(got, want, rtol=0, atol=1e-12)
    g_want = torch.autograd.grad(want.square().sum(), [x, first[1].weight])
    g_got = torch.autograd.grad(got.square().sum(), [x, first[1].weight])
    for a, b in zip(g_got, g_want):
        torch.testing.assert_close(a, b, rtol=0, atol=1e-10)
    # a wrong tap table (e.g. the odd phase shifted) must not pass
    weight = first[1].weight.detach()
    plain = first(upsample(act(x.detach())))
    assert (upsample_conv4(act(x.detach()), weight.flip(-1)) - plain).abs().max() > 1e-3


# ------------------------------------------------------------------------------------- the U-Net candidate (issue 26)

def _unet(**kw):
    with torch.random.fork_rng():  # seeded weights without resetting the RNG of the tests that follow
        torch.manual_seed(0)
        return Generator(GeneratorConfig(**{**dict(width=0.125, decoder_blocks=3, arch="unet"), **kw})).eval()


def test_unet_keeps_the_contract_of_the_published_generator():
    g = _unet()
    x = torch.rand(2, 3, 37, 50)
    y = g(x)
    assert y.shape == (2, N_CHANNELS, 37, 50) and torch.isfinite(y).all()
    assert torch.allclose(y[:, SLICES["normal"]].norm(dim=1), torch.ones(2, 37, 50), atol=1e-5)
    lat = g.forward_features(x)
    part = g.decode(lat, ["normal"], size=(37, 50))
    assert list(part) == ["normal"] and torch.equal(part["normal"], y[:, SLICES["normal"]])
    assert {n for n, _ in g.named_children()} >= {"encoder", "decoder_nr", "decoder_ds"}
    assert GeneratorConfig.from_dict(g.cfg.to_dict()) == g.cfg
    with pytest.raises(ValueError, match="arch"):
        GeneratorConfig(arch="resnet")


def test_unet_sees_the_photo_level_and_colour():
    x = torch.rand(1, 3, 32, 32) * 0.5
    tinted = x * torch.tensor([1.0, 0.5, 0.25]).view(1, 3, 1, 1)
    g = _unet()
    with torch.no_grad():
        base = g(x)[:, SLICES["diffuse"]]
        assert (g(2.0 * x)[:, SLICES["diffuse"]] - base).abs().mean() > 1e-3  # a global gain reaches the output
        assert (g(tinted)[:, SLICES["diffuse"]] - base).abs().mean() > 1e-3  # and so does a tint


def test_flash_cue_finds_the_highlight():
    x = torch.full((1, 3, 40, 40), 0.1)
    x[..., 5:8, 30:33] = 1.0  # a clipped highlight up and to the right
    offset, centre = flash_cue(x)
    assert centre[0, 0] > 0.5 and centre[0, 1] > 0.5
    assert offset.shape == (1, 2, 40, 40)
    assert offset[0, :, 6, 31].abs().max() < 0.05  # about zero on the highlight


def test_flash_cue_of_a_tile_in_the_photo_frame_equals_the_crop_of_the_whole():
    x = torch.rand(2, 3, 40, 56)
    offset, centre = flash_cue(x)
    part, c2 = flash_cue(x[..., 8:32, 16:48], centre, torch.tensor([8, 16]), (40, 56))
    torch.testing.assert_close(part, offset[..., 8:32, 16:48])
    torch.testing.assert_close(c2, centre)
    alone, _ = flash_cue(x[..., 8:32, 16:48])  # the tile's own frame: other offsets
    assert (alone - offset[..., 8:32, 16:48]).abs().max() > 0.1


def test_a_tile_with_the_photo_context_gets_the_whole_photo_maps_away_from_its_border():
    g = _unet()
    x = torch.rand(1, 3, 128, 128)
    x[..., 20:26, 90:96] = 1.0  # a highlight outside the tile
    with torch.no_grad():
        whole = g(x)
        ctx = g.photo_context(x)
        torch.testing.assert_close(g(x, ctx, torch.tensor([0, 0])), whole)  # the whole photo: the same maps
        tile = x[..., 32:96, 32:96]
        inside = (slice(None), slice(None), slice(24, -24), slice(24, -24))
        with_ctx = (g(tile, ctx, torch.tensor([32, 32])) - whole[..., 32:96, 32:96])[inside].abs().max()
        alone = (g(tile) - whole[..., 32:96, 32:96])[inside].abs().max()
    assert with_ctx < 1e-4 < 1e-2 < alone


def test_the_photo_context_is_a_unet_thing():
    g = Generator(GeneratorConfig(width=0.125))
    with pytest.raises(ValueError, match="unet"):
        g.photo_context(torch.rand(1, 3, 16, 16))
    x = torch.rand(1, 3, 16, 16)
    with torch.no_grad():  # a "wen" generator ignores a context argument
        torch.testing.assert_close(g(x, None, torch.tensor([4, 4])), g(x))


def test_unet_gradients_reach_every_trainable_part_and_the_encoder_can_be_frozen():
    g = _unet(train_encoder=False).train()
    g(torch.rand(1, 3, 32, 32)).sum().backward()
    assert all(p.grad is None for p in g.encoder.parameters())
    for name in ("decoder_nr", "decoder_ds"):
        assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in getattr(g, name).parameters())


# --------------------------------------------------------------------------- the height's activation (stage one v2)

def _height_grad(g, photo):
    """Norm of the normals' gradient on the height channel's last convolution."""
    g.zero_grad(set_to_none=True)
    n = g(photo)[:, SLICES["normal"]]
    (n[:, :2] ** 2).sum().backward()
    return float(g.decoder_nr.out.weight.grad[0].norm())


def test_a_linear_height_keeps_the_normals_gradient_where_a_tanh_height_saturates():
    photo = torch.rand(1, 3, 32, 32)
    grads = {}
    for act in ("tanh", "linear"):
        g = _unet(height_activation=act).train()
        with torch.no_grad():
            g.out_offset[0] = -4.0  # deep in the tanh's tail, where both stage ones' heights ended
        grads[act] = _height_grad(g, photo)
    assert grads["linear"] > 0
    assert grads["tanh"] < 0.01 * grads["linear"]  # sech(4)**2 ~ 1.3e-3 of the gradient survives the tanh


def test_the_linear_height_has_the_tanh_heights_slope_at_zero_and_no_bound():
    photo = torch.rand(1, 3, 32, 32)
    a, b = _unet(), _unet(height_activation="linear")
    with torch.no_grad():
        for g in (a, b):
            g.decoder_nr.out.weight.mul_(1e-3)  # pre-activation heights near 0
            g.decoder_nr.out.bias.zero_()
        na, nb = a(photo)[:, SLICES["normal"]], b(photo)[:, SLICES["normal"]]
        torch.testing.assert_close(na, nb, atol=1e-5, rtol=0)
        rest = [s for n, s in SLICES.items() if n != "normal"]
        for s in rest:
            torch.testing.assert_close(a(photo)[:, s], b(photo)[:, s], atol=0, rtol=0)
        b.out_offset[0] = 50.0  # a tanh would be a constant 1 here; the linear height only shifts
        torch.testing.assert_close(b(photo)[:, SLICES["normal"]], nb, atol=1e-4, rtol=0)


def test_linearise_height_keeps_a_saturated_models_normals_and_records_the_switch():
    photo = torch.rand(2, 3, 32, 32)
    g = _unet()
    with torch.no_grad():
        g.decoder_nr.out.weight[0].mul_(0.05)  # small variation of the height around a saturated level
        g.decoder_nr.out.bias[0] = 0.0
        g.out_offset[0] = -2.5
        before = g(photo)
    k = linearise_height(g, photo)
    assert g.cfg.height_activation == "linear"
    assert 0.02 < k < 0.05  # sech(2.5)**2 = 0.027 around the level
    with torch.no_grad():
        after = g(photo)
    assert float(before[:, SLICES["normal"]][:, :2].abs().max()) > 1e-4  # the check sees tilted normals
    torch.testing.assert_close(after[:, SLICES["normal"]], before[:, SLICES["normal"]], atol=2e-4, rtol=0.05)
    other = [c for c in range(N_CHANNELS) if c not in range(*SLICES["normal"].indices(N_CHANNELS))]
    torch.testing.assert_close(after[:, other], before[:, other], atol=0, rtol=0)
    with pytest.raises(ValueError, match="already"):
        linearise_height(g, photo)


def test_height_activation_is_validated_and_old_configs_read_as_tanh():
    with pytest.raises(ValueError, match="height_activation"):
        GeneratorConfig(height_activation="relu")
    d = GeneratorConfig(arch="unet").to_dict()
    del d["height_activation"]
    assert GeneratorConfig.from_dict(d).height_activation == "tanh"


def test_the_unet_output_conv_stays_float32_under_bf16_autocast():
    # a linear height's normals are 16x the differences of neighbouring outputs: bf16 would round them to degrees
    g = _unet(height_activation="linear")
    x = torch.rand(1, 3, 32, 32)
    with torch.no_grad(), torch.autocast("cpu", dtype=torch.bfloat16):
        latent = g.forward_features(x)
        feats = g.decoder_nr._levels(latent.encoded)
        y = g.decoder_nr(latent.encoded)
    assert feats.dtype == torch.bfloat16 and y.dtype == torch.float32
    want = F.conv2d(feats.float(), g.decoder_nr.out.weight, g.decoder_nr.out.bias)
    torch.testing.assert_close(y, want, atol=1e-6, rtol=1e-6)
