"""The map layout: packing, normal conventions and encoding, validation."""

import numpy as np
import pytest

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.core.maps import (
    MAP_ALIASES, MAP_CHANNELS, MAP_NAMES, N_CHANNELS, SLICES, Maps, channel_slice, decode_normal, encode_normal,
    normal_dx_to_gl, normal_gl_to_dx, normalize_normals, select_maps,
)
from svbrdf.runtime.core.render import DESCHAINTRE


def _random_maps(h=5, w=7, seed=0):
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(h, w, 3))
    n[..., 2] = np.abs(n[..., 2])
    return Maps(
        diffuse=rng.random((h, w, 3)), specular=rng.random((h, w, 1)), roughness=rng.random((h, w)),
        normal=normalize_normals(n), meta={"k": 1},
    )


def test_layout():
    assert MAP_NAMES == ("diffuse", "specular", "roughness", "normal") and N_CHANNELS == 8
    covered = sorted(i for n in MAP_NAMES for i in range(8)[SLICES[n]])
    assert covered == list(range(8))
    assert all(SLICES[n].stop - SLICES[n].start == MAP_CHANNELS[n] for n in MAP_NAMES)
    with pytest.raises(KeyError, match="unknown map 'albedo'"):
        channel_slice("albedo")


def test_pack_unpack_round_trip():
    m = _random_maps()
    assert m.roughness.shape == (5, 7, 1) and m.diffuse.dtype == np.float32  # (H, W) promoted, float32
    packed = m.pack()
    assert packed.shape == (5, 7, 8) and packed.dtype == np.float32
    for name, arr in m.items():
        np.testing.assert_array_equal(packed[..., SLICES[name]], arr)
    back = Maps.unpack(packed, meta=m.meta)
    for name, arr in m.items():
        np.testing.assert_array_equal(getattr(back, name), arr)
    assert back.meta == {"k": 1} and back.meta is not m.meta
    np.testing.assert_array_equal(back.pack(), packed)


def test_crop_and_clipped():
    m = _random_maps()
    c = m.crop(1, 2, 3, 4)
    assert c.shape == (3, 4)
    np.testing.assert_array_equal(c.normal, m.normal[1:4, 2:6])
    wild = Maps(m.diffuse * 3 - 1, m.specular + 2, -m.roughness, m.normal * 5)
    cl = wild.clipped()
    assert cl.diffuse.min() >= 0 and cl.diffuse.max() <= 1 and cl.specular.max() == 1 and cl.roughness.max() <= 0
    np.testing.assert_allclose(np.linalg.norm(cl.normal, axis=-1), 1.0, atol=1e-6)


def test_gl_dx_involution():
    n = _random_maps().normal
    dx = normal_gl_to_dx(n)
    np.testing.assert_array_equal(dx[..., 1], -n[..., 1])
    np.testing.assert_array_equal(dx[..., [0, 2]], n[..., [0, 2]])
    np.testing.assert_array_equal(normal_dx_to_gl(dx), n)
    assert not np.shares_memory(dx, n)
    # Channel-first layout (axis=0), e.g. a (3, H, W) array.
    chw = np.moveaxis(n, -1, 0)
    np.testing.assert_array_equal(np.moveaxis(normal_gl_to_dx(chw, axis=0), 0, -1), dx)


def test_encode_decode_normal():
    n = _random_maps().normal
    enc = encode_normal(n)
    assert enc.min() >= 0 and enc.max() <= 1
    np.testing.assert_allclose(enc, (n + 1) / 2, atol=1e-7)
    np.testing.assert_allclose(decode_normal(enc), n, atol=1e-6)
    # 8-bit storage: decoding re-normalises, so the result stays unit length.
    dec8 = decode_normal(np.round(enc * 255) / 255)
    np.testing.assert_allclose(np.linalg.norm(dec8, axis=-1), 1.0, atol=1e-6)
    assert np.abs(dec8 - n).max() < 0.02


def test_normalize_normals_edge_cases():
    n = np.array([[[0.0, 0.0, 0.0], [3.0, 0.0, -4.0], [0.0, 0.0, 2.0]]], np.float32)
    out = normalize_normals(n)
    np.testing.assert_allclose(out, [[[0, 0, 1], [1, 0, 0], [0, 0, 1]]], atol=1e-7)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        (dict(diffuse=np.zeros((4, 4, 1))), r"'diffuse' must be \(H, W, 3\)"),
        (dict(specular=np.zeros((4, 4, 3))), r"'specular' must be \(H, W, 1\)"),
        (dict(normal=np.zeros((4, 4))), r"'normal' must be \(H, W, 3\)"),
        (dict(roughness=np.zeros((4, 5, 1))), r"'roughness' is 5x4 px but the texture set's diffuse map is 4x4 px"),
        (dict(diffuse=np.zeros((2, 4, 4, 3))), r"'diffuse' must be"),
    ],
)
def test_maps_validation(kwargs, match):
    base = dict(diffuse=np.zeros((4, 4, 3)), specular=np.zeros((4, 4, 1)), roughness=np.zeros((4, 4, 1)),
                normal=np.zeros((4, 4, 3)))
    with pytest.raises(ValueError, match=match):
        Maps(**{**base, **kwargs})


def test_unpack_validation():
    with pytest.raises(ValueError, match=r"packed maps must be \(H, W, 8\)"):
        Maps.unpack(np.zeros((4, 4, 7)))
    with pytest.raises(ValueError, match="packed maps"):
        Maps.unpack(np.zeros((8, 4, 4)))


def test_maps_is_a_plain_value():
    # Writing is runtime.outputs' (write_texture_set), the relief core.relief's (with_relief, the method a
    # one-line compatibility call of it, tests/runtime/core/test_relief.py).
    assert not hasattr(Maps, "save")


# ------------------------------------------------------------------------------------------ subsets
def test_select_maps_orders_dedupes_and_resolves_aliases():
    assert select_maps(None) == MAP_NAMES
    assert select_maps(["normal", "diffuse", "normal"]) == ("diffuse", "normal")  # packing order, once
    assert select_maps("roughness") == ("roughness",)  # one name as a string, not its letters
    assert select_maps(["basecolor"]) == ("diffuse",) and MAP_ALIASES["basecolor"] == "diffuse"
    with pytest.raises(SvbrdfError) as err:
        select_maps(["normal", "albedo", "height"])
    msg = str(err.value)
    assert "\n" not in msg and "'albedo', 'height'" in msg and all(n in msg for n in MAP_NAMES)
    with pytest.raises(SvbrdfError, match="no maps requested"):
        select_maps([])


def test_a_subset_holds_only_its_maps():
    full = _random_maps()
    part = full.subset(["normal", "diffuse"])
    assert part.names == ("diffuse", "normal") and not part.complete and full.complete
    assert part.specular is None and part.roughness is None and part.shape == (5, 7)
    assert [n for n, _ in part.items()] == ["diffuse", "normal"] and part.meta == full.meta
    np.testing.assert_array_equal(part.normal, full.normal)
    with pytest.raises(ValueError, match=r"pack\(\) needs the specular, roughness map\(s\); .* only diffuse, normal"):
        part.pack()
    with pytest.raises(ValueError, match="needs the roughness"):
        part.subset("roughness")
    wild = Maps(roughness=np.full((2, 3), 4.0)).clipped()  # no normal to renormalise
    assert wild.names == ("roughness",) and wild.roughness.max() == 1.0 and wild.crop(0, 1, 2, 2).shape == (2, 2)
    with pytest.raises(ValueError, match="at least one"):
        Maps(meta={"k": 1})


def test_unpack_a_subset_ignores_the_other_channels():
    packed = _random_maps().pack()
    packed[..., SLICES["diffuse"]] = np.nan  # what a part graph leaves in the maps it does not compute
    packed[..., SLICES["specular"]] = np.nan
    m = Maps.unpack(packed, maps=("roughness", "normal"))
    assert m.names == ("roughness", "normal") and np.isfinite(m.normal).all()
    np.testing.assert_array_equal(m.roughness, packed[..., SLICES["roughness"]])


def test_render_config_is_a_typed_field():
    maps = _random_maps()
    assert maps.render_config is None
    with pytest.raises(TypeError, match="RenderConfig"):
        Maps(maps.diffuse, render_config=DESCHAINTRE.to_dict())
    typed = Maps(maps.diffuse, maps.specular, maps.roughness, maps.normal, render_config=DESCHAINTRE)
    assert typed.clipped().render_config is DESCHAINTRE and typed.subset("normal").render_config is DESCHAINTRE
    assert typed.crop(0, 0, 2, 2).render_config is DESCHAINTRE
    assert Maps.unpack(typed.pack(), render_config=DESCHAINTRE).render_config is DESCHAINTRE
