"""The camera's field of view from a photo's EXIF record (OpenImageIO's ``Exif:*`` attributes).

The field of view is across the photo's **width as displayed** (EXIF ``Orientation`` applied), the renderer's
``fov_deg`` (:class:`~svbrdf.runtime.core.render_config.RenderConfig`). From, in this order:

1. ``FocalLengthIn35mmFilm`` ``f35``: the lens a 36 x 24 mm frame would need for the same diagonal field of view
   (CIPA DC-008), so the width spans ``43.27 mm * W / sqrt(W^2 + H^2)`` of that frame and
   ``fov = 2 atan(width_mm / (2 f35))``;
2. ``FocalLength`` ``f`` with ``FocalPlaneXResolution`` and ``FocalPlaneResolutionUnit`` (pixels per inch, cm or
   mm on the sensor) and the recorded ``PixelXDimension``: the sensor's width ``PixelXDimension / resolution``.

A photo whose pixel size differs from the size EXIF records (``PixelXDimension`` x ``PixelYDimension``) was
downsized (the same aspect ratio within 1 %: the same field of view) or cropped (another aspect ratio: taken as a
crop that kept the whole height, or the whole width when it is the wider, at any scale; ``tan(fov / 2)`` scaled by
the share of the width kept, with a warning). A crop to the same aspect ratio cannot be told from a downsizing.
A focal length of 0, a negative one or a field of view outside :data:`FOV_RANGE` is a warning and no answer (the
caller, :func:`svbrdf.runtime.workflow.camera.photo_camera`, then estimates the field of view from the photo's
own fall-off, :mod:`svbrdf.runtime.core.falloff`).

Without any of that, :func:`phone_fov` is the field of view a phone's main camera (:data:`PHONE_F35_MM`, a 4:3
frame) gives a photo of that shape, taken as the largest centred crop of the frame (the same rule as a crop above).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Tuple, Union

from .images import ImageWarning

#: The diagonal of the 36 x 24 mm frame that 35 mm-equivalent focal lengths refer to, mm.
FULL_FRAME_DIAGONAL_MM = math.hypot(36.0, 24.0)
#: Fields of view (degrees, across the width) taken as plausible for a photo of a material; outside: absurd.
FOV_RANGE: Tuple[float, float] = (5.0, 120.0)
#: A phone's main camera, the commonest camera of a flash photo: its 35 mm-equivalent focal length (mm; 26 mm on
#: most phones since 2018, 24-28 mm on the others) and its frame's aspect ratio (width, height), landscape.
PHONE_F35_MM = 26.0
PHONE_FRAME: Tuple[float, float] = (4.0, 3.0)
#: ``FocalPlaneResolutionUnit``: millimetres per unit.
_UNIT_MM = {2: 25.4, 3: 10.0, 4: 1.0, 5: 0.001}


@dataclass(frozen=True)
class ExifCamera:
    """What a photo's EXIF says of its camera.

    Attributes:
        fov_deg: field of view across the photo's displayed width, degrees.
        how: which fields gave it, e.g. ``"FocalLengthIn35mmFilm 26 mm"``; ``"; cropped ..."`` appended for a crop.
    """

    fov_deg: float
    how: str


def fov_35mm(f35: float, frame: Tuple[float, float]) -> float:
    """The field of view (degrees) across the width of a ``frame`` (width, height; any unit) taken with a lens of
    35 mm-equivalent focal length ``f35`` (mm): ``2 atan(w_mm / (2 f35))``, ``w_mm`` the width's share of the
    43.27 mm diagonal."""
    width_mm = FULL_FRAME_DIAGONAL_MM * frame[0] / math.hypot(frame[0], frame[1])
    return 2.0 * math.degrees(math.atan(width_mm / (2.0 * f35)))


def crop_fov(fov_deg: float, frame: Tuple[float, float], photo: Tuple[float, float]) -> Tuple[float, float]:
    """``(fov, kept)``: the field of view (degrees) across the width of ``photo`` (width, height) taken as the
    largest centred crop of its aspect ratio from ``frame`` (width, height), whose width spans ``fov_deg``; ``kept``
    is the share of the frame's width kept (1 when the photo is as wide as the frame or wider: the whole width)."""
    kept = min(1.0, (photo[0] / photo[1]) * frame[1] / frame[0])
    return 2.0 * math.degrees(math.atan(math.tan(math.radians(fov_deg) / 2.0) * kept)), kept


def phone_fov(width: int, height: int) -> float:
    """The field of view (degrees) across a ``width`` x ``height`` photo from a phone's main camera: the largest
    centred crop of that shape from its :data:`PHONE_FRAME` in the photo's orientation, at :data:`PHONE_F35_MM`
    (a 4:3 or wider photo: 67.3 deg; a square one: 53.1 deg), within :data:`FOV_RANGE` (a strip narrower than
    about 1:10 gets its lower end)."""
    frame = PHONE_FRAME if width >= height else (PHONE_FRAME[1], PHONE_FRAME[0])
    fov = crop_fov(fov_35mm(PHONE_F35_MM, frame), frame, (width, height))[0]
    return min(max(fov, FOV_RANGE[0]), FOV_RANGE[1])


def _attr(spec, name: str) -> Optional[float]:
    value = spec.getattribute(name)
    if value is None:
        return None
    if isinstance(value, (tuple, list)):  # a rational read as (num, den)
        value = value[0] / value[1] if len(value) == 2 and value[1] else None
    try:
        return float(value)
    except (TypeError, ValueError):
        return None


def exif_camera(path: Union[str, Path], size: Optional[Tuple[int, int]] = None) -> Optional[ExifCamera]:
    """The field of view that ``path``'s EXIF record gives (module docstring), or None.

    Args:
        path: an image file.
        size: ``(height, width)`` of the photo as processed (displayed orientation; any downsizing), default the
            file's own.

    Returns:
        :class:`ExifCamera`, or None when the file has no usable record. An absurd record (a focal length of 0 or
        below, a field of view outside :data:`FOV_RANGE`) is an :class:`ImageWarning` naming the file and None.
    """
    import OpenImageIO as oiio

    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        oiio.geterror()
        return None
    try:
        spec = inp.spec()
    finally:
        inp.close()
    turned = spec.get_int_attribute("Orientation", 1) in (5, 6, 7, 8)
    stored = (spec.height, spec.width)
    rec_w, rec_h = _attr(spec, "Exif:PixelXDimension"), _attr(spec, "Exif:PixelYDimension")
    if not (rec_w and rec_h and rec_w > 0 and rec_h > 0):
        rec_w, rec_h = float(stored[1]), float(stored[0])
    f35, f = _attr(spec, "Exif:FocalLengthIn35mmFilm"), _attr(spec, "Exif:FocalLength")
    if f35 is None and f is None:
        return None
    # the recorded frame as displayed: width across, and its diagonal
    shown_w, shown_h = (rec_h, rec_w) if turned else (rec_w, rec_h)
    if f35 is not None:
        if f35 <= 0:
            return _absurd(path, f"FocalLengthIn35mmFilm {f35:g}")
        fov, how = fov_35mm(f35, (shown_w, shown_h)), f"FocalLengthIn35mmFilm {f35:g} mm"
    else:
        res, unit = _attr(spec, "Exif:FocalPlaneXResolution"), spec.get_int_attribute("Exif:FocalPlaneResolutionUnit", 2)
        if f <= 0:
            return _absurd(path, f"FocalLength {f:g}")
        if not res or res <= 0 or unit not in _UNIT_MM:
            return None  # a focal length without the sensor's size says nothing of the field of view
        sensor_x_mm = rec_w / res * _UNIT_MM[unit]  # along the stored rows
        sensor_y_mm = sensor_x_mm * rec_h / rec_w
        width_mm = sensor_y_mm if turned else sensor_x_mm
        fov, how = 2.0 * math.degrees(math.atan(width_mm / (2.0 * f))), f"FocalLength {f:g} mm, sensor {width_mm:.2f} mm wide"
    h, w = size if size is not None else ((stored[1], stored[0]) if turned else stored)
    if abs((w / h) / (shown_w / shown_h) - 1.0) > 0.01:  # another aspect ratio: a crop of the whole height (or width)
        fov, kept = crop_fov(fov, (shown_w, shown_h), (w, h))
        how += f"; {w}x{h} px of a {shown_w:.0f}x{shown_h:.0f} frame, taken as a crop of {kept:.0%} of its width"
        warnings.warn(ImageWarning(f"{path}: {w}x{h} px of a {shown_w:.0f}x{shown_h:.0f} frame (EXIF): the field of "
                                   f"view assumes a crop of {kept:.0%} of its width ({fov:.1f} deg)"), stacklevel=2)
    if not FOV_RANGE[0] <= fov <= FOV_RANGE[1]:
        return _absurd(path, f"{how}: a field of view of {fov:.1f} deg")
    return ExifCamera(fov, how)


def _absurd(path, what: str) -> None:
    warnings.warn(ImageWarning(f"{path}: EXIF {what} is not a plausible camera (field of view outside "
                               f"{FOV_RANGE[0]:g}-{FOV_RANGE[1]:g} deg); ignored"), stacklevel=3)
    return None


__all__ = ["ExifCamera", "FOV_RANGE", "FULL_FRAME_DIAGONAL_MM", "PHONE_F35_MM", "PHONE_FRAME", "crop_fov", "exif_camera",
           "fov_35mm", "phone_fov"]
