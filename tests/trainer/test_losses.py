import math

import numpy as np
import pytest
import torch

from svbrdf.runtime.core.maps import SLICES
from svbrdf.trainer.colour import linear_to_srgb
from svbrdf.trainer.losses import (
    CLIP_LEVEL,
    clipped_fraction,
    diffuse_loss, flash_basis, flash_correlation_loss, flash_maps, fourier_loss,
    gan_discriminator_loss,
    gan_generator_loss, guessed_diffuse, maps_for_loss, render_loss,
)
from svbrdf.trainer.models import DISC_PRESETS, MODEL_PRESETS, Discriminator, Generator
from svbrdf.trainer.perceptual import PerceptualLoss
from svbrdf.trainer.render import FlashGeometry


# ---- guessed diffuse ----

def _guess_reference(img, k, sigma, eps, mode):
    """Zhao's recipe with plain loops, float64; img (C, H, W)."""
    r = k // 2
    ax = np.arange(k) - r
    kern = np.exp(-(ax[:, None] ** 2 + ax[None, :] ** 2) / (2 * sigma ** 2))
    kern /= kern.sum()
    c, h, w = img.shape

    def blur(ch):
        p = np.pad(ch, r, mode="constant" if mode == "zeros" else "reflect")
        out = np.zeros_like(ch)
        for i in range(h):
            for j in range(w):
                out[i, j] = sum(kern[a, b] * p[i + a, j + b] for a in range(k) for b in range(k))
        return out

    res = np.zeros_like(img)
    for ci in range(c):
        m = blur(img[ci])
        s = np.sqrt(blur((img[ci] - m) ** 2))
        z = (img[ci] - m) / (s + eps)
        res[ci] = (z - z.min()) / (z.max() - z.min() + eps)
    return res


@pytest.mark.parametrize("padding", ["zeros", "reflect"])
def test_guessed_diffuse_matches_hand_computation(padding):
    rng = np.random.default_rng(3)
    img = rng.random((3, 7, 7))
    ref = _guess_reference(img, 5, 2.0, 1e-4, padding)
    out = guessed_diffuse(torch.from_numpy(img)[None], kernel_size=5, sigma=2.0, padding=padding)
    assert out.dtype == torch.float64
    np.testing.assert_allclose(out[0].numpy(), ref, atol=1e-10)
    out32 = guessed_diffuse(torch.from_numpy(img).float()[None], kernel_size=5, sigma=2.0, padding=padding)
    np.testing.assert_allclose(out32[0].numpy(), ref, atol=1e-6)


def test_guessed_diffuse_non_square_float32():
    rng = np.random.default_rng(4)
    img = rng.random((3, 6, 9))
    ref = _guess_reference(img, 3, 1.5, 1e-4, "zeros")
    out = guessed_diffuse(torch.from_numpy(img).float()[None], kernel_size=3, sigma=1.5)
    np.testing.assert_allclose(out[0].numpy(), ref, atol=2e-5)


@pytest.mark.parametrize("padding", ["zeros", "reflect"])
@pytest.mark.parametrize("value", [0.0, 0.4, 1.0])
def test_guessed_diffuse_constant_image_is_finite(value, padding):
    out = guessed_diffuse(torch.full((1, 3, 64, 48), value), kernel_size=21, sigma=21.0, padding=padding)
    assert torch.isfinite(out).all() and out.min() >= 0 and out.max() <= 1


def test_guessed_diffuse_default_kernel_larger_than_image():
    out = guessed_diffuse(torch.rand(1, 3, 40, 30))  # 101 px window, zero padding: still defined
    assert out.shape == (1, 3, 40, 30) and torch.isfinite(out).all()
    assert out.amin(dim=(-2, -1)).max() == 0 and out.amax(dim=(-2, -1)).min() > 0.99


def test_guessed_diffuse_bad_arguments():
    x = torch.rand(1, 3, 20, 20)
    with pytest.raises(ValueError, match="odd"):
        guessed_diffuse(x, kernel_size=4)
    with pytest.raises(ValueError, match="reflect"):
        guessed_diffuse(x, kernel_size=41, padding="reflect")
    with pytest.raises(ValueError, match="padding"):
        guessed_diffuse(x, padding="wrap")


def test_guessed_diffuse_gradcheck():
    x = torch.rand(1, 2, 5, 6, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda t: guessed_diffuse(t, kernel_size=3, sigma=1.0), (x,))


# ---- one form ----

def test_every_loss_is_one_function_and_no_module():
    import inspect

    from torch import nn

    from svbrdf.trainer import losses

    public = {name: getattr(losses, name) for name in losses.__all__}
    assert not [n for n, v in vars(losses).items() if inspect.isclass(v) and issubclass(v, nn.Module)]
    assert all(inspect.isfunction(v) for n, v in public.items() if n.endswith("_loss"))


# ---- diffuse and GAN losses ----

def test_diffuse_loss_value_and_gradcheck():
    a, b = torch.rand(2, 3, 4, 5, dtype=torch.float64), torch.rand(2, 3, 4, 5, dtype=torch.float64)
    assert diffuse_loss(a, b).item() == pytest.approx((a - b).abs().mean().item())
    a.requires_grad_(True)
    assert torch.autograd.gradcheck(lambda t: diffuse_loss(t, b), (a,))


def test_gan_losses_match_cross_entropy():
    fake = torch.tensor([[[[2.0, -1.0], [0.0, 0.5]]]])
    real = torch.tensor([[[[1.0, 3.0], [-2.0, 0.0]]]])

    def softplus(x):
        return torch.log1p(torch.exp(x))

    g = softplus(-fake).mean()  # -log sigmoid(fake)
    d = softplus(-real).mean() + softplus(fake).mean()  # -log sigmoid(real) - log(1 - sigmoid(fake))
    torch.testing.assert_close(gan_generator_loss(fake), g)
    torch.testing.assert_close(gan_discriminator_loss(real, fake), d)
    assert gan_discriminator_loss(torch.zeros(1, 1, 2, 2), torch.zeros(1, 1, 2, 2)).item() == pytest.approx(
        2 * math.log(2))  # no 1/2 factor
    assert gan_generator_loss(torch.zeros(1, 1, 3, 3, dtype=torch.bfloat16)).dtype == torch.float32


# ---- Fourier loss ----

def _random_maps(b, h, w, dtype=torch.float32, seed=0):
    gen = torch.Generator().manual_seed(seed)
    m = torch.rand(b, 8, h, w, generator=gen, dtype=dtype)
    n = m[:, SLICES["normal"]] * 2 - 1
    n[:, 2] = n[:, 2].abs() + 0.1
    m[:, SLICES["normal"]] = n / n.norm(dim=1, keepdim=True)
    return m


def _fourier_reference(maps, guess, mode, include_dc):
    maps, guess = maps.double().numpy(), guess.double().numpy()
    h, w = maps.shape[-2:]
    us = [maps[:, SLICES["diffuse"]], np.repeat(maps[:, SLICES["specular"]], 3, axis=1),
          np.repeat(maps[:, SLICES["roughness"]], 3, axis=1), (maps[:, SLICES["normal"]] + 1) / 2]
    fg = np.fft.fft2(guess) / np.sqrt(h * w)
    vals = []
    for u in us:
        fu = np.fft.fft2(u) / np.sqrt(h * w)
        d = np.abs(fu - fg) if mode == "complex" else np.abs(np.abs(fu) - np.abs(fg))
        if not include_dc:
            d = d.reshape(*d.shape[:-2], -1)[..., 1:]
        vals.append(d.mean())
    return math.log(np.mean(vals) + 1e-8)


@pytest.mark.parametrize("mode", ["complex", "magnitude"])
@pytest.mark.parametrize("include_dc", [True, False])
def test_fourier_loss_matches_numpy(mode, include_dc):
    maps, guess = _random_maps(2, 6, 7), torch.rand(2, 3, 6, 7)
    ref = _fourier_reference(maps, guess, mode, include_dc)
    assert fourier_loss(maps, guess, mode=mode, include_dc=include_dc).item() == pytest.approx(ref, abs=1e-5)


def test_maps_for_loss_layout():
    maps = _random_maps(1, 4, 4)
    u = maps_for_loss(maps)
    assert u.shape == (1, 4, 3, 4, 4)
    torch.testing.assert_close(u[:, 1], maps[:, SLICES["specular"]].expand(1, 3, 4, 4))
    torch.testing.assert_close(u[:, 3], (maps[:, SLICES["normal"]] + 1) / 2)


def test_magnitude_mode_is_translation_invariant_complex_is_not():
    maps, guess = _random_maps(1, 8, 8), torch.rand(1, 3, 8, 8)
    shifted = torch.roll(maps, shifts=(3, 2), dims=(-2, -1))
    mag = [fourier_loss(m, guess, mode="magnitude") for m in (maps, shifted)]
    cpx = [fourier_loss(m, guess, mode="complex") for m in (maps, shifted)]
    torch.testing.assert_close(mag[0], mag[1])
    assert abs(cpx[0] - cpx[1]) > 1e-3


def test_excluding_dc_ignores_a_constant_offset():
    torch.manual_seed(0)  # unseeded, 7 draws in 300 moved the DC term by less than the 1e-3 asked below
    maps, guess = _random_maps(1, 8, 8), torch.rand(1, 3, 8, 8)
    moved = maps + 0.1  # every map, normal encoding included, shifts by a constant
    torch.testing.assert_close(fourier_loss(maps, guess, include_dc=False),
                               fourier_loss(moved, guess, include_dc=False))
    assert abs(fourier_loss(maps, guess) - fourier_loss(moved, guess)) > 1e-3


@pytest.mark.parametrize("mode", ["complex", "magnitude"])
def test_fourier_loss_identical_inputs_finite_gradients(mode):
    c = torch.rand(1, 1, 8, 8)
    guess = c.expand(1, 3, 8, 8).clone().requires_grad_(True)
    maps = torch.cat([c.expand(1, 3, 8, 8), c, c, c.expand(1, 3, 8, 8) * 2 - 1], dim=1).requires_grad_(True)
    loss = fourier_loss(maps, guess, mode=mode)
    loss.backward()
    assert torch.isfinite(loss) and loss.item() < math.log(1e-7)
    assert torch.isfinite(maps.grad).all() and torch.isfinite(guess.grad).all()


@pytest.mark.parametrize("mode", ["complex", "magnitude"])
def test_fourier_loss_black_maps_finite_gradients(mode):
    maps = torch.zeros(1, 8, 8, 8, requires_grad=True)  # every non-DC coefficient is 0
    loss = fourier_loss(maps, torch.zeros(1, 3, 8, 8), mode=mode)
    loss.backward()
    assert torch.isfinite(loss) and torch.isfinite(maps.grad).all()


@pytest.mark.parametrize("mode", ["complex", "magnitude"])
def test_fourier_loss_gradcheck(mode):
    maps = _random_maps(1, 5, 6, dtype=torch.float64, seed=1).requires_grad_(True)
    guess = torch.rand(1, 3, 5, 6, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda m, g: fourier_loss(m, g, mode=mode), (maps, guess))


def test_fourier_loss_bf16_autocast_runs_in_float32():
    maps, guess = _random_maps(1, 8, 8), torch.rand(1, 3, 8, 8)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        loss = fourier_loss(maps.bfloat16(), guess.bfloat16())
    assert loss.dtype == torch.float32
    assert loss.item() == pytest.approx(fourier_loss(maps.bfloat16().float(), guess.bfloat16().float()).item(),
                                        abs=1e-5)


def test_fourier_loss_bad_mode():
    with pytest.raises(ValueError, match="mode"):
        fourier_loss(_random_maps(1, 4, 4), torch.rand(1, 3, 4, 4), mode="phase")


# ---- the whole generator objective on degenerate photos ----

@pytest.mark.parametrize("value", [0.0, 1.0])
@pytest.mark.parametrize("backend", ["pyramid", "vgg19-random"])
def test_black_and_white_photos_give_finite_losses_and_gradients(value, backend):
    torch.manual_seed(0)
    g, d = Generator(MODEL_PRESETS["tiny"]), Discriminator(DISC_PRESETS["tiny"])
    perceptual = PerceptualLoss(backend)
    photo = torch.full((1, 3, 32, 32), value)
    guess = guessed_diffuse(photo, kernel_size=9, sigma=9.0)
    maps = g(photo)
    render = FlashGeometry(32, 32).render(maps)
    losses = [
        0.1 * gan_generator_loss(d(render)),
        diffuse_loss(maps[:, SLICES["diffuse"]], guess),
        0.1 * fourier_loss(maps, guess),
        0.1 * fourier_loss(maps, guess, mode="magnitude", include_dc=False),
        0.2 * perceptual(photo, render),
        gan_discriminator_loss(d(photo), d(render.detach())),
    ]
    total = sum(losses)
    total.backward()
    assert all(torch.isfinite(x) for x in losses)
    for module in (g.decoder_nr, g.decoder_ds, d):
        assert all(torch.isfinite(p.grad).all() for p in module.parameters())


def test_clipped_fraction_counts_saturated_pixels_by_their_brightest_channel():
    photo = torch.full((1, 3, 10, 10), 0.5)
    assert clipped_fraction(photo) == 0.0
    photo[0, 0, :2, :5] = 1.0  # one saturated channel is enough: 10 of 100 pixels
    photo[0, 1, 9, 9] = CLIP_LEVEL - 1e-3  # just below the level: not counted
    assert clipped_fraction(photo) == pytest.approx(0.1)


# ---- highlight-free terms ----

def test_normalized_diffuse_loss_ignores_level_and_contrast():
    g = torch.rand(2, 3, 16, 16)
    pred = 0.5 * g + 0.05  # the guess's pattern at another level and contrast
    same_pattern = float(diffuse_loss(pred, g, "normalized"))  # not 0 only through the 0.01 added to the std
    assert same_pattern < 0.05 and float(diffuse_loss(pred, g, "absolute")) > 0.2
    assert float(diffuse_loss(torch.rand(2, 3, 16, 16), g, "normalized")) > 10 * same_pattern  # another pattern
    with pytest.raises(ValueError):
        diffuse_loss(pred, g, "relative")


def _srgb(x):
    return linear_to_srgb(torch.full((1, 3, 1, 1), float(x)))[0, 0, 0, 0]


def test_render_loss_is_srgb_l1_and_one_sided_on_clipped_pixels():
    photo = torch.full((1, 3, 2, 2), 0.2)
    photo[..., 0, 0] = 1.0  # one saturated pixel
    r = photo.clone()
    assert render_loss(r, photo) == 0.0
    r[..., 0, 0] = 5.0  # brighter than the clip: allowed
    assert render_loss(r, photo) == 0.0
    r[..., 0, 0] = 0.5  # darker than the clip: penalised
    want = float((_srgb(torch.tensor(0.99)) - _srgb(torch.tensor(0.5))) / 4)
    assert float(render_loss(r, photo)) == pytest.approx(want, rel=1e-4)
    r = photo.clone()
    r[..., 1, 1] = 0.4  # an unsaturated pixel: |srgb(r) - srgb(photo)| both ways
    want = float((_srgb(torch.tensor(0.4)) - _srgb(torch.tensor(0.2))) / 4)
    assert float(render_loss(r, photo)) == pytest.approx(want, rel=1e-4)


def test_flash_basis_peaks_under_the_flash():
    geo = FlashGeometry(33, 33)
    b = flash_basis(geo.light)
    assert b.shape == (1, 3, 33, 33) and float(b.min()) >= 0 and float(b.max()) <= 1
    for k in range(3):
        assert int(b[0, k].argmax()) == 16 * 33 + 16  # the centre pixel
    assert float(b[0, 0].min()) > float(b[0, 2].min())  # the broad field decays less than the narrow one


def _stationary_maps(n=64, seed=0):
    g = torch.Generator().manual_seed(seed)
    m = torch.rand(1, 8, n, n, generator=g) * 0.4 + 0.3
    m[:, SLICES["normal"]] = torch.tensor([0.0, 0.0, 1.0])[None, :, None, None]
    return m


def test_flash_correlation_loss_separates_burnt_from_stationary_maps():
    basis = flash_basis(FlashGeometry(64, 64).light)
    clean = _stationary_maps()
    burnt = clean.clone()
    burnt[:, SLICES["diffuse"]] += 0.3 * basis[:, 1:2]
    assert float(flash_correlation_loss(clean, basis)) < 0.01
    assert float(flash_correlation_loss(burnt, basis)) > 10 * float(flash_correlation_loss(clean, basis))
    assert flash_maps(burnt).shape == (1, 6, 64, 64)


def test_flash_correlation_gradient_only_removes_the_flash_pattern():
    """With the scale held fixed, the gradient lies in the span of the (centred) flash fields: descending it
    removes flash-shaped structure and leaves the rest of the texture alone."""
    basis = flash_basis(FlashGeometry(64, 64).light)
    maps = _stationary_maps(seed=1)
    maps[:, SLICES["specular"]] += 0.2 * basis[:, 2:3]
    maps.requires_grad_(True)
    flash_correlation_loss(maps, basis).backward()
    grad = maps.grad[0, 3].flatten()  # the specular channel
    b = basis[0].reshape(3, -1)
    b = b - b.mean(dim=1, keepdim=True)
    coef = torch.linalg.lstsq(b.T, grad[:, None]).solution
    residual = grad - (b.T @ coef)[:, 0]
    assert float(residual.norm()) < 1e-4 * float(grad.norm()) + 1e-12
    assert float(grad.norm()) > 0


# ---- supervised losses of the procedural prior ----

def _flat_maps(diffuse=0.3, specular=0.04, roughness=0.5, size=8):
    from svbrdf.trainer.models import pack_maps

    n = torch.zeros(1, 3, size, size)
    n[:, 2] = 1.0
    return pack_maps({"diffuse": torch.full((1, 3, size, size), diffuse), "specular": torch.full((1, 1, size, size), specular),
                      "roughness": torch.full((1, 1, size, size), roughness), "normal": n})


def test_supervised_maps_loss_per_map_and_weighted_total():
    from svbrdf.trainer.losses import SUPERVISED_WEIGHTS, supervised_maps_loss

    a, b = _flat_maps(), _flat_maps(specular=0.14, roughness=0.2)
    terms = supervised_maps_loss(a, b)
    assert float(terms["diffuse"]) == 0 and float(terms["normal"]) == 0
    assert float(terms["specular"]) == pytest.approx(0.1, abs=1e-6)
    assert float(terms["roughness"]) == pytest.approx(0.3, abs=1e-6)
    expect = SUPERVISED_WEIGHTS["specular"] * 0.1 + SUPERVISED_WEIGHTS["roughness"] * 0.3
    assert float(terms["total"]) == pytest.approx(expect, abs=1e-6)
    half = {**SUPERVISED_WEIGHTS, "roughness": 0.5}
    assert float(supervised_maps_loss(a, b, half)["total"]) == pytest.approx(expect - 0.5 * 0.3, abs=1e-6)


def test_supervised_diffuse_error_weighs_dark_materials_like_bright_ones():
    from svbrdf.trainer.losses import supervised_maps_loss

    # The same linear error of 0.02 costs more on a near-black albedo than on a bright one (sRGB encoding).
    dark = float(supervised_maps_loss(_flat_maps(diffuse=0.02), _flat_maps(diffuse=0.04))["diffuse"])
    bright = float(supervised_maps_loss(_flat_maps(diffuse=0.70), _flat_maps(diffuse=0.72))["diffuse"])
    assert dark > 3 * bright


def test_relit_loss_is_zero_for_equal_renderings_and_log_scaled():
    from svbrdf.trainer.losses import RELIT_LOG_EPS, relit_loss

    x = torch.rand(2, 3, 8, 8) * 5
    assert float(relit_loss(x, x)) == 0.0
    one = torch.ones(1, 3, 4, 4)
    # Doubling the radiance costs log(2) (up to eps), whatever its level.
    assert float(relit_loss(2 * one, one, eps=0.0)) == pytest.approx(math.log(2.0), rel=1e-6)
    assert float(relit_loss(200 * one, 100 * one)) == pytest.approx(math.log((200 + RELIT_LOG_EPS) / (100 + RELIT_LOG_EPS)), rel=1e-5)
    x.requires_grad_(True)
    relit_loss(x, torch.rand(2, 3, 8, 8)).backward()
    assert torch.isfinite(x.grad).all()


def test_gradient_loss_measures_detail_not_level():
    from svbrdf.trainer.losses import gradient_loss

    target = torch.rand(2, 8, 16, 16, generator=torch.Generator().manual_seed(0))
    shifted = target.clone()
    shifted[:, SLICES["roughness"]] += 0.2  # the same detail at another level
    assert float(gradient_loss(shifted, target)) == pytest.approx(0.0, abs=1e-6)
    blurred = target.clone()
    blurred[:, SLICES["normal"]] = target[:, SLICES["normal"]].mean((2, 3), keepdim=True)
    assert float(gradient_loss(blurred, target)) > 0.01
    other = target.clone()
    other[:, SLICES["diffuse"]] = 0.0  # maps outside the term do not count
    assert float(gradient_loss(other, target)) == 0.0
    assert float(gradient_loss(other, target, maps=("diffuse",))) > 0


def test_detail_amount_loss_asks_for_variation_wherever_it_lies_in_the_window():
    from svbrdf.trainer.losses import detail_amount_loss, gradient_loss

    g = torch.Generator().manual_seed(0)
    target = torch.rand(2, 8, 32, 32, generator=g)
    assert float(detail_amount_loss(target, target)) == pytest.approx(0.0, abs=1e-6)
    flat = target.clone()
    flat[:, SLICES["roughness"]] = target[:, SLICES["roughness"]].mean((2, 3), keepdim=True)
    # The same roughness, shuffled inside each 16 px window: as much detail, in the wrong places.
    shuffled = target.clone()
    r = target[:, SLICES["roughness"]].unfold(2, 16, 16).unfold(3, 16, 16)  # (B, 1, 2, 2, 16, 16)
    perm = torch.randperm(256, generator=g)
    r = r.reshape(*r.shape[:4], 256)[..., perm].reshape(*r.shape)
    shuffled[:, SLICES["roughness"]] = r.permute(0, 1, 2, 4, 3, 5).reshape(2, 1, 32, 32)
    one = dict(windows=(16,))
    assert float(detail_amount_loss(shuffled, target, **one)) == pytest.approx(0.0, abs=1e-5)
    assert float(detail_amount_loss(flat, target, **one)) > 0.06  # noise std 0.29 on one of the four channels
    # gradient_loss and the per-pixel error prefer the flat map to the shuffled one; this term does not.
    assert float(gradient_loss(flat, target)) < float(gradient_loss(shuffled, target))
    half = target.clone()
    half[:, SLICES["roughness"]] = 0.5 + 0.5 * (target[:, SLICES["roughness"]] - 0.5)
    assert 0 < float(detail_amount_loss(half, target)) < float(detail_amount_loss(flat, target))
    other = target.clone()
    other[:, SLICES["diffuse"]] = 0.0  # maps outside the term do not count
    assert float(detail_amount_loss(other, target)) == pytest.approx(0.0, abs=1e-6)
    big = detail_amount_loss(flat[..., :8, :8], target[..., :8, :8], windows=(64,))  # window clamped to 8 px
    assert torch.isfinite(big) and float(big) > 0
    # A nearly flat map is pushed to vary more: a step down the gradient lowers the term.
    x = flat.clone()
    x[:, SLICES["roughness"]] += 0.01 * (torch.rand(2, 1, 32, 32, generator=g) - 0.5)
    x.requires_grad_(True)
    before = detail_amount_loss(x, target)
    before.backward()
    assert torch.isfinite(x.grad).all()
    assert float(detail_amount_loss(x.detach() - 10.0 * x.grad, target)) < float(before.detach())


# ---- slope correlation (the stage one's normals) ----

def _relief_maps(height: torch.Tensor, scale: float = 32.0) -> torch.Tensor:
    """(B, 8, H, W) packed maps with the normals of ``height`` (B, 1, H, W) and grey other maps."""
    from svbrdf.trainer.models import height_to_normal

    b, _, h, w = height.shape
    maps = torch.full((b, 8, h, w), 0.5)
    maps[:, SLICES["normal"]] = height_to_normal(height, scale)
    return maps


def test_slope_correlation_is_the_benchmarks_slope_correlation():
    from svbrdf.trainer.bench.metrics import _corr, _slopes
    from svbrdf.trainer.losses import slope_correlation_loss

    g = torch.Generator().manual_seed(0)
    h = torch.rand(1, 1, 24, 20, generator=g) * 0.05
    truth = _relief_maps(h)
    pred = _relief_maps(0.5 * h + torch.rand(1, 1, 24, 20, generator=g) * 0.03)  # partly right
    want = _corr(_slopes(pred[0, SLICES["normal"]].permute(1, 2, 0).numpy()),
                 _slopes(truth[0, SLICES["normal"]].permute(1, 2, 0).numpy()))
    assert 0.05 < want < 0.95
    assert float(slope_correlation_loss(pred, truth)) == pytest.approx(1.0 - want, abs=1e-5)


def test_slope_correlation_ignores_the_scale_and_leaves_out_flat_truths():
    from svbrdf.trainer.losses import slope_correlation_loss

    g = torch.Generator().manual_seed(1)
    h = torch.rand(2, 1, 16, 16, generator=g)
    truth = _relief_maps(h * 0.05)
    assert float(slope_correlation_loss(truth, truth)) == pytest.approx(0.0, abs=1e-5)
    assert float(slope_correlation_loss(_relief_maps(h * 0.0005), truth)) == pytest.approx(0.0, abs=1e-3)  # 100x flatter
    assert float(slope_correlation_loss(_relief_maps(-h * 0.05), truth)) == pytest.approx(2.0, abs=1e-3)  # inverted relief
    # a flat truth has no pattern: the image is left out, not scored 1
    flat = truth.clone()
    flat[1, SLICES["normal"]] = torch.tensor([0.0, 0.0, 1.0]).view(3, 1, 1)
    pred = truth.clone()
    pred[1] = _relief_maps(torch.rand(1, 1, 16, 16, generator=g) * 0.05)[0]
    assert float(slope_correlation_loss(pred, flat)) == pytest.approx(0.0, abs=1e-5)
    flat[0] = flat[1]
    assert float(slope_correlation_loss(pred, flat)) == 0.0
    # ridges along one axis (slopes in x only) still have a pattern
    ridge = torch.linspace(0, 3, 16).sin().view(1, 1, 1, 16).expand(1, 1, 16, 16).contiguous() * 0.05
    assert float(slope_correlation_loss(_relief_maps(ridge), _relief_maps(ridge))) == pytest.approx(0.0, abs=1e-5)
    assert float(slope_correlation_loss(_relief_maps(-ridge), _relief_maps(ridge))) > 1.5


def test_slope_correlation_reaches_a_flattened_network_where_the_l1_does_not():
    # the normals' L1 pushes a nearly flat height's pattern as little as its scale; this term does not shrink with it
    from svbrdf.trainer.losses import slope_correlation_loss, supervised_maps_loss

    g = torch.Generator().manual_seed(2)
    truth = _relief_maps(torch.rand(1, 1, 16, 16, generator=g) * 0.05)
    pattern = torch.rand(1, 1, 16, 16, generator=g)
    grads = {}
    for scale in (1e-2, 1e-4):
        p = pattern.clone().requires_grad_(True)
        pred = _relief_maps(p * scale)
        l1 = supervised_maps_loss(pred, truth)["normal"]
        (g_l1,) = torch.autograd.grad(l1, p, retain_graph=True)
        (g_sc,) = torch.autograd.grad(slope_correlation_loss(pred, truth), p)
        grads[scale] = float(g_l1.norm()), float(g_sc.norm())
    assert grads[1e-4][0] < 0.02 * grads[1e-2][0]  # the L1's push on the pattern falls with the scale
    assert grads[1e-4][1] == pytest.approx(grads[1e-2][1], rel=1e-3)  # this one does not depend on the scale
    assert grads[1e-4][1] > 0
