"""Readers for third-party ground-truth SVBRDF sets and a folder walker that finds test cases.

Three panel layouts exist in the public data (square panels of side H placed side by side, width = k H):

==========  ==========================================================  ======================
format      panels, left to right                                       aspect (width : height)
==========  ==========================================================  ======================
``des18``   input photo, normal, diffuse, roughness, specular           5 : 1
``des19``   normal, diffuse, roughness, specular                        4 : 1
``xuejiao`` diffuse, specular, roughness, normal                        4 : 1
==========  ==========================================================  ======================

Decoding (the evidence is in ``docs/conventions.md``; the defaults follow it):

* normals are stored as ``(n + 1) / 2``; they are decoded to unit vectors and converted to the project's
  OpenGL frame (:mod:`svbrdf.runtime.core.maps`). ``normal_y="up"`` means the file already stores +y up the image
  (green up, OpenGL); ``"down"`` flips y (DirectX files).
* ``maps_encoding`` says how the diffuse and specular panels are stored: ``"srgb-diffuse"`` (default: the
  diffuse panel is sRGB-encoded and decoded on read, the specular panel is linear; the usual texture
  convention, and the reading under which the project renderer reproduces the Des18 input panels best;
  dielectric specular sits at 10/255 ~ 0.04, a linear F0), ``"linear"`` (both used as stored, what the
  Deschaintre et al. code does) or ``"srgb"`` (both decoded).
* roughness and specular panels are stored as RGB; the reader takes the **mean of the three channels**
  (they are grey in Des18/Des19; the Xuejiao specular panel is tinted and the project's specular is grey).
  Albedos and roughness are kept in [0, 1]; roughness 0 (two Des19 files) is valid, the renderer clamps
  alpha = r^2.
* the Des18 input panel is a gamma-encoded rendering; it is returned decoded to linear with the project's sRGB
  curve (:func:`svbrdf.runtime.core.colour.srgb_to_linear`).

Format detection (:func:`detect_format`), in this order:

1. an explicit ``format=`` argument wins (the file's size must fit it);
2. width = 5 x height -> ``des18``;
3. width = 4 x height -> ``des19`` or ``xuejiao``. The two differ by where the normal panel is, so the content
   decides first: a panel counts as a normal map when at least 90 % of its pixels decode to a vector of length
   1 +- 0.1 with z > 0 (a colour map almost never does). If exactly one of the first and last panels is a normal
   map, that settles it. Otherwise the naming convention of the Xuejiao et al. repository decides: a file
   whose stem ends with ``_gt`` or that lives in a folder whose name contains ``xuejiao`` is ``xuejiao``;
   anything else is ``des19``;
4. any other size -> ``photo`` (a real photo, no ground truth).

Multi-view flash captures (the layout of Guo et al.'s svbrdf-diff-renderer, e.g. ``bath_tile/``): a folder of
rectified photos of one flat material, ``00.png``, ``01.png``, ..., each taken from another camera position with
the flash on the camera, plus a calibration JSON (:func:`read_capture_calibration`). Every view is an ordinary
real photo for the methods; the benchmark relights the maps estimated from one view at the others
(:func:`svbrdf.trainer.bench.metrics.capture_errors`). Several published captures ship a subset of the views their
calibration lists: a capture is read with the views on disk, and a :class:`MissingViewsWarning` (once per
calibration file) names the missing ones.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Set, Tuple, Union

import numpy as np
import OpenImageIO as oiio

from svbrdf.runtime.core.colour import srgb_to_linear
from svbrdf.runtime.errors import ImageError
from svbrdf.runtime.io.images import image_info, read_image
from svbrdf.runtime.core.maps import Maps, decode_normal, normal_dx_to_gl

PathLike = Union[str, os.PathLike]

#: Panel order of each ground-truth layout.
LAYOUTS = {
    "des18": ("input", "normal", "diffuse", "roughness", "specular"),
    "des19": ("normal", "diffuse", "roughness", "specular"),
    "xuejiao": ("diffuse", "specular", "roughness", "normal"),
}
#: How the diffuse and specular panels are stored: both as linear values, both sRGB-encoded, or only the
#: diffuse sRGB-encoded (the usual texture convention: base colour sRGB, specular level linear).
MAPS_ENCODINGS = ("linear", "srgb", "srgb-diffuse")
#: Every value :func:`detect_format` can return.
FORMATS = tuple(LAYOUTS) + ("photo",)

# OpenImageIO's readable extensions, minus its pseudo-formats (null, term).
IMAGE_EXTENSIONS = frozenset(
    "." + ext
    for entry in oiio.get_string_attribute("extension_list").split(";")
    if entry.split(":")[0] not in ("null", "term")
    for ext in entry.split(":")[1].split(",")
)

_NORMAL_LIKE_FRACTION = 0.9
#: Reader defaults, chosen from the evidence in docs/conventions.md (Des18 fits, normal integrability).
DEFAULT_NORMAL_Y = "up"
DEFAULT_MAPS_ENCODING = "srgb-diffuse"


@dataclass(frozen=True)
class Case:
    """One test case found on disk.

    Attributes:
        name: path relative to the searched root, without extension, "/"-separated (unique within a search).
        path: the image file.
        kind: ``"gt"`` (a ground-truth panel set) or ``"photo"`` (a real photo, no ground truth).
        format: one of :data:`FORMATS` (``"photo"`` for photos).
    """

    name: str
    path: Path
    kind: str
    format: str


def _check_options(normal_y: str, maps_encoding: str) -> None:
    if normal_y not in ("up", "down"):
        raise ValueError(f"normal_y must be 'up' or 'down', got {normal_y!r}")
    if maps_encoding not in MAPS_ENCODINGS:
        raise ValueError(f"maps_encoding must be one of {', '.join(MAPS_ENCODINGS)}, got {maps_encoding!r}")


def _size(path: Path) -> Tuple[int, int]:
    """(height, width) as displayed (EXIF orientations 5-8 swap the stored axes)."""
    info = image_info(path)
    h, w = info["height"], info["width"]
    return (w, h) if info["orientation"] >= 5 else (h, w)


def _fits(fmt: str, height: int, width: int) -> bool:
    return fmt == "photo" or width == len(LAYOUTS[fmt]) * height


def _size_error(path: Path, fmt: str, height: int, width: int) -> ImageError:
    k = len(LAYOUTS[fmt])
    return ImageError(f"{path}: {width}x{height} does not fit the {fmt} layout "
                      f"({k} square panels, width = {k} x height)")


def _is_normal_panel(panel: np.ndarray) -> bool:
    n = panel.astype(np.float32) * 2.0 - 1.0
    length = np.sqrt(np.sum(n * n, axis=-1))
    ok = (np.abs(length - 1.0) < 0.1) & (n[..., 2] > 0.0)
    return float(np.mean(ok)) >= _NORMAL_LIKE_FRACTION


def _xuejiao_by_name(path: Path) -> bool:
    return path.stem.lower().endswith("_gt") or any("xuejiao" in part.lower() for part in path.parent.parts)


def detect_format(path: PathLike, format: Optional[str] = None) -> str:
    """Which layout a file has (see the module docstring for the rule).

    Args:
        path: an image file.
        format: explicit override, one of :data:`FORMATS`; the file's size must fit it.

    Returns:
        ``"des18"``, ``"des19"``, ``"xuejiao"`` or ``"photo"``.

    Raises:
        ImageError: unreadable file, or its size does not fit the given ``format``.
        ValueError: unknown ``format``.
    """
    path = Path(path)
    if format is not None and format not in FORMATS:
        raise ValueError(f"format must be one of {', '.join(FORMATS)}, got {format!r}")
    h, w = _size(path)
    if format is not None:
        if not _fits(format, h, w):
            raise _size_error(path, format, h, w)
        return format
    if w == 5 * h:
        return "des18"
    if w != 4 * h:
        return "photo"
    raw = read_image(path, raw=True)
    first, last = _is_normal_panel(raw[:, :h]), _is_normal_panel(raw[:, 3 * h:])
    if first != last:
        return "des19" if first else "xuejiao"
    return "xuejiao" if _xuejiao_by_name(path) else "des19"


def _read_panels(path: PathLike, fmt: str, normal_y: str, maps_encoding: str) -> Tuple[Maps, Optional[np.ndarray]]:
    _check_options(normal_y, maps_encoding)
    path = Path(path)
    raw = read_image(path, raw=True)
    h, w = raw.shape[:2]
    names = LAYOUTS[fmt]
    if not _fits(fmt, h, w):
        raise _size_error(path, fmt, h, w)
    panel = {name: raw[:, i * h:(i + 1) * h] for i, name in enumerate(names)}

    normal = decode_normal(panel["normal"])
    if normal_y == "down":
        normal = normal_dx_to_gl(normal)
    diffuse, specular = panel["diffuse"], panel["specular"]
    if maps_encoding in ("srgb", "srgb-diffuse"):
        diffuse = srgb_to_linear(diffuse)
    if maps_encoding == "srgb":
        specular = srgb_to_linear(specular)
    # Integer files are in [0, 1] already; a float (EXR) panel set may not be.
    maps = Maps(
        diffuse=np.clip(diffuse, 0.0, 1.0),
        specular=np.clip(np.mean(specular, axis=-1, keepdims=True), 0.0, 1.0),
        roughness=np.clip(np.mean(panel["roughness"], axis=-1, keepdims=True), 0.0, 1.0),
        normal=normal,
        meta={"source": str(path), "format": fmt, "normal_y": normal_y, "maps_encoding": maps_encoding},
    )
    photo = srgb_to_linear(panel["input"]) if "input" in panel else None
    return maps, photo


def read_des18(
    path: PathLike, *, normal_y: str = DEFAULT_NORMAL_Y, maps_encoding: str = DEFAULT_MAPS_ENCODING
) -> Tuple[Maps, np.ndarray]:
    """Read a Deschaintre 2018 test file (5 panels: input, normal, diffuse, roughness, specular).

    Args:
        path: the (5H x H) image.
        normal_y: ``"up"`` (the file stores +y up, OpenGL) or ``"down"`` (DirectX; y is flipped on read).
        maps_encoding: how the diffuse/specular panels are stored: ``"srgb-diffuse"`` (diffuse sRGB-encoded,
            specular linear), ``"linear"`` (both used as stored) or ``"srgb"`` (both sRGB-encoded).

    Returns:
        ``(maps, photo)``: :class:`~svbrdf.runtime.core.maps.Maps` of (H, H) maps, and the input panel as an
        (H, H, 3) float32 linear image (sRGB-decoded).

    Raises:
        ImageError: unreadable file, or width != 5 x height.
    """
    return _read_panels(path, "des18", normal_y, maps_encoding)


def read_des19(
    path: PathLike, *, normal_y: str = DEFAULT_NORMAL_Y, maps_encoding: str = DEFAULT_MAPS_ENCODING
) -> Maps:
    """Read a Deschaintre 2019 map set (4 panels: normal, diffuse, roughness, specular).

    Same options and errors as :func:`read_des18` (width must be 4 x height); returns the maps only.
    """
    return _read_panels(path, "des19", normal_y, maps_encoding)[0]


def read_xuejiao(
    path: PathLike, *, normal_y: str = DEFAULT_NORMAL_Y, maps_encoding: str = DEFAULT_MAPS_ENCODING
) -> Maps:
    """Read a Xuejiao et al. map set (4 panels: diffuse, specular, roughness, normal).

    Same options and errors as :func:`read_des18` (width must be 4 x height); returns the maps only.
    """
    return _read_panels(path, "xuejiao", normal_y, maps_encoding)[0]


def read_gt(
    path: PathLike,
    format: Optional[str] = None,
    *,
    normal_y: str = DEFAULT_NORMAL_Y,
    maps_encoding: str = DEFAULT_MAPS_ENCODING,
) -> Tuple[Maps, Optional[np.ndarray]]:
    """Read any ground-truth panel set; the format is detected unless given.

    Returns:
        ``(maps, photo)``; ``photo`` is the linear input panel for ``des18`` and ``None`` otherwise.

    Raises:
        ImageError: unreadable file, size that fits no panel layout (a photo), or does not fit ``format``.
    """
    fmt = detect_format(path, format)
    if fmt == "photo":
        raise ImageError(f"{Path(path)}: not a ground-truth panel set (width is not 4 or 5 x height)")
    return _read_panels(path, fmt, normal_y, maps_encoding)


def normal_curl_ratio(normal: np.ndarray) -> float:
    """How far a normal map is from the normals of a height field, read in the project's frame (+y up).

    The slopes p = dh/dx = -nx/nz and q = dh/dy = -ny/nz of any height field satisfy dp/dy = dq/dx. This returns
    ``rms(dp/dy - dq/dx) / sqrt(rms(dp/dy)^2 + rms(dq/dx)^2)`` (central differences, y up the image): well below
    1 for a map baked from a height field in the OpenGL convention, about sqrt(2) when the map's y axis is the
    other way (the two terms then add instead of cancelling). It is the evidence behind ``normal_y``.

    Args:
        normal: (H, W, 3) unit normals, OpenGL frame, z > 0.

    Returns:
        the ratio (>= 0), or NaN for a flat map (no slope: no evidence).
    """
    n = np.asarray(normal, dtype=np.float64)
    nz = np.maximum(n[..., 2], 1e-3)
    p, q = -n[..., 0] / nz, -n[..., 1] / nz
    dp_dy = -(p[2:, 1:-1] - p[:-2, 1:-1]) * 0.5  # rows grow downwards, y upwards
    dq_dx = (q[1:-1, 2:] - q[1:-1, :-2]) * 0.5
    scale = math.sqrt(np.mean(dp_dy ** 2) + np.mean(dq_dx ** 2))
    if scale < 1e-9:
        return float("nan")
    return float(np.sqrt(np.mean((dp_dy - dq_dx) ** 2)) / scale)


#: Calibration files of a multi-view capture, in the order they are looked for (two versions of one format).
CAPTURE_CALIBRATIONS = ("parameters.json", "optim.json")


class MissingViewsWarning(UserWarning):
    """A capture's calibration lists views whose photos are not on disk; the capture is read without them."""


#: Calibration files already warned about (one warning per file and process, however many views are read).
_WARNED: Set[Path] = set()


def capture_view_file(folder: PathLike, index: int, suffix: Optional[str] = None) -> Optional[Path]:
    """The photo of view ``index`` of a capture folder (``03.png``, or ``3.png``), or None when it is not on disk.

    Args:
        folder: the capture folder.
        index: the view index (the file stem).
        suffix: the extension to look for (e.g. ``".png"``); default: any image extension OpenImageIO reads.
    """
    folder = Path(folder)
    for stem in (f"{index:02d}", str(index)):
        if suffix is not None:
            if (folder / (stem + suffix)).is_file():
                return folder / (stem + suffix)
            continue
        found = sorted(p for p in folder.glob(stem + ".*")
                       if p.suffix.lower() in IMAGE_EXTENSIONS and p.is_file() and not p.name.startswith("."))
        if found:
            return found[0]
    return None


def _ranges(indices: List[int]) -> str:
    """``[0, 1, 2, 5, 6]`` -> ``"0-2, 5, 6"`` (runs of three or more joined)."""
    runs: List[List[int]] = []
    for i in sorted(indices):
        if runs and runs[-1][-1] == i - 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    return ", ".join(f"{r[0]}-{r[-1]}" if len(r) >= 3 else ", ".join(map(str, r)) for r in runs)


@dataclass(frozen=True)
class CaptureCalibration:
    """Camera and light positions of a multi-view flash capture (lengths in cm).

    The frame (both versions of the format): the origin at the centre of the rectified crop, +x to the right of
    the image, +y up the image, +z out of the surface; every photo shows the same square ``width_cm`` wide, so a
    pixel is the same point of the material in every view. This is the renderer's frame
    (:mod:`svbrdf.runtime.core.render`) scaled by half the width.

    Attributes:
        path: the JSON read.
        width_cm: physical width of the photographed square (``image_size``, or ``im_size`` in ``optim.json``).
        views: view index -> (camera position (3,), light position (3,)) in cm, of the views whose photo is on
            disk; the index is the photo's file stem (``03.png`` is view 3).
        missing: the indices the calibration lists whose photo is not on disk (left out of ``views``).
    """

    path: Path
    width_cm: float
    views: Dict[int, Tuple[Tuple[float, float, float], Tuple[float, float, float]]]
    missing: Tuple[int, ...] = ()

    def scene_units(self, index: int) -> Tuple[np.ndarray, np.ndarray]:
        """(camera, light) of view ``index`` in the renderer's units (half the photo width), float64 (3,)."""
        cam, light = self.views[index]
        half = self.width_cm / 2.0
        return np.asarray(cam, np.float64) / half, np.asarray(light, np.float64) / half


def read_capture_calibration(folder: PathLike) -> Optional[CaptureCalibration]:
    """The calibration of a multi-view capture folder, or None when the folder has none.

    Reads the first of :data:`CAPTURE_CALIBRATIONS` present: ``image_size`` or ``im_size`` (cm), ``camera_pos``
    (one (3,) position per view, cm), ``light_pos`` (default: the camera positions, a co-located flash) and
    ``idx`` (the view indices the positions belong to; default 0, 1, ...). Views whose photo is not on disk
    (:func:`capture_view_file`) are left out and listed in ``missing``, with one :class:`MissingViewsWarning` per
    calibration file naming them.

    Raises:
        ImageError: the JSON is unreadable or inconsistent (lists of different lengths, a view listed twice, a width
            of 0 or below), or none of the views it lists is on disk (one line, with the file).
    """
    folder = Path(folder)
    path = next((folder / n for n in CAPTURE_CALIBRATIONS if (folder / n).is_file()), None)
    if path is None:
        return None
    try:
        doc = json.loads(path.read_text())
        width = float(doc["image_size"] if "image_size" in doc else doc["im_size"])
        cams = [tuple(float(c) for c in p) for p in doc["camera_pos"]]
        lights = [tuple(float(c) for c in p) for p in doc.get("light_pos", cams)]
        idx = [int(i) for i in doc.get("idx", range(len(cams)))]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ImageError(f"{path}: not a capture calibration ({type(e).__name__}: {e})") from None
    if not (len(cams) == len(lights) == len(idx)) or any(len(p) != 3 for p in cams + lights) or width <= 0:
        raise ImageError(f"{path}: camera_pos, light_pos and idx must list one (x, y, z) per view, and the "
                         f"image size must be > 0")
    twice = sorted({i for i in idx if idx.count(i) > 1})
    if twice:
        raise ImageError(f"{path}: idx lists view{'s' if len(twice) > 1 else ''} {_ranges(twice)} more than once: "
                         f"each view has one camera and one light")
    listed = {i: (c, l) for i, c, l in zip(idx, cams, lights)}
    views = {i: v for i, v in listed.items() if capture_view_file(folder, i) is not None}
    missing = tuple(sorted(set(listed) - set(views)))
    if not views:
        raise ImageError(f"{path}: the calibration lists views {_ranges(list(listed))} but none of their photos "
                         f"(00.png, 01.png, ...) is in {folder}")
    if missing and path.resolve() not in _WARNED:
        _WARNED.add(path.resolve())
        names = ", ".join(f"{i:02d}" for i in missing)
        warnings.warn(MissingViewsWarning(
            f"{path}: the calibration lists view{'s' if len(missing) > 1 else ''} {_ranges(list(missing))} but "
            f"there is no photo of {'them' if len(missing) > 1 else 'it'} ({names}); the capture is read with the "
            f"{len(views)} view{'s' if len(views) > 1 else ''} on disk ({_ranges(list(views))})"), stacklevel=2)
    return CaptureCalibration(path, width, views, missing)


def capture_view(path: PathLike) -> Optional[Tuple[CaptureCalibration, int]]:
    """``(calibration, view index)`` when the image at ``path`` is a view of a calibrated capture, else None
    (no calibration beside it, or a file stem that is not one of its view indices)."""
    path = Path(path)
    if not path.stem.isdigit():
        return None
    calib = read_capture_calibration(path.parent)
    if calib is None or int(path.stem) not in calib.views:
        return None
    return calib, int(path.stem)


def find_cases(root: PathLike, format: Optional[str] = None) -> List[Case]:
    """Every image under ``root`` (recursively), as ground-truth sets or real photos.

    Hidden files and folders (name starting with ".") and files whose extension OpenImageIO does not read
    (licences, JSON, ...) are skipped. The result is sorted by name.

    Args:
        root: a folder (any folder, not only the project's shared data) or a single image file.
        format: force this format for every image found (see :func:`detect_format`).

    Returns:
        list of :class:`Case`.

    Raises:
        ImageError: ``root`` does not exist, an image is unreadable, or does not fit ``format``.
    """
    root = Path(root)
    if root.is_file():
        files, base = [root], root.parent
    elif root.is_dir():
        files, base = [], root
        for folder, dirs, names in os.walk(root):
            dirs[:] = sorted(d for d in dirs if not d.startswith("."))
            files += [Path(folder) / n for n in sorted(names)
                      if not n.startswith(".") and Path(n).suffix.lower() in IMAGE_EXTENSIONS]
    else:
        raise ImageError(f"{root}: no such file or folder")
    cases = []
    for path in files:
        fmt = detect_format(path, format)
        name = path.relative_to(base).with_suffix("").as_posix()
        cases.append(Case(name=name, path=path, kind="photo" if fmt == "photo" else "gt", format=fmt))
    return sorted(cases, key=lambda c: c.name)


__all__ = ["Case", "CaptureCalibration", "CAPTURE_CALIBRATIONS", "MissingViewsWarning", "read_capture_calibration",
           "capture_view", "capture_view_file",
           "FORMATS", "LAYOUTS", "MAPS_ENCODINGS", "DEFAULT_NORMAL_Y", "DEFAULT_MAPS_ENCODING",
           "IMAGE_EXTENSIONS", "detect_format", "find_cases", "read_des18",
           "read_des19", "read_xuejiao", "read_gt", "normal_curl_ratio"]
