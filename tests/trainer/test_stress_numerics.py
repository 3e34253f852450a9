"""Stress: finite values and gradients of the renderer and of every loss over their whole input box (float32), and
training on extreme photos without NaN, divergence or work for the numerical guard.

Tiles: black, white (fully clipped), saturated (linear 1e4, an over-exposed float photo), noise, a texture with a
clipped flash highlight, and a constant grey. Sizes go down to 1 x 1 wherever the function accepts them.
"""

import math

import numpy as np
import pytest
import torch
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.core.maps import MAP_NAMES, SLICES, Maps
from svbrdf.runtime.core.render import RenderConfig, render
from svbrdf.trainer.config import resolve
from svbrdf.trainer.losses import (diffuse_loss, fourier_loss, gan_discriminator_loss, gan_generator_loss,
                                   guessed_diffuse)
from svbrdf.trainer.perceptual import PerceptualLoss
from svbrdf.trainer.render import FlashGeometry
from svbrdf.trainer.train import Trainer, to_maps

STRESS = settings(max_examples=40, deadline=None, derandomize=True)
TILES = ("black", "white", "saturated", "noise", "highlight", "constant")
MAP_KINDS = ("zeros", "ones", "random", "grazing")
UNIT = st.floats(0.0, 1.0, width=32)
BIG = float(np.float32(1e30))  # |logit| bound of the GAN-loss stress (exactly a float32)


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _tile(kind: str, h: int, w: int, seed: int = 0) -> torch.Tensor:
    """(1, 3, h, w) float32 linear photo tile of the given kind."""
    g = torch.Generator().manual_seed(seed)
    if kind == "black":
        return torch.zeros(1, 3, h, w)
    if kind == "white":
        return torch.ones(1, 3, h, w)
    if kind == "saturated":
        return torch.full((1, 3, h, w), 1e4)
    if kind == "noise":
        return torch.rand(1, 3, h, w, generator=g)
    if kind == "constant":
        return torch.full((1, 3, h, w), 0.37)
    if kind == "highlight":
        yy, xx = torch.meshgrid(torch.arange(h) + 0.5 - h / 2, torch.arange(w) + 0.5 - w / 2, indexing="ij")
        blob = torch.exp(-(yy**2 + xx**2) / (2 * (0.2 * max(h, w)) ** 2))
        return (0.15 + 0.1 * torch.rand(1, 3, h, w, generator=g) + 3.0 * blob).clamp(0.0, 1.0)
    raise AssertionError(kind)


def _maps(kind: str, h: int, w: int, seed: int = 0) -> torch.Tensor:
    """(1, 8, h, w) packed maps at the corners of their box (zeros: black, mirror-smooth, zero-length normals)."""
    g = torch.Generator().manual_seed(seed)
    out = torch.zeros(1, 8, h, w)
    if kind == "zeros":
        return out
    if kind == "ones":
        out[:, :5] = 1.0
        out[:, SLICES["normal"].stop - 1] = 1.0
        return out
    tilt = torch.full((h, w), math.pi / 2) if kind == "grazing" else torch.rand(h, w, generator=g) * math.pi / 2
    az = torch.rand(h, w, generator=g) * 2 * math.pi
    out[:, SLICES["normal"]] = torch.stack([tilt.sin() * az.cos(), tilt.sin() * az.sin(), tilt.cos()])[None]
    out[:, :5] = torch.rand(1, 5, h, w, generator=g)
    if kind == "grazing":
        out[:, SLICES["specular"]] = 1.0
        out[:, SLICES["roughness"]] = 0.0
    return out


def _assert_finite_grad(*tensors):
    for t in tensors:
        assert t.grad is not None and torch.isfinite(t.grad).all()


# ------------------------------------------------------------------------------ renderer
@STRESS
@given(
    diffuse=arrays(np.float32, (3, 3, 4), elements=UNIT),
    specular=arrays(np.float32, (1, 3, 4), elements=UNIT),
    roughness=arrays(np.float32, (1, 3, 4), elements=UNIT),
    tilt=arrays(np.float32, (3, 4), elements=st.floats(0.0, 90.0, width=32)),
    azimuth=arrays(np.float32, (3, 4), elements=st.floats(0.0, 360.0, width=32)),
    zero_normal=st.booleans(),
    photo=st.tuples(st.integers(3, 200), st.integers(4, 200)),
    where=st.tuples(UNIT, UNIT),
    intensity=st.floats(0.0, 1e4),
    fov=st.floats(1.0, 170.0),
    light=st.one_of(st.none(), st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(0.01, 5))),
    geometry=st.sampled_from(["schlick", "smith"]),
    fresnel=st.sampled_from(["schlick", "none"]),
    falloff=st.booleans(),
    conservation=st.booleans(),
    target=st.sampled_from([0.0, 1.0, 1e4]),
)
# A mirror (roughness 0) facing the flash exactly: the centre pixel of an odd-sized photo, where n.h = 1.
@example(diffuse=np.ones((3, 3, 4), np.float32), specular=np.ones((1, 3, 4), np.float32),
         roughness=np.zeros((1, 3, 4), np.float32), tilt=np.zeros((3, 4), np.float32),
         azimuth=np.zeros((3, 4), np.float32), zero_normal=False, photo=(3, 5), where=(0.0, 0.0), intensity=1e4,
         fov=66.0, light=None, geometry="schlick", fresnel="schlick", falloff=True, conservation=False, target=0.0)
def test_render_maps_finite_values_and_gradients_over_the_box(diffuse, specular, roughness, tilt, azimuth,
                                                              zero_normal, photo, where, intensity, fov, light,
                                                              geometry, fresnel, falloff, conservation, target):
    """Spatially varying maps anywhere in the box (roughness and specular 0..1 inclusive, normals up to exactly
    grazing, a zero-length normal), any light, intensity 0..1e4, a tile anywhere in a photo of any aspect."""
    config = RenderConfig(fov_deg=fov, intensity=intensity, falloff=falloff, diffuse_conservation=conservation,
                          geometry=geometry, fresnel=fresnel)
    t, a = np.radians(tilt), np.radians(azimuth)
    normal = np.stack([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)]).astype(np.float32)
    if zero_normal:
        normal[:, 1, 2] = 0.0
    values = {"diffuse": diffuse, "specular": specular, "roughness": roughness, "normal": normal}
    packed = torch.from_numpy(np.concatenate([values[n] for n in MAP_NAMES]))[None].requires_grad_(True)
    h, w = photo
    y0, x0 = round(where[0] * (h - 3)), round(where[1] * (w - 4))

    geo = FlashGeometry(h, w, config, light_pos=light)
    img = geo.render(packed, y0, x0)
    assert img.dtype == torch.float32 and torch.isfinite(img).all() and (img >= 0).all()
    (img - target).abs().mean().backward()  # the gradient a reconstruction loss sends back
    _assert_finite_grad(packed)

    maps = Maps(**{n: np.moveaxis(v, 0, -1) for n, v in values.items()})  # the numpy renderer of the previews
    ref = render(maps, light, config, full_size=(h, w), offset=(y0, x0))
    assert np.isfinite(ref).all() and (ref >= 0).all()


# ------------------------------------------------------------------------------ guessed diffuse
@STRESS
@given(
    kind=st.sampled_from(TILES),
    size=st.sampled_from([(1, 1), (5, 7), (16, 16), (24, 40)]),
    kernel=st.sampled_from([1, 3, 9, 101]),
    padding=st.sampled_from(["zeros", "reflect"]),
    seed=st.integers(0, 1000),
)
@example(kind="constant", size=(16, 16), kernel=9, padding="reflect", seed=0)
@example(kind="highlight", size=(24, 40), kernel=3, padding="zeros", seed=0)
def test_guessed_diffuse_finite_values_and_gradients(kind, size, kernel, padding, seed):
    photo = _tile(kind, *size, seed=seed).requires_grad_(True)
    if padding == "reflect" and min(size) <= kernel // 2:
        with pytest.raises(ValueError, match="reflect padding needs"):
            guessed_diffuse(photo, kernel_size=kernel, sigma=float(kernel), padding=padding)
        return
    guess = guessed_diffuse(photo, kernel_size=kernel, sigma=float(kernel), padding=padding)
    assert guess.dtype == torch.float32 and torch.isfinite(guess).all()
    assert guess.min() >= 0 and guess.max() <= 1
    (guess * torch.rand(guess.shape, generator=torch.Generator().manual_seed(seed))).sum().backward()
    _assert_finite_grad(photo)


@pytest.mark.parametrize("value", [0.0, 0.37, 1.0, 1e4])
def test_guessed_diffuse_of_a_constant_image_is_flat(value):
    """Zero variance everywhere (reflect padding: no darkened border) invents no structure: the FFT round-off of
    the local mean (~1e-16 of the value) divided by eps = 1e-4 twice stays far below one 8-bit step."""
    guess = guessed_diffuse(torch.full((1, 3, 20, 28), value), kernel_size=9, sigma=9.0, padding="reflect")
    assert torch.isfinite(guess).all() and guess.max() - guess.min() <= 1e-3


@pytest.mark.parametrize("padding", ["zeros", "reflect"])
@pytest.mark.parametrize("kernel", [5, 9])
def test_guessed_diffuse_of_a_clipped_highlight(padding, kernel):
    """Where the window lies inside the clipped plateau the local variance is 0: the guess there is one flat level
    (per channel), finite with finite gradients, and the highlight does not stay the brightest region."""
    photo = _tile("highlight", 48, 64).requires_grad_(True)
    plateau = (photo.detach()[0] >= 1.0).all(0).float()
    inside = torch.nn.functional.max_pool2d(1 - plateau[None, None], kernel, 1, kernel // 2)[0, 0] == 0
    assert inside.sum() >= 20
    guess = guessed_diffuse(photo, kernel_size=kernel, sigma=float(kernel), padding=padding)
    level = guess.detach()[0][:, inside]  # (3, n)
    assert (level.max(1).values - level.min(1).values).max() <= 1e-4
    assert level.max() <= 0.75  # min-max of the photo itself would put the plateau at 1.0
    guess.sum().backward()
    _assert_finite_grad(photo)


# ------------------------------------------------------------------------------ map losses
@STRESS
@given(
    maps_kind=st.sampled_from(MAP_KINDS),
    guess_kind=st.sampled_from(TILES),
    size=st.sampled_from([(1, 1), (2, 3), (5, 7), (8, 8), (16, 24)]),
    mode=st.sampled_from(["complex", "magnitude"]),
    include_dc=st.booleans(),
    seed=st.integers(0, 1000),
)
def test_diffuse_and_fourier_losses_finite(maps_kind, guess_kind, size, mode, include_dc, seed):
    maps = _maps(maps_kind, *size, seed=seed).requires_grad_(True)
    guess = _tile(guess_kind, *size, seed=seed).clamp(0.0, 1.0).requires_grad_(True)  # a guess is in [0, 1]
    ld = diffuse_loss(maps[:, SLICES["diffuse"]], guess)
    if not include_dc and size == (1, 1):
        with pytest.raises(ValueError, match="at least 2 pixels"):
            fourier_loss(maps, guess, mode=mode, include_dc=False)
        return
    lf = fourier_loss(maps, guess, mode=mode, include_dc=include_dc)
    assert torch.isfinite(ld) and torch.isfinite(lf) and 0 <= ld <= 1
    (ld + lf).backward()
    _assert_finite_grad(maps, guess)


@STRESS
@given(
    kind=st.sampled_from(TILES),
    size=st.sampled_from([(1, 1), (5, 7), (8, 8), (16, 24)]),
    mode=st.sampled_from(["complex", "magnitude"]),
    include_dc=st.booleans(),
    seed=st.integers(0, 1000),
)
def test_fourier_loss_on_identical_inputs_is_its_minimum(kind, size, mode, include_dc, seed):
    """Maps whose four loss images equal the guess: |spectrum difference| is 0 everywhere, the modulus epsilon
    keeps the gradient finite, and the loss is at its floor (any change raises it)."""
    if not include_dc and size == (1, 1):
        return  # refused, see test_diffuse_and_fourier_losses_finite
    grey = _tile(kind, *size, seed=seed).clamp(0.0, 1.0)[:, :1]
    guess = grey.expand(1, 3, *size).clone().requires_grad_(True)
    maps = torch.cat([guess.detach(), grey, grey, guess.detach() * 2 - 1], dim=1).requires_grad_(True)
    loss = fourier_loss(maps, guess, mode=mode, include_dc=include_dc)
    loss.backward()
    assert torch.isfinite(loss) and loss.item() <= math.log(1e-8 + 1e-9)
    _assert_finite_grad(maps, guess)
    bump = torch.zeros_like(maps)
    bump[..., 0, 0] = 0.05
    bump[..., -1, -1] = -0.05  # not a pure DC shift, so include_dc=False sees it too
    assert fourier_loss(maps.detach() + bump, guess.detach(), mode=mode, include_dc=include_dc) > loss + 1.0


@STRESS
@given(
    real=arrays(np.float32, (1, 1, 2, 3), elements=st.floats(-BIG, BIG, width=32)),
    fake=arrays(np.float32, (1, 1, 2, 3), elements=st.floats(-BIG, BIG, width=32)),
)
@example(real=np.full((1, 1, 2, 3), 1e4, np.float32), fake=np.full((1, 1, 2, 3), -1e4, np.float32))
def test_gan_losses_finite_at_extreme_logits(real, fake):
    r, f = torch.from_numpy(real).requires_grad_(True), torch.from_numpy(fake).requires_grad_(True)
    lg, ld = gan_generator_loss(f), gan_discriminator_loss(r, f)
    assert torch.isfinite(lg) and torch.isfinite(ld) and lg >= 0 and ld >= 0
    (lg + ld).backward()
    _assert_finite_grad(r, f)


# ------------------------------------------------------------------------------ perceptual
_PERCEPTUAL = {}


def _perceptual(backend: str) -> PerceptualLoss:
    if backend not in _PERCEPTUAL:
        _PERCEPTUAL[backend] = PerceptualLoss(backend, seed=0)
    return _PERCEPTUAL[backend]


def _check_perceptual(backend, a, b):
    loss = _perceptual(backend)
    b = b.clone().requires_grad_(True)
    value = loss(a, b)
    assert torch.isfinite(value) and value >= 0
    value.backward()
    _assert_finite_grad(b)
    assert loss(a, a.clone()).item() <= 1e-6


@STRESS
@given(
    size=st.sampled_from([(1, 1), (2, 3), (5, 7), (16, 16), (17, 33)]),
    kind_a=st.sampled_from(TILES),
    kind_b=st.sampled_from(TILES),
    seed=st.integers(0, 1000),
)
def test_pyramid_perceptual_loss_finite(size, kind_a, kind_b, seed):
    _check_perceptual("pyramid", _tile(kind_a, *size, seed=seed), _tile(kind_b, *size, seed=seed + 1))


@pytest.mark.parametrize("kind_a,kind_b,size", [
    ("black", "white", (16, 16)),
    ("saturated", "black", (16, 16)),
    ("highlight", "noise", (17, 33)),
    ("constant", "saturated", (16, 16)),
])
def test_vgg_perceptual_loss_finite(kind_a, kind_b, size):
    """VGG-19 with random weights at its smallest sizes (a full-width network: a few cases only)."""
    _check_perceptual("vgg19-random", _tile(kind_a, *size), _tile(kind_b, *size, seed=1))


def test_vgg_refuses_tiles_below_16_px():
    """Four 2x2 max-pools come before relu5_1: a smaller image must be a clear ValueError, not a torch error."""
    loss = _perceptual("vgg19-random")
    for size in ((15, 64), (8, 8), (1, 1)):
        with pytest.raises(ValueError, match="16"):
            loss(torch.rand(1, 3, *size), torch.rand(1, 3, *size))


# ------------------------------------------------------------------------------ training
def _extreme_photos(h: int, w: int) -> dict:
    photos = {kind: _tile(kind, h, w, seed=1) for kind in ("black", "white", "highlight", "noise")}
    # An HDR float photo (EXR): a texture with an unclipped flash highlight up to 1e4.
    photos["hdr"] = _tile("constant", h, w) + 1e4 * (_tile("highlight", h, w) >= 1.0).float()
    return photos


def _params_and_states(trainer):
    nets = list(trainer.generator.parameters()) + list(trainer.discriminator.parameters())
    states = [v for opt in trainer.optimizers.values() for s in opt.state.values() for v in s.values()
              if isinstance(v, torch.Tensor)]
    return nets + states


def _assert_sane_run(trainer, history, name):
    assert trainer.counters == {"nonfinite_skips": 0, "rollbacks": 0}, name
    for rec in history:
        nones = [k for k, v in rec.items() if v is None and k != "eval/map_change"]
        assert not nones, (name, rec["step"], nones)
        # BCE of a patch mean: far above ~10 the discriminator's logits have blown up.
        assert all(rec[k] < 30 for k in ("nr/gan", "ds/gan", "d/loss")), (name, rec)
    assert all(torch.isfinite(t).all() for t in _params_and_states(trainer)), name
    maps = trainer.predict()
    assert torch.isfinite(maps).all(), name
    maps = to_maps(maps)
    for n, arr in maps.items():
        assert np.isfinite(arr).all(), (name, n)
    # No divergence of the supervised term: the L1 to the guessed diffuse does not grow.
    k = max(2, len(history) // 4)
    first = sum(r["ds/diffuse"] for r in history[:k]) / k
    last = sum(r["ds/diffuse"] for r in history[-k:]) / k
    assert last <= 1.1 * first + 1e-3, (name, first, last)


def _train_all(h, w, iters, bf16):
    for name, photo in _extreme_photos(h, w).items():
        config = resolve("tiny", iters_fit=iters, eval_every=4, guard_snapshot_every=4, bf16=bf16)
        trainer = Trainer(photo, config, threads=1)
        history = trainer.run()
        assert len(history) == iters
        _assert_sane_run(trainer, history, name)


@pytest.mark.integration
@pytest.mark.parametrize("bf16", [False, True])  # bf16 falls back to float32 on CPUs without it
def test_training_on_extreme_photos_fast(bf16):
    _train_all(32, 36, iters=8, bf16=bf16)


@pytest.mark.slow
@pytest.mark.parametrize("bf16", [False, True])
def test_training_on_extreme_photos_long(bf16):
    """A couple hundred iterations in total (5 photos x 50) at 40 x 48 px."""
    _train_all(40, 48, iters=50, bf16=bf16)


def test_smallest_accepted_photo_and_tile_train():
    """Whatever minimum the trainer announces, a photo of that size must train (not crash mid-run); a tile the
    networks cannot take is refused when the trainer is built."""
    side = next(s for s in range(8, 129) if _accepts(s))
    trainer = Trainer(_tile("noise", side, side), resolve("tiny", iters_fit=2), threads=1)
    trainer.run()
    assert trainer.step == 2 and trainer.counters["nonfinite_skips"] == 0
    assert torch.isfinite(trainer.predict()).all()
    for tile in (8, 16, 24):
        try:
            trainer = Trainer(_tile("noise", 48, 48), resolve("tiny", iters_fit=1, tile=tile), threads=1)
        except (ValueError, ImageError) as exc:
            assert "tile" in str(exc) and "\n" not in str(exc)
            continue
        trainer.run()
        assert trainer.step == 1


def _accepts(side: int) -> bool:
    try:
        Trainer(torch.rand(1, 3, side, side), resolve("tiny"), threads=1)
    except ImageError as exc:
        assert "at least" in str(exc)
        return False
    return True
