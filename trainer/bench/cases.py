"""Benchmark cases: ground-truth sets turned into synthetic flash photos, and real photos (numpy, no torch).

Every image under the data folder is found by :func:`svbrdf.trainer.bench.datasets.find_cases`:

* a ground-truth panel set (Des18, Des19, Xuejiao layouts) becomes a **synthetic case**: its maps are
  area-averaged to ``size x size`` (:func:`resize_maps`, normals renormalised) and the input photo is rendered
  from them with a co-located flash above the centre, then recorded by a camera
  (:func:`svbrdf.trainer.camera_model.expose`). Two settings:

  - **realistic** (the default): rendered by Mitsuba 3 where it is installed (:func:`render_mitsuba`: an
    independent renderer with inverse-square fall-off), else by the project renderer with the same physics
    (:func:`physical_config`: fall-off, exact Smith masking, F = F0); then a camera drawn per case from
    :data:`svbrdf.trainer.camera_model.REALISTIC` (exposure +-0.5 stop, vignetting, Poisson-Gaussian noise,
    saturation, 8-bit sRGB storage). The highlight clips wherever the rendering exceeds 1 after exposure;
  - **clean** (``realistic=False``, for the inverse-crime comparison): rendered by ``renderer`` with the
    benchmark's own configuration, optional Gaussian noise (``noise``), clipped to [0, 1], optionally 8-bit
    sRGB (``quantize``).

  The input panel of a Des18 file is not used (it was rendered with unknown perturbations; see the data README).
* any other image is a **real photo**: centre-cropped to a square, area-averaged to ``size x size`` (linear).
  A photo that is a view of a calibrated multi-view capture
  (:func:`svbrdf.trainer.bench.datasets.capture_view`) also carries the capture's other views
  (:class:`CaptureViews`), against which the benchmark relights its maps.

Every random draw (camera, noise, Mitsuba sampler) is seeded by the case name, so a case gets the same photo in
every run; :attr:`BenchCase.simulation` records how it was made.
"""

from __future__ import annotations

import fnmatch
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np
import OpenImageIO as oiio

from svbrdf.runtime.quality.burn_in import highlight_centre
from svbrdf.trainer.camera_model import Camera, expose, sample_camera
from svbrdf.trainer.bench.datasets import Case, CaptureCalibration, capture_view, capture_view_file, find_cases, read_gt
from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.images import read_image
from svbrdf.runtime.core.maps import Maps, encode_normal, normalize_normals
from svbrdf.runtime.core.render import ALPHA_MIN, ZHAO, RenderConfig, physical_config, render


RENDERERS = ("auto", "ours", "mitsuba")
#: Samples per pixel of the Mitsuba renders.
MITSUBA_SPP = 32


@dataclass
class CaptureViews:
    """The views of a multi-view flash capture, prepared like the case photos, for relighting one of them.

    Attributes:
        calibration: the capture's calibration (:class:`~svbrdf.trainer.bench.datasets.CaptureCalibration`).
        index: the view this case is (its photo is the input of the methods).
        photos: view index -> (S, S, 3) float32 linear photo in [0, 1] (every view, this one included).
    """

    calibration: CaptureCalibration
    index: int
    photos: Dict[int, np.ndarray]

    def others(self) -> List[int]:
        """The views to relight at: every view but this one, in index order."""
        return sorted(i for i in self.photos if i != self.index)


@dataclass
class BenchCase:
    """One prepared benchmark input.

    Attributes:
        name: the case name (path relative to the data folder, no extension).
        source: the image file it came from.
        kind: ``"synthetic"`` (rendered from ground truth) or ``"photo"`` (real, no ground truth).
        format: the file layout (``des18``, ``des19``, ``xuejiao`` or ``photo``).
        photo: (S, S, 3) float32 linear input photo in [0, 1].
        gt: ground-truth maps (S, S) for synthetic cases, else None.
        centre: (row, column) of the flash highlight in pixels, used by the burn-in score.
        simulation: how a synthetic photo was made (renderer, camera, clipped fraction); None for photos.
        capture: the capture's views when the photo is one view of a calibrated multi-view capture, else None.
    """

    name: str
    source: str
    kind: str
    format: str
    photo: np.ndarray
    gt: Optional[Maps]
    centre: Tuple[float, float]
    simulation: Optional[Dict[str, Any]] = None
    capture: Optional[CaptureViews] = None


def _resize(arr: np.ndarray, height: int, width: int) -> np.ndarray:
    """Resize (h, w, c) float32 with OpenImageIO: box filter (exact area average) when shrinking."""
    h, w, c = arr.shape
    if (h, w) == (height, width):
        return np.asarray(arr, dtype=np.float32)
    buf = oiio.ImageBuf(oiio.ImageSpec(w, h, c, oiio.FLOAT))
    buf.set_pixels(oiio.ROI(), np.ascontiguousarray(arr, dtype=np.float32))
    filt = "box" if height <= h and width <= w else "triangle"
    out = oiio.ImageBufAlgo.resize(buf, filtername=filt, roi=oiio.ROI(0, width, 0, height, 0, 1, 0, c))
    if out.has_error:
        raise SvbrdfError(f"OpenImageIO resize failed: {out.geterror()}")
    return out.get_pixels(oiio.FLOAT).reshape(height, width, c)


def resize_maps(maps: Maps, size: int) -> Maps:
    """Area-average every map to ``size x size`` (OpenImageIO box filter) and renormalise the normals."""
    out = {n: _resize(a, size, size) for n, a in maps.items()}
    out["normal"] = normalize_normals(out["normal"])
    return Maps(**out, meta=dict(maps.meta))


def centre_square(image: np.ndarray) -> np.ndarray:
    """The largest centred square crop of an (H, W, C) image."""
    h, w = image.shape[:2]
    s = min(h, w)
    y0, x0 = (h - s) // 2, (w - s) // 2
    return image[y0:y0 + s, x0:x0 + s]


def _mitsuba():
    try:
        import mitsuba as mi
    except ImportError:
        return None
    mi.set_variant("scalar_rgb")  # the LLVM variants abort with the system LLVM (platform notes)
    return mi


def mitsuba_available() -> bool:
    """True when Mitsuba 3 can be imported."""
    return _mitsuba() is not None


def render_mitsuba(maps: Maps, light_pos: Optional[Sequence[float]] = None, config: RenderConfig = ZHAO,
                   spp: int = MITSUBA_SPP, seed: int = 0) -> np.ndarray:
    """Render a texture set with Mitsuba 3 (``scalar_rgb``), the same scene as :func:`svbrdf.runtime.core.render.render`.

    Scene: the maps cover the plane z = 0 over x in [-1, 1]; a perspective camera at ``(0, 0, d)`` looks down
    with ``config.fov_deg`` across the width (box pixel filter, ``spp`` samples); a point light at
    ``light_pos`` (default: the camera). The material is ``normalmap`` (tangent space, (n+1)/2) around an equal
    blend of ``diffuse`` (reflectance = diffuse map) and ``roughconductor`` (GGX, alpha = max(r^2, ALPHA_MIN),
    ``material="none"`` so F = specular map), weighted x2 so the two lobes add. Mitsuba is physically based, so
    regardless of ``config``: inverse-square fall-off (intensity ``I d^2``, so a surface point at the camera
    distance gets ``I``), exact Smith GGX masking, F = F0, no (1 - rho_s) on the diffuse term. It matches
    :func:`~svbrdf.runtime.core.render.render` with ``config.replace(falloff=True, geometry="smith",
    fresnel="none")`` up to Monte Carlo noise and texture filtering, and differs from the ZHAO settings
    the methods assume (an independent check of robustness to the image-formation model).

    Args:
        maps: texture set (H, W); textures are passed as raw data (no colour conversion).
        light_pos: point light (3,) in scene units; None = co-located with the camera.
        config: field of view and light intensity are used.
        spp: samples per pixel.
        seed: sampler seed.

    Returns:
        (H, W, 3) float32 linear radiance.

    Raises:
        SvbrdfError: Mitsuba 3 is not installed.
    """
    mi = _mitsuba()
    if mi is None:
        raise SvbrdfError("--renderer mitsuba needs Mitsuba 3 (pip install mitsuba)")
    h, w = maps.shape
    d = config.camera_distance

    def tex(a: np.ndarray) -> dict:
        # Mitsuba puts bitmap row 0 at v = 0, the bottom (-y) of the rectangle: flip rows to keep +y up.
        return {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(a[::-1], dtype=np.float32)),
                "raw": True, "filter_type": "bilinear", "wrap_mode": "clamp"}

    m = maps.clipped()
    bsdf = {
        # Mitsuba >= 3.7 defaults (flipping invalid normals, a terminator shadowing term) are not in our model.
        "type": "normalmap", "flip_invalid_normals": False, "use_shadowing_function": False,
        "normalmap": tex(encode_normal(m.normal)),
        "bsdf": {
            "type": "blendbsdf", "weight": 0.5,
            "bsdf_0": {"type": "diffuse", "reflectance": tex(m.diffuse)},
            "bsdf_1": {"type": "roughconductor", "distribution": "ggx", "material": "none",
                       "alpha": tex(np.maximum(m.roughness ** 2, ALPHA_MIN)),
                       "specular_reflectance": tex(np.repeat(m.specular, 3, axis=-1))},
        },
    }
    light = [0.0, 0.0, d] if light_pos is None else [float(c) for c in light_pos]
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct"},
        "sensor": {
            "type": "perspective", "fov": float(config.fov_deg), "fov_axis": "x",
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, d], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": w, "height": h, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp)},
        },
        "plane": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([1.0, h / w, 1.0]), "bsdf": bsdf},
        # x2: the blend halves each lobe.
        "light": {"type": "point", "position": light, "intensity": {"type": "rgb", "value": 2.0 * config.intensity * d * d}},
    })
    img = mi.render(scene, spp=int(spp), seed=int(seed))
    return np.asarray(img, dtype=np.float32)[..., :3]


def resolve_renderer(renderer: str) -> str:
    """``"auto"`` -> ``"mitsuba"`` where Mitsuba 3 is installed, else ``"ours"``; other names unchanged."""
    if renderer not in RENDERERS:
        raise ValueError(f"renderer must be one of {', '.join(RENDERERS)}, got {renderer!r}")
    if renderer == "auto":
        return "mitsuba" if mitsuba_available() else "ours"
    return renderer


def simulate_photo(maps: Maps, *, renderer: str = "ours", config: RenderConfig = ZHAO,
                   camera: Optional[Camera] = None, seed: int = 0) -> np.ndarray:
    """The flash photo of a texture set: render (co-located flash), then record with ``camera``.

    Args:
        maps: texture set.
        renderer: ``"ours"`` (the project renderer with ``config``), ``"mitsuba"`` (physical, see
            :func:`render_mitsuba`) or ``"auto"``.
        config: renderer settings.
        camera: the camera model (:func:`svbrdf.trainer.camera_model.expose`); default: clip to [0, 1] only.
        seed: noise and Mitsuba sampler seed.

    Returns:
        (H, W, 3) float32 linear photo in [0, 1].
    """
    renderer = resolve_renderer(renderer)
    img = render(maps, None, config) if renderer == "ours" else render_mitsuba(maps, None, config, seed=seed)
    return expose(img, camera or Camera(), seed=seed)


def select_cases(cases: List[Case], spec: Optional[str]) -> List[Case]:
    """Pick cases: ``None`` = all, a number N = the first N, else comma-separated globs matched against the case
    name or the file name (cases kept in their sorted order).

    Raises:
        SvbrdfError: no case at all, or the selection is empty.
    """
    if not cases:
        raise SvbrdfError("no image found in the data folder")
    if spec is None or spec == "":
        picked = list(cases)
    elif spec.isdigit():
        picked = cases[: int(spec)]
    else:
        globs = [g.strip() for g in spec.split(",") if g.strip()]
        picked = [c for c in cases if any(fnmatch.fnmatchcase(c.name, g) or fnmatch.fnmatchcase(c.path.name, g)
                                          for g in globs)]
    if not picked:
        raise SvbrdfError(f"--cases {spec!r} selects no case (found {len(cases)})")
    return picked


def case_seed(name: str) -> int:
    """Stable per-case seed (CRC32 of the name)."""
    return zlib.crc32(name.encode("utf-8"))


def prepare_case(case: Case, size: int, *, realistic: bool = True, renderer: str = "auto",
                 config: RenderConfig = ZHAO, noise: float = 0.0, quantize: bool = False) -> BenchCase:
    """Load one found case and turn it into a :class:`BenchCase` of side ``size`` (see the module docstring).

    ``realistic`` picks the setting; ``renderer`` (``"auto"``: Mitsuba where installed) applies to both, ``noise``
    and ``quantize`` to the clean one only.
    """
    if case.kind == "gt":
        gt, _ = read_gt(case.path, case.format)
        gt = resize_maps(gt, size)
        seed = case_seed(case.name)
        used = resolve_renderer(renderer)
        if realistic:
            camera = sample_camera(seed)
            cfg = physical_config(config) if used == "ours" else config
        else:
            camera, cfg = Camera(read=noise, quantize=quantize), config
        photo = simulate_photo(gt, renderer=used, config=cfg, camera=camera, seed=seed)
        sim = {"setting": "realistic" if realistic else "clean", "renderer": used,
               "render_config": cfg.to_dict() if used == "ours" else None, "camera": camera.to_dict(),
               "clipped_fraction": float((photo.max(axis=-1) >= 1.0).mean())}
        return BenchCase(case.name, str(case.path), "synthetic", case.format, photo, gt, (size / 2.0, size / 2.0),
                         sim)
    photo = _read_photo(case.path, size)
    view = capture_view(case.path)
    capture = None
    if view is not None:
        calib, index = view
        folder = Path(case.path).parent
        photos = {i: photo if i == index else _read_photo(_view_file(folder, i, Path(case.path).suffix), size)
                  for i in calib.views}
        capture = CaptureViews(calib, index, photos)
    return BenchCase(case.name, str(case.path), "photo", case.format, photo, None, highlight_centre(photo),
                     capture=capture)


def _read_photo(path: Path, size: int) -> np.ndarray:
    """A real photo as the benchmark uses it: centre square, area-averaged to ``size``, linear, in [0, 1]."""
    return np.clip(_resize(centre_square(read_image(path)), size, size), 0.0, 1.0)


def _view_file(folder: Path, index: int, suffix: str) -> Path:
    """The photo of view ``index`` of a capture folder: ``03.png`` or ``3.png`` (the case's own extension first,
    else any image extension). The calibration lists only views on disk
    (:func:`svbrdf.trainer.bench.datasets.read_capture_calibration`), so one is found unless it was just removed."""
    found = capture_view_file(folder, index, suffix) or capture_view_file(folder, index)
    if found is None:
        raise SvbrdfError(f"{folder}: the photo of view {index} ({index:02d}{suffix}) is no longer on disk")
    return found


def load_cases(root: Path, size: int, spec: Optional[str] = None, split: Optional[str] = None, **kw
               ) -> List[BenchCase]:
    """Find, keep one part of the split (:mod:`svbrdf.trainer.bench.split`; ``None``: all), select
    (:func:`select_cases`) and prepare (:func:`prepare_case`) every case under ``root``."""
    found = find_cases(root)
    if not found:
        raise SvbrdfError(f"{root}: no image found")
    if split is not None:
        from svbrdf.trainer.bench.split import select_split

        keep = set(select_split([c.name for c in found], split))
        found = [c for c in found if c.name in keep]
        if not found:
            raise SvbrdfError(f"{root}: no case in the {split} part of the split")
    return [prepare_case(c, size, **kw) for c in select_cases(found, spec)]


__all__ = ["BenchCase", "CaptureViews", "RENDERERS", "MITSUBA_SPP", "resize_maps", "centre_square", "render_mitsuba",
           "mitsuba_available", "physical_config", "resolve_renderer", "simulate_photo", "select_cases", "case_seed", "prepare_case", "load_cases"]
