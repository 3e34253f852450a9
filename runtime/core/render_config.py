"""The renderer's settings (:class:`RenderConfig`) and the conventions of the papers (:data:`ZHAO`,
:data:`DESCHAINTRE`): a leaf module, so that :mod:`svbrdf.runtime.core.maps` can name a set's renderer without
importing the renderer."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

__all__ = ["RenderConfig", "ZHAO", "DESCHAINTRE", "physical_config"]


@dataclass(frozen=True)
class RenderConfig:
    """Renderer settings. Defaults follow the Zhao et al. 2020 code that Wen et al. 2022 reuse.

    Attributes:
        fov_deg: horizontal field of view of the camera across the photo width, degrees.
        intensity: light intensity I (Zhao: pi).
        falloff: divide by the squared light distance (scaled so the centre pixel of a co-located
            light is unchanged: factor ``d^2 / |p_l - p|^2``).
        diffuse_conservation: multiply the diffuse term by (1 - rho_s) (Deschaintre convention).
        geometry: "schlick" (Smith-Schlick, k = alpha/2) or "smith" (exact separable Smith GGX).
        fresnel: "schlick" (spherical-Gaussian Schlick) or "none" (F = F0).
    """

    fov_deg: float = 66.0
    intensity: float = math.pi
    falloff: bool = False
    diffuse_conservation: bool = False
    geometry: str = "schlick"
    fresnel: str = "schlick"

    def __post_init__(self) -> None:
        if not (1.0 <= self.fov_deg <= 170.0):
            raise ValueError(f"fov_deg must be in [1, 170], got {self.fov_deg}")
        if self.geometry not in ("schlick", "smith"):
            raise ValueError(f"geometry must be 'schlick' or 'smith', got {self.geometry!r}")
        if self.fresnel not in ("schlick", "none"):
            raise ValueError(f"fresnel must be 'schlick' or 'none', got {self.fresnel!r}")

    @property
    def camera_distance(self) -> float:
        """Camera height d above the plane, in half-photo-widths."""
        return 1.0 / math.tan(math.radians(self.fov_deg) / 2.0)

    def to_dict(self) -> dict:
        return asdict(self)

    def replace(self, **kw) -> "RenderConfig":
        return replace(self, **kw)


#: Zhao et al. 2020 / Wen et al. 2022 convention (the project default).
ZHAO = RenderConfig()
#: Deschaintre et al. 2018 convention, used by the Des18/Des19 ground-truth data.
DESCHAINTRE = RenderConfig(fov_deg=45.0, diffuse_conservation=True)


def physical_config(config: RenderConfig = ZHAO) -> RenderConfig:
    """``config`` with the physics of a real flash and of Mitsuba 3: inverse-square fall-off, exact Smith GGX
    masking, F = F0 (the benchmark's realistic inputs, :func:`svbrdf.trainer.bench.cases.render_mitsuba`)."""
    return config.replace(falloff=True, geometry="smith", fresnel="none")
