"""Our Cook-Torrance parameters <-> the material models of the export targets, written once.

Our model (:mod:`svbrdf.runtime.core.render`): GGX with ``alpha = r**2``, Schlick Fresnel with a grey ``F0 = rho_s``
(the specular albedo) and ``F90 = 1``, and a Lambert lobe ``w_d rho_d / pi`` with ``w_d = 1`` (Zhao et al.
2020, the project default) or ``w_d = 1 - rho_s`` (Deschaintre et al. 2018, ``diffuse_conservation=True``).

Every target below uses GGX with ``alpha = roughness**2`` too, so roughness is copied unchanged everywhere
except where a target stores smoothness. What differs is how F0 is spelled and how the diffuse lobe is weighted:

===========================  =====================================================  ============================
target model                 F0 of a dielectric / diffuse weight                    function here
===========================  =====================================================  ============================
glTF + KHR_materials_        ``min(0.04 specularColor, 1) specular`` (ior 1.5);     :func:`to_khr_specular`,
specular [KHR-spec]          base weighted by ``1 - max(F(v.h))``                   :func:`to_weighted_base`
UsdPreviewSurface,           ``specularColor``; diffuse times ``1 - F(v.h)``        :func:`to_weighted_base`
specular workflow [USD]
Unity specular setup,        ``specular`` RGB; albedo times ``1 - max(specular)``   :func:`to_weighted_base`,
KHR spec-gloss [SG]          (smoothness ``1 - r`` in Unity)                        :func:`roughness_to_smoothness`
MaterialX standard_surface   ``((ior - 1)/(ior + 1))^2``, base under an albedo-     :func:`f0_to_ior`,
[MTLX]                       scaled specular layer (about ``1 - F0``)               :func:`to_weighted_base`
glTF core metal-rough,       ``lerp(0.04, base, metallic)``,                        :func:`specgloss_to_metalrough`
Unreal [GLTF]                ``c_diff = base (1 - 0.04)(1 - metallic)``
Blender Principled BSDF      ``0.08 Specular``; diffuse ``(1 - metallic) base``,    :func:`to_principled_base`,
(2.8-3.x) [BL]               not weighted by the Fresnel term                       :func:`to_principled_specular`
===========================  =====================================================  ============================

The ``1 - F`` weighting of those models is evaluated here at normal incidence (``F = F0``), which is exact
for our flash geometry at the image centre (``v = l``, so ``v.h = 1``) and close elsewhere (``v.h`` near 1
for every light near the camera). Model differences that no parameter can absorb (Smith height-correlated vs
Smith-Schlick G, exact dielectric vs Schlick Fresnel) are listed in ``docs/targets.md``.

Sources:

* [KHR-spec] KhronosGroup/glTF, ``extensions/2.0/Khronos/KHR_materials_specular/README.md`` (ratified):
  ``dielectric_f0 = min(0.04 specularColor, 1) specular``, ``dielectric_f90 = specular``, diffuse weighted by
  ``1 - max_value(dielectric_fresnel)``, ``specularColorFactor`` may exceed 1, ``specularColorTexture`` is sRGB.
* [SG] KhronosGroup/glTF, archived ``KHR_materials_pbrSpecularGlossiness`` README and its
  ``examples/convert-between-workflows`` (the conversion re-used by Babylon.js, three.js and glTF-Transform):
  perceived brightness ``sqrt(0.299 r^2 + 0.587 g^2 + 0.114 b^2)``, ``solveMetallic``, the metallic-squared
  blend of the two base-colour estimates, and the inverse ``specular = lerp(0.04, base, m)``,
  ``diffuse = base (1 - 0.04)(1 - m) / (1 - max(specular))``.
* [USD] OpenUSD ``usdImaging/plugin/usdShaders/shaders/previewSurface.glslfx`` (reference implementation of the
  UsdPreviewSurface spec): ``alpha = roughness^2``, Smith-Schlick ``k = alpha / 2``, ``F0 = specularColor``,
  ``F90 = 1``, ``d *= 1 - mix(F0, F90, fresnel)``.
* [MTLX] MaterialX ``libraries/bxdf/standard_surface.mtlx`` (``dielectric_bsdf`` with ``specular_IOR``) and the
  Fresnel reflectance at normal incidence ``F0 = ((n - 1) / (n + 1))^2``.
* [GLTF] glTF 2.0 specification, Appendix B (``alpha = roughness^2``, ``f0 = lerp(0.04, baseColor, metallic)``).
* [BL] Blender 3.4 manual, *Principled BSDF* (Specular is the facing reflectivity over the 0-8 % range, i.e.
  ``Specular = F0 / 0.08``; Roughness squared into the GGX alpha; distribution GGX or Multiscatter GGX). Checked in
  Cycles 3.4 itself (``tests/runtime/outputs/test_blender.py``, ``docs/targets.md`` *Blender*): a set written with
  these conversions renders as :func:`svbrdf.runtime.core.render.render` renders our maps (sRGB RMSE 0.0004-0.004),
  the diffuse lobe is ``base / pi`` not weighted by the Fresnel term, the Fresnel term blends F0 to 1; what is
  left (Smith G, Burley's diffuse factor, Cycles' shadow-terminator term) no parameter can absorb.

All arrays are linear, channel-last numpy; scalars broadcast.
"""

from __future__ import annotations

from typing import Tuple

import numpy as np

from ..core.render import RenderConfig, ZHAO

#: F0 of glTF's default dielectric (ior 1.5), the constant of the metal-rough and KHR_materials_specular models.
DIELECTRIC_F0 = 0.04
_EPS = 1e-6


def diffuse_weight(specular: np.ndarray, config: RenderConfig = ZHAO) -> np.ndarray:
    """Our diffuse weight ``w_d``: 1, or ``1 - rho_s`` with ``config.diffuse_conservation``.

    Args:
        specular: rho_s, any shape, linear in [0, 1].
        config: the renderer settings the maps were estimated with.

    Returns:
        float32 array of the shape of ``specular``.
    """
    s = np.asarray(specular, dtype=np.float32)
    return (1.0 - s) if config.diffuse_conservation else np.ones_like(s)


def to_weighted_base(diffuse: np.ndarray, specular: np.ndarray, config: RenderConfig = ZHAO) -> np.ndarray:
    """Base colour of a model whose diffuse lobe is weighted by ``1 - F0`` (KHR specular, USD, Unity, spec-gloss).

    Matches ``w_d rho_d = (1 - rho_s) base``, i.e. ``base = rho_d w_d / (1 - rho_s)``: with diffuse conservation
    this is ``rho_d`` itself; in the Zhao convention the base colour is brighter by ``1 / (1 - rho_s)``.

    Args:
        diffuse: rho_d (H, W, 3), linear in [0, 1].
        specular: rho_s (H, W, 1), linear in [0, 1].
        config: renderer settings of the maps (``diffuse_conservation`` selects ``w_d``).

    Returns:
        (H, W, 3) float32 linear base colour, clipped to [0, 1] (the only loss, for very bright diffuse
        albedos under a strong specular).
    """
    s = np.asarray(specular, dtype=np.float32)
    base = np.asarray(diffuse, dtype=np.float32) * diffuse_weight(s, config) / np.maximum(1.0 - s, _EPS)
    return np.clip(base, 0.0, 1.0).astype(np.float32)


def from_weighted_base(base: np.ndarray, specular: np.ndarray, config: RenderConfig = ZHAO) -> np.ndarray:
    """Inverse of :func:`to_weighted_base`: ``rho_d = base (1 - rho_s) / w_d``. Shapes as there."""
    s = np.asarray(specular, dtype=np.float32)
    return (np.asarray(base, dtype=np.float32) * (1.0 - s) / np.maximum(diffuse_weight(s, config), _EPS)).astype(
        np.float32)


def f0_to_ior(f0: np.ndarray) -> np.ndarray:
    """Index of refraction whose normal-incidence Fresnel reflectance is ``f0``: ``(1 + sqrt f0) / (1 - sqrt f0)``.

    Args:
        f0: reflectance at normal incidence, in [0, 1) (1 maps to an infinite ior).

    Returns:
        float64 ior >= 1 (inverse of :func:`ior_to_f0` on ior >= 1).
    """
    r = np.sqrt(np.asarray(f0, dtype=np.float64))
    return (1.0 + r) / (1.0 - r)


def ior_to_f0(ior: np.ndarray) -> np.ndarray:
    """Fresnel reflectance at normal incidence from air, ``((ior - 1) / (ior + 1))^2`` (0 and inf give 1)."""
    n = np.asarray(ior, dtype=np.float64)
    return ((n - 1.0) / (n + 1.0)) ** 2


def to_khr_specular(specular: np.ndarray) -> Tuple[float, np.ndarray]:
    """Our rho_s as KHR_materials_specular ``specularColorFactor`` x ``specularColorTexture`` (ior 1.5, specular 1).

    ``0.04 * factor * texture = rho_s``: the factor carries the scale (it may exceed 1 [KHR-spec]) so the
    texture uses its whole [0, 1] range, and ``specular = 1`` keeps ``F90 = 1`` as in our Schlick term. The
    product never reaches the spec's clamp at 1 because ``rho_s <= 1``.

    Args:
        specular: rho_s (H, W, 1) or any shape, linear in [0, 1].

    Returns:
        ``(factor, texture)``: the grey factor (float, ``max(rho_s) / 0.04``; 0 for an all-black map) and the
        texture ``rho_s / max(rho_s)`` (float32, linear, same shape; write it sRGB-encoded).
    """
    s = np.clip(np.asarray(specular, dtype=np.float32), 0.0, 1.0)
    peak = float(s.max()) if s.size else 0.0
    if peak <= 0.0:
        return 0.0, np.zeros_like(s)
    return peak / DIELECTRIC_F0, (s / peak).astype(np.float32)


def from_khr_specular(factor: float, texture: np.ndarray, specular: float = 1.0) -> np.ndarray:
    """Dielectric F0 of KHR_materials_specular at ior 1.5: ``min(0.04 factor texture, 1) specular`` [KHR-spec]."""
    return (np.minimum(DIELECTRIC_F0 * factor * np.asarray(texture, dtype=np.float32), 1.0) * specular).astype(
        np.float32)


def perceived_brightness(rgb: np.ndarray) -> np.ndarray:
    """``sqrt(0.299 r^2 + 0.587 g^2 + 0.114 b^2)`` of (..., 3) linear colour [SG]; (..., 1) is taken as grey."""
    c = np.asarray(rgb, dtype=np.float32)
    if c.shape[-1] == 1:
        return c[..., 0]
    return np.sqrt(0.299 * c[..., 0] ** 2 + 0.587 * c[..., 1] ** 2 + 0.114 * c[..., 2] ** 2)


def specgloss_to_metalrough(diffuse: np.ndarray, specular: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Khronos specular-glossiness -> metallic-roughness conversion [SG] (roughness is unchanged).

    With ``d``, ``s`` the perceived brightness of the spec-gloss diffuse and specular colours and
    ``k = 1 - max(specular)``, the metallic value solves ``a m^2 + b m + c = 0`` with ``a = 0.04``,
    ``b = d k / (1 - 0.04) + s - 2 (0.04)``, ``c = 0.04 - s`` (``m = 0`` when ``s < 0.04``), clipped to [0, 1].
    The base colour blends ``diffuse k / ((1 - 0.04)(1 - m))`` and ``(specular - 0.04 (1 - m)) / m`` by ``m^2``
    and is clipped to [0, 1].

    Args:
        diffuse: spec-gloss diffuse colour (H, W, 3), linear; from our maps use :func:`to_weighted_base`
            (the spec-gloss diffuse lobe is ``diffuse (1 - max(specular)) / pi``).
        specular: spec-gloss specular colour (H, W, 3) or grey (H, W, 1), linear F0.

    Returns:
        ``(base_color (H, W, 3), metallic (H, W, 1))``, float32, linear, in [0, 1].
    """
    dif = np.asarray(diffuse, dtype=np.float64)
    spec = np.asarray(specular, dtype=np.float64)
    if spec.shape[-1] == 1:
        spec = np.repeat(spec, 3, axis=-1)
    k = 1.0 - spec.max(axis=-1, keepdims=True)
    d = perceived_brightness(dif)[..., None].astype(np.float64)
    s = perceived_brightness(spec)[..., None].astype(np.float64)
    a = DIELECTRIC_F0
    b = d * k / (1.0 - a) + s - 2.0 * a
    c = a - s
    root = (-b + np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))) / (2.0 * a)
    metallic = np.where(s < a, 0.0, np.clip(root, 0.0, 1.0))
    from_diffuse = dif * k / ((1.0 - a) * np.maximum(1.0 - metallic, _EPS))
    from_specular = (spec - a * (1.0 - metallic)) / np.maximum(metallic, _EPS)
    t = metallic * metallic
    base = np.clip(from_diffuse * (1.0 - t) + from_specular * t, 0.0, 1.0)
    return base.astype(np.float32), metallic.astype(np.float32)


def metalrough_to_specgloss(base_color: np.ndarray, metallic: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Inverse Khronos conversion [SG]: ``specular = lerp(0.04, base, m)``,
    ``diffuse = base (1 - 0.04)(1 - m) / (1 - max(specular))`` (0 where ``max(specular)`` is 1).

    Args:
        base_color: (H, W, 3) linear in [0, 1].
        metallic: (H, W, 1) in [0, 1].

    Returns:
        ``(diffuse (H, W, 3), specular (H, W, 3))`` float32, linear.
    """
    base = np.asarray(base_color, dtype=np.float64)
    m = np.asarray(metallic, dtype=np.float64)
    spec = DIELECTRIC_F0 * (1.0 - m) + base * m
    k = 1.0 - spec.max(axis=-1, keepdims=True)
    dif = np.where(k > _EPS, base * (1.0 - DIELECTRIC_F0) * (1.0 - m) / np.maximum(k, _EPS), 0.0)
    return dif.astype(np.float32), spec.astype(np.float32)


def roughness_to_smoothness(roughness: np.ndarray) -> np.ndarray:
    """Unity smoothness (and glTF spec-gloss glossiness) ``1 - r``; both square ``1 - smoothness`` to get alpha."""
    return (1.0 - np.asarray(roughness, dtype=np.float32)).astype(np.float32)


#: The map is its own inverse: ``r = 1 - smoothness``.
smoothness_to_roughness = roughness_to_smoothness


#: F0 per unit of the Principled BSDF's ``Specular`` input (Blender 2.8-3.x; 4.x: ``Specular IOR Level`` at IOR 1.5):
#: ``F0 = 0.08 Specular``, so the default 0.5 is the 4 % of a dielectric of index 1.5 [BL].
PRINCIPLED_F0_PER_SPECULAR = 0.08


def to_principled_base(diffuse: np.ndarray, specular: np.ndarray, config: RenderConfig = ZHAO) -> np.ndarray:
    """Base colour of Blender's Principled BSDF (Metallic 0) for our maps: ``rho_d w_d``.

    The Principled BSDF of Blender 2.8-3.x adds its diffuse lobe ``base / pi`` (times a Disney retro-reflection
    factor that is 1 at normal incidence) to the specular lobe without weighting it by the Fresnel term, as our
    Zhao convention does; so the base colour is our diffuse albedo itself (Zhao) or ``rho_d (1 - rho_s)``
    (Deschaintre, ``diffuse_conservation``). Inverse: :func:`from_principled_base`.

    Args:
        diffuse: rho_d (H, W, 3), linear in [0, 1].
        specular: rho_s (H, W, 1), linear in [0, 1].
        config: renderer settings of the maps (``diffuse_conservation`` selects ``w_d``).

    Returns:
        (H, W, 3) float32 linear base colour in [0, 1] (write it sRGB-encoded).
    """
    base = np.asarray(diffuse, dtype=np.float32) * diffuse_weight(specular, config)
    return np.clip(base, 0.0, 1.0).astype(np.float32)


def from_principled_base(base: np.ndarray, specular: np.ndarray, config: RenderConfig = ZHAO) -> np.ndarray:
    """Inverse of :func:`to_principled_base`: ``rho_d = base / w_d`` (0 where ``w_d`` is 0). Shapes as there."""
    w = diffuse_weight(specular, config)
    return np.where(w > _EPS, np.asarray(base, dtype=np.float32) / np.maximum(w, _EPS), 0.0).astype(np.float32)


def to_principled_specular(specular: np.ndarray) -> Tuple[float, np.ndarray]:
    """Our rho_s as the Principled BSDF's ``Specular`` input, ``rho_s / 0.08``, stored as a texture and a scale.

    A texture holds values in [0, 1] but ``Specular`` goes past 1 for F0 above 0.08 (Cycles takes any value: F0 =
    0.08 Specular, up to 1 at 12.5). So the texture is ``Specular / scale`` with ``scale = max(1, max Specular)``:
    a set whose F0 stays at or below 0.08 (most dielectrics) has ``scale = 1`` and its texture *is* the input
    (Node Wrangler's *Principled Setup* wires it as is); above, the material multiplies the texture by ``scale``.

    Args:
        specular: rho_s (H, W, 1) or any shape, linear in [0, 1].

    Returns:
        ``(scale, texture)``: the float ``scale >= 1`` and the float32 texture in [0, 1], same shape; the input is
        ``scale * texture`` (:func:`from_principled_specular`).
    """
    value = np.clip(np.asarray(specular, dtype=np.float32), 0.0, 1.0) / np.float32(PRINCIPLED_F0_PER_SPECULAR)
    scale = max(1.0, float(value.max()) if value.size else 1.0)
    return scale, (value / np.float32(scale)).astype(np.float32)


def from_principled_specular(texture: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """F0 of the Principled BSDF whose ``Specular`` input is ``scale * texture``: ``0.08 scale texture`` (float32)."""
    return (np.asarray(texture, dtype=np.float32) * np.float32(scale * PRINCIPLED_F0_PER_SPECULAR)).astype(np.float32)


__all__ = [
    "DIELECTRIC_F0", "diffuse_weight", "to_weighted_base", "from_weighted_base", "f0_to_ior", "ior_to_f0",
    "to_khr_specular", "from_khr_specular", "perceived_brightness", "specgloss_to_metalrough",
    "metalrough_to_specgloss", "roughness_to_smoothness", "smoothness_to_roughness", "PRINCIPLED_F0_PER_SPECULAR",
    "to_principled_base", "from_principled_base", "to_principled_specular", "from_principled_specular",
]
