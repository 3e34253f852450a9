"""The one SVBRDF map layout used everywhere (runtime numpy, trainer torch, export, benchmark).

Four maps, always in this order when packed into one array of ``N_CHANNELS`` channels:

=========  ==  ============================================================================
name       ch  meaning, range, colour space
=========  ==  ============================================================================
diffuse    3   diffuse albedo rho_d, linear RGB, [0, 1]
specular   1   specular albedo rho_s (grey F0 of Schlick's Fresnel), linear, [0, 1]
roughness  1   perceptual roughness r, [0, 1]; the GGX width is alpha = r**2
normal     3   unit tangent-space normal, components in [-1, 1], z >= 0 (out of the surface)
=========  ==  ============================================================================

Normal axis convention ("OpenGL", green up): +x points to the right of the image, +y points **up the
image** (towards row 0), +z points out of the surface towards the camera. The renderer uses the same
frame, so the normal map is used as is. DirectX-style maps (+y down the image) differ by the sign of y:
see :func:`normal_gl_to_dx` / :func:`normal_dx_to_gl`. On disk a normal is stored as ``(n + 1) / 2``.

Packed layouts:

* numpy (runtime): channel-last ``(H, W, 8)`` float32, or a :class:`Maps` of separate arrays;
* torch (trainer): channel-first ``(B, 8, H, W)``.

Use :data:`SLICES` (or :func:`channel_slice`) rather than bare indices.

Subsets ("maps on demand"): a caller may ask for some of the maps only (:func:`select_maps` validates the
names). A :class:`Maps` then holds ``None`` for the others; a packed array keeps the full 8-channel layout and
the channels of maps that were not computed are NaN (see :mod:`svbrdf.runtime.inference.manifest` for the part graphs).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, Iterable, Iterator, Mapping, Optional, Tuple, Union

import numpy as np

from ..errors import MapError, SvbrdfError
from .relief import AO_STRENGTH, RELIEF_NAMES, Relief
from .relief import with_relief as _with_relief
from .render_config import RenderConfig

#: Map names in packing order.
MAP_NAMES: Tuple[str, ...] = ("diffuse", "specular", "roughness", "normal")
#: Channels per map.
MAP_CHANNELS: Mapping[str, int] = {"diffuse": 3, "specular": 1, "roughness": 1, "normal": 3}


def _slices() -> Dict[str, slice]:
    out, start = {}, 0
    for name in MAP_NAMES:
        out[name] = slice(start, start + MAP_CHANNELS[name])
        start += MAP_CHANNELS[name]
    return out


#: Channel slice of each map in a packed array (channel axis: last in numpy, 1 in torch).
SLICES: Mapping[str, slice] = _slices()
#: Total number of packed channels (8).
N_CHANNELS: int = sum(MAP_CHANNELS.values())
#: Valid value range of each map (after decoding; normals are unit vectors).
MAP_RANGES: Mapping[str, Tuple[float, float]] = {
    "diffuse": (0.0, 1.0),
    "specular": (0.0, 1.0),
    "roughness": (0.0, 1.0),
    "normal": (-1.0, 1.0),
}
#: Colour space of each map as stored in memory (always linear; base colour is sRGB-encoded only on disk).
MAP_COLOUR_SPACES: Mapping[str, str] = {
    "diffuse": "linear",
    "specular": "linear",
    "roughness": "data",
    "normal": "data",
}
#: Normal convention of every in-memory normal in the project.
NORMAL_CONVENTION = "opengl"  # +x right, +y up the image, +z out of the surface

SUPPORTED_NORMAL_CONVENTIONS = ("opengl", "dx")

#: Other accepted names of a map: the file role of the diffuse map in a texture set (``<name>_basecolor.png``).
MAP_ALIASES: Mapping[str, str] = {"basecolor": "diffuse"}


def select_maps(names: Union[None, str, Iterable[str]] = None) -> Tuple[str, ...]:
    """Validate a request for some of the maps.

    Args:
        names: map names (or :data:`MAP_ALIASES`), in any order, duplicates allowed; one name as a string;
            ``None`` = all maps.

    Returns:
        The distinct names in :data:`MAP_NAMES` order (:data:`MAP_NAMES` itself for all four).

    Raises:
        SvbrdfError: an unknown name (the message lists the valid ones) or an empty request.
    """
    if names is None:
        return MAP_NAMES
    names = [names] if isinstance(names, str) else list(names)
    unknown = [n for n in names if n not in MAP_NAMES and n not in MAP_ALIASES]
    if unknown:
        aliases = ", ".join(f"{a} (= {n})" for a, n in MAP_ALIASES.items())
        raise SvbrdfError(f"unknown map name {', '.join(map(repr, unknown))}; valid names: "
                          f"{', '.join(MAP_NAMES)}; aliases: {aliases}")
    want = {MAP_ALIASES.get(n, n) for n in names}
    if not want:
        raise SvbrdfError(f"no maps requested; valid names: {', '.join(MAP_NAMES)}")
    return tuple(n for n in MAP_NAMES if n in want)


def channel_slice(name: str) -> slice:
    """Channel slice of map ``name`` in a packed array."""
    try:
        return SLICES[name]
    except KeyError:
        raise KeyError(f"unknown map {name!r}; expected one of {', '.join(MAP_NAMES)}") from None


def normal_gl_to_dx(normal: np.ndarray, axis: int = -1) -> np.ndarray:
    """Convert normals from OpenGL (+y up) to DirectX (+y down): flips the y component.

    Works on unit vectors in [-1, 1] along ``axis`` (numpy or torch). The conversion is its own inverse.
    """
    out = normal.copy() if isinstance(normal, np.ndarray) else normal.clone()
    idx = [slice(None)] * out.ndim
    idx[axis] = 1
    out[tuple(idx)] = -out[tuple(idx)]
    return out


normal_dx_to_gl = normal_gl_to_dx


def _sum_squares(a: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 1): ``x^2 + y^2 + z^2`` added in the order of ``np.sum`` over the last axis (the same bits),
    by channel: a reduction over an axis of 3 is several times slower. The unit normals here, the renderer's view and
    light vectors (:func:`svbrdf.runtime.core.render.light_vectors`)."""
    x, y, z = a[..., 0:1], a[..., 1:2], a[..., 2:3]
    out = x * x
    out += y * y
    out += z * z
    return out


def normalize_normals(normal: np.ndarray, eps: float = 1e-8) -> np.ndarray:
    """Unit-length normals (H, W, 3) with z >= 0; a zero vector becomes (0, 0, 1)."""
    n = np.array(normal, dtype=np.float32)
    np.maximum(n[..., 2], 0.0, out=n[..., 2])
    norm = _sum_squares(n)
    np.sqrt(norm, out=norm)
    flat = norm[..., 0] < eps
    if flat.any():
        n[flat] = (0.0, 0.0, 1.0)
        norm[flat] = 1.0
    n /= norm
    return n


def encode_normal(normal: np.ndarray) -> np.ndarray:
    """Unit normals in [-1, 1] -> storage encoding (n + 1) / 2 in [0, 1]."""
    return np.clip((normal + 1.0) * 0.5, 0.0, 1.0)


def decode_normal(encoded: np.ndarray) -> np.ndarray:
    """Storage encoding (n + 1) / 2 in [0, 1] -> unit normals in [-1, 1]."""
    return normalize_normals(np.asarray(encoded, dtype=np.float32) * 2.0 - 1.0)


@dataclass
class Maps:
    """An SVBRDF texture set as numpy arrays, channel-last, float32: all four maps, or a subset of them.

    Attributes:
        diffuse: (H, W, 3) linear diffuse albedo in [0, 1].
        specular: (H, W, 1) linear grey specular albedo (F0) in [0, 1].
        roughness: (H, W, 1) perceptual roughness r in [0, 1]; alpha = r**2.
        normal: (H, W, 3) unit normals, OpenGL convention (see module docstring).
        meta: free-form provenance (source file, timings, ...), copied into sidecars.
        render_config: the :class:`~svbrdf.runtime.core.render.RenderConfig` the maps were estimated for (set by
            :func:`~svbrdf.runtime.inference.pipeline.estimate` and the CLIs; ``None`` = unknown). Writers describe it in
            the sidecar and the ``--target`` conversions use its diffuse weighting (``ZHAO`` when ``None``).
        relief: the height map and ambient occlusion derived from the normal map
            (:class:`~svbrdf.runtime.core.relief.Relief`, made on demand by
            :func:`~svbrdf.runtime.core.relief.with_relief`), written by every writer when present; ``None`` = none.
            It must be the maps' size; :meth:`clipped` keeps it, the other copies (crop, subset) drop it.

    A map that was not computed is ``None`` (at least one is present; :attr:`names` lists them). What needs
    every map (:meth:`pack`, rendering, the relit panel, the ``--target`` conversions) checks with
    :meth:`require`.

    A plain value: the relief is made by :func:`~svbrdf.runtime.core.relief.with_relief` and a set is written by
    :func:`~svbrdf.runtime.outputs.texture_set.write_texture_set` (or a ``--target``'s
    :func:`~svbrdf.runtime.outputs.targets.write_target`).
    """

    diffuse: Optional[np.ndarray] = None
    specular: Optional[np.ndarray] = None
    roughness: Optional[np.ndarray] = None
    normal: Optional[np.ndarray] = None
    meta: dict = field(default_factory=dict)
    render_config: Optional["RenderConfig"] = None
    relief: Optional[Relief] = None

    def __post_init__(self) -> None:
        shape = None
        for name in MAP_NAMES:
            if getattr(self, name) is None:
                continue
            arr = np.asarray(getattr(self, name), dtype=np.float32)
            if arr.ndim == 2:
                arr = arr[..., None]
            if arr.ndim != 3 or arr.shape[-1] != MAP_CHANNELS[name]:
                raise MapError(f"map {name!r} must be (H, W, {MAP_CHANNELS[name]}), got {arr.shape}")
            if shape is None:
                shape = arr.shape[:2]
            elif arr.shape[:2] != shape:
                raise MapError(f"map {name!r} is {arr.shape[1]}x{arr.shape[0]} px but the texture set's "
                               f"{self.names[0]} map is {shape[1]}x{shape[0]} px")
            setattr(self, name, arr)
        if shape is None:
            raise ValueError(f"a texture set needs at least one of the maps {', '.join(MAP_NAMES)}")
        if self.render_config is not None:
            if not isinstance(self.render_config, RenderConfig):
                raise TypeError(f"render_config must be a RenderConfig or None, "
                                f"got {type(self.render_config).__name__}")
        if self.relief is not None:
            if not isinstance(self.relief, Relief):
                raise TypeError(f"relief must be a Relief or None, got {type(self.relief).__name__}")
            if tuple(self.relief.shape) != tuple(shape):
                raise MapError(f"the relief maps are {self.relief.shape[1]}x{self.relief.shape[0]} px but the "
                                  f"texture set is {shape[1]}x{shape[0]} px")

    @property
    def names(self) -> Tuple[str, ...]:
        """Names of the maps present, in :data:`MAP_NAMES` order."""
        return tuple(n for n in MAP_NAMES if getattr(self, n) is not None)

    @property
    def complete(self) -> bool:
        """True when all four maps are present."""
        return self.names == MAP_NAMES

    def require(self, names: Iterable[str] = MAP_NAMES, what: str = "this operation") -> None:
        """Raise ``ValueError`` (one line naming ``what``) unless every map in ``names`` is present."""
        missing = [n for n in MAP_NAMES if n in set(names) and getattr(self, n) is None]
        if missing:
            raise ValueError(f"{what} needs the {', '.join(missing)} map(s); this texture set has only "
                             f"{', '.join(self.names)}")

    @property
    def shape(self) -> Tuple[int, int]:
        """(H, W) of every map."""
        return getattr(self, self.names[0]).shape[:2]

    def items(self) -> Iterator[Tuple[str, np.ndarray]]:
        """(name, array) of the maps present, in :data:`MAP_NAMES` order."""
        for name in self.names:
            yield name, getattr(self, name)

    def pack(self) -> np.ndarray:
        """(H, W, 8) float32 array in :data:`MAP_NAMES` order (needs all four maps)."""
        self.require(what="pack()")
        return np.concatenate([getattr(self, n) for n in MAP_NAMES], axis=-1)

    @classmethod
    def unpack(cls, packed: np.ndarray, meta: dict | None = None,
               maps: Union[None, str, Iterable[str]] = None,
               render_config: Optional["RenderConfig"] = None) -> "Maps":
        """Inverse of :meth:`pack` for a channel-last (H, W, 8) array; ``maps`` keeps only those maps
        (:func:`select_maps`; default all), e.g. the channels a part graph computed."""
        packed = np.asarray(packed, dtype=np.float32)
        if packed.ndim != 3 or packed.shape[-1] != N_CHANNELS:
            raise ValueError(f"packed maps must be (H, W, {N_CHANNELS}), got {packed.shape}")
        return cls(**{n: packed[..., SLICES[n]] for n in select_maps(maps)}, meta=dict(meta or {}),
                   render_config=render_config)

    def subset(self, maps: Union[str, Iterable[str]]) -> "Maps":
        """The same set restricted to ``maps`` (:func:`select_maps`), which must be present; meta copied."""
        names = select_maps(maps)
        self.require(names, "subset()")
        return self._with({n: getattr(self, n) for n in names})

    def crop(self, y0: int, x0: int, h: int, w: int) -> "Maps":
        return self._with({n: a[y0:y0 + h, x0:x0 + w] for n, a in self.items()})

    def clipped(self) -> "Maps":
        """Copy with every map clipped to its valid range and unit normals (the relief kept)."""
        out = {n: np.clip(a, *MAP_RANGES[n]) for n, a in self.items()}
        if "normal" in out:
            out["normal"] = normalize_normals(out["normal"])
        return self._with(out, relief=self.relief)

    def with_relief(self, *, tileable: bool = False, maps: Iterable[str] = RELIEF_NAMES,
                    ao_strength: float = AO_STRENGTH) -> "Maps":
        """Compatibility call: ``with_relief(self, ...)`` of :mod:`svbrdf.runtime.core.relief` (its doc gives the
        arguments), which new code calls."""
        return _with_relief(self, tileable=tileable, maps=maps, ao_strength=ao_strength)

    def _with(self, arrays: Mapping[str, np.ndarray], relief: Optional[Relief] = None) -> "Maps":
        """A set of these arrays with a copy of this set's meta and its render config (and ``relief``)."""
        return Maps(**arrays, meta=dict(self.meta), render_config=self.render_config, relief=relief)


__all__ = [
    "MAP_NAMES", "MAP_CHANNELS", "SLICES", "N_CHANNELS", "MAP_RANGES", "MAP_COLOUR_SPACES", "NORMAL_CONVENTION",
    "MAP_ALIASES", "RELIEF_NAMES", "Maps", "select_maps", "channel_slice", "normal_gl_to_dx", "normal_dx_to_gl", "normalize_normals",
    "encode_normal",
    "decode_normal",
]
