"""The torch renderer (svbrdf.trainer.render) agrees with numpy, has correct and finite gradients."""

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from svbrdf.runtime.core.maps import MAP_NAMES, SLICES, Maps
from svbrdf.runtime.core.render import DESCHAINTRE, ZHAO, RenderConfig, light_vectors, render, shade
from svbrdf.trainer.render import FlashGeometry, render_maps

CONFIGS = [
    ZHAO,
    DESCHAINTRE,
    ZHAO.replace(falloff=True, geometry="smith", fresnel="none"),
]


def _random_maps(rng, h, w, max_tilt_deg=60.0, rough=(0.1, 1.0)):
    tilt = np.radians(rng.uniform(0, max_tilt_deg, (h, w)))
    az = rng.uniform(0, 2 * np.pi, (h, w))
    normal = np.stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)], -1)
    return Maps(diffuse=rng.uniform(0, 1, (h, w, 3)), specular=rng.uniform(0, 1, (h, w, 1)),
                roughness=rng.uniform(*rough, (h, w, 1)), normal=normal)


def _packed(maps: Maps, dtype=torch.float32) -> torch.Tensor:
    return torch.as_tensor(maps.pack(), dtype=dtype).permute(2, 0, 1)[None].contiguous()


@pytest.mark.parametrize("config", CONFIGS)
def test_shade_same_formula_numpy_and_torch_float64(config):
    rng = np.random.default_rng(2)
    maps = _random_maps(rng, 16, 24)
    v, l, d2 = (a.astype(np.float64) for a in light_vectors(16, 24, (0.4, -0.3, 1.2), config))
    args = ([maps.normal[..., i].astype(np.float64) for i in range(3)], [v[..., i] for i in range(3)],
            [l[..., i] for i in range(3)], maps.specular[..., 0].astype(np.float64),
            maps.roughness[..., 0].astype(np.float64))
    ref = shade(*args, config, d2[..., 0])
    as_t = lambda a: [torch.as_tensor(x) for x in a] if isinstance(a, list) else torch.as_tensor(a)
    out = shade(*(as_t(a) for a in args), config, torch.as_tensor(d2[..., 0]))
    for o, r in zip(out, ref):
        np.testing.assert_allclose(o.numpy(), r, rtol=1e-12)


@pytest.mark.parametrize("config", CONFIGS)
@pytest.mark.parametrize("light_pos", [None, (0.4, -0.3, 1.2)])
def test_torch_matches_numpy_float32(config, light_pos):
    rng = np.random.default_rng(0)
    maps = _random_maps(rng, 16, 24)
    ref = render(maps, light_pos, config)
    geo = FlashGeometry(16, 24, config, light_pos=light_pos)
    out = geo.render(_packed(maps))[0].permute(1, 2, 0).numpy()
    # float32 rounding differs between the numpy and torch kernels (measured: <= 1.4e-5 of the image's peak,
    # <= 4e-5 relative on single pixels of the sharpest highlights); the float64 test above checks the formula.
    tol = dict(rtol=1e-4, atol=1e-5 * float(np.abs(ref).max()))
    np.testing.assert_allclose(out, ref, **tol)
    # A tile rendered with the cropped geometry equals the crop of the whole render.
    tile = geo.render(_packed(maps.crop(3, 5, 8, 8)), 3, 5)[0].permute(1, 2, 0).numpy()
    np.testing.assert_allclose(tile, ref[3:11, 5:13], **tol)


@pytest.mark.parametrize("config", CONFIGS)
def test_gradcheck_float64(config):
    rng = np.random.default_rng(1)
    # Stay away from the guards' kinks (alpha clamp at r ~ 0.03, cosine clamps at grazing angles).
    maps = _random_maps(rng, 3, 4, max_tilt_deg=35.0, rough=(0.3, 0.9))
    geo = FlashGeometry(3, 4, config, light_pos=(0.2, 0.1, 1.5), dtype=torch.float64)
    x = _packed(maps, torch.float64).requires_grad_(True)
    assert torch.autograd.gradcheck(lambda m: render_maps(m, geo.view, geo.light, config, geo.dist2), (x,),
                                    eps=1e-6, atol=1e-5, rtol=1e-4)


def _assert_finite_with_grads(packed: torch.Tensor, config: RenderConfig, light_pos=None):
    x = packed.clone().requires_grad_(True)
    geo = FlashGeometry(x.shape[-2], x.shape[-1], config, light_pos=light_pos)
    img = geo.render(x)
    assert torch.isfinite(img).all()
    img.sum().backward()
    assert torch.isfinite(x.grad).all()


def test_black_maps_finite():
    # All-zero maps: black albedos, roughness 0 and a zero normal vector.
    for config in CONFIGS:
        _assert_finite_with_grads(torch.zeros(1, 8, 6, 6), config.replace(intensity=1e4))


@settings(max_examples=50, deadline=None)
@given(
    rough=st.one_of(st.just(0.0), st.floats(0.0, 1.0)),
    spec=st.floats(0.0, 1.0),
    diffuse=st.one_of(st.just(0.0), st.floats(0.0, 1.0)),
    tilt=st.floats(0.0, 89.0),
    azimuth=st.floats(0.0, 360.0),
    intensity=st.floats(1e-3, 1e4),
    geometry=st.sampled_from(["schlick", "smith"]),
    fresnel=st.sampled_from(["schlick", "none"]),
    falloff=st.booleans(),
    conservation=st.booleans(),
    fov=st.floats(20.0, 120.0),
    light=st.one_of(st.none(), st.tuples(st.floats(-2, 2), st.floats(-2, 2), st.floats(0.1, 3))),
)
def test_finite_values_and_gradients(rough, spec, diffuse, tilt, azimuth, intensity, geometry, fresnel, falloff,
                                     conservation, fov, light):
    config = RenderConfig(fov_deg=fov, intensity=intensity, falloff=falloff, diffuse_conservation=conservation,
                          geometry=geometry, fresnel=fresnel)
    t, a = math.radians(tilt), math.radians(azimuth)
    values = {"diffuse": [diffuse] * 3, "specular": [spec], "roughness": [rough],
              "normal": [math.sin(t) * math.cos(a), math.sin(t) * math.sin(a), math.cos(t)]}
    packed = torch.zeros(1, 8, 5, 5)
    for name in MAP_NAMES:
        packed[:, SLICES[name]] = torch.tensor(values[name], dtype=torch.float32)[None, :, None, None]
    _assert_finite_with_grads(packed, config, light)


@pytest.mark.parametrize("light", [None, (0.3, -0.2, 1.1)])
def test_batched_point_light_vectors_equal_the_numpy_geometry(light):
    from svbrdf.runtime.core.render import camera_position
    from svbrdf.trainer.render import plane_grid, point_light_vectors

    cfg = ZHAO.replace(fov_deg=50.0)
    v_np, l_np, d2_np = light_vectors(12, 20, light, cfg)
    cam = torch.as_tensor(camera_position(cfg))[None]
    lp = cam if light is None else torch.tensor([light])
    v, l, d2 = point_light_vectors(plane_grid(12, 20), cam, lp)
    for got, want in ((v, v_np), (l, l_np), (d2, d2_np)):
        np.testing.assert_allclose(got[0].permute(1, 2, 0).numpy(), want, atol=1e-6)


def test_unpack_gives_each_map_of_the_packed_layout_as_a_view():
    from svbrdf.trainer.render import unpack

    x = torch.arange(2 * 8 * 3 * 4, dtype=torch.float32).reshape(2, 8, 3, 4)
    m = unpack(x)
    for name in ("diffuse", "specular", "roughness"):
        assert torch.equal(m[name], x[:, SLICES[name]]), name
        assert m[name].data_ptr() == x[:, SLICES[name]].data_ptr()  # a view, no copy
    assert torch.equal(torch.cat(m["normal"], dim=1), x[:, SLICES["normal"]])


