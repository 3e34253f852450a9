import math

import numpy as np
import pytest
import torch

from svbrdf.runtime.maps import SLICES
from svbrdf.trainer.losses import (
    CLIP_LEVEL,
    clipped_fraction,
    DiffuseLoss, FourierLoss, GANDiscriminatorLoss, GANGeneratorLoss, diffuse_loss, fourier_loss,
    gan_discriminator_loss, gan_generator_loss, guessed_diffuse, maps_for_loss,
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


# ---- diffuse and GAN losses ----

def test_diffuse_loss_value_and_gradcheck():
    a, b = torch.rand(2, 3, 4, 5, dtype=torch.float64), torch.rand(2, 3, 4, 5, dtype=torch.float64)
    assert diffuse_loss(a, b).item() == pytest.approx((a - b).abs().mean().item())
    assert DiffuseLoss()(a, b) == diffuse_loss(a, b)
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
    torch.testing.assert_close(GANGeneratorLoss()(fake), g)
    torch.testing.assert_close(GANDiscriminatorLoss()(real, fake), d)
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
    assert FourierLoss(mode, include_dc=include_dc)(maps, guess).item() == pytest.approx(ref, abs=1e-5)


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
        FourierLoss("phase")


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
