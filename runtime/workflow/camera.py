"""The camera of a photo for every physical step (the relit panel, the viewer, the refine's renderer):
:func:`photo_camera`, from ``--fov``, the EXIF record, the flash's fall-off or a phone's main camera."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Optional

import numpy as np

from ..core.filters import block_mean
from ..io.images import ImageWarning, read_image

__all__ = ["CAMERA_ESTIMATE_SIZE", "declared_camera", "image_camera", "photo_camera", "warn_out_of_frame"]

#: The photo's long side (pixels) at which :func:`photo_camera` estimates the field of view from the fall-off.
CAMERA_ESTIMATE_SIZE = 256


def photo_camera(photo: Path, fov: Optional[float], image: Optional[np.ndarray] = None) -> dict:
    """The camera of ``photo`` for every physical step (the relit panel, the viewer, the refine's renderer):
    ``{"fov_deg", "fov_source", "how"}``, the field of view across the photo's width, from the first of

    1. ``fov`` (``"option"``);
    2. the file's EXIF record (``"exif"``, :func:`svbrdf.runtime.io.exif.exif_camera`; an absurd record is a
       warning and goes on to 3.);
    3. the flash's fall-off in the photo (``"estimated"``) where it is reliable, else a phone's main camera
       (``"default"``): :func:`image_camera` on the photo at :data:`CAMERA_ESTIMATE_SIZE` px, or on ``image``.

    A highlight out of frame is also one :class:`ImageWarning` naming the photo and the camera assumed. Its maps
    are made as any other's.

    Args:
        photo: the photo file.
        fov: ``--fov`` (degrees) or None.
        image: the photo already read (linear (H, W, 3), any size), to save reading it again.

    Raises:
        ImageError: the photo cannot be read (step 3 reads it; one line naming the file).
    """
    camera = declared_camera(photo, fov)
    if camera is not None:
        return camera
    if image is None:
        with warnings.catch_warnings():  # the photo itself is read (and its problems said) by the caller
            warnings.simplefilter("ignore", ImageWarning)
            image = read_image(photo, max_size=CAMERA_ESTIMATE_SIZE)
    camera = image_camera(image)
    warn_out_of_frame(photo, camera)
    return camera


def declared_camera(photo: Path, fov: Optional[float]) -> Optional[dict]:
    """Steps 1 and 2 of :func:`photo_camera`, which need no pixels: ``fov`` (``"option"``), else the file's EXIF
    record (``"exif"``); None when neither says (an absurd EXIF record is a warning and None)."""
    if fov is not None:
        return {"fov_deg": float(fov), "fov_source": "option", "how": "--fov"}
    from ..io.exif import exif_camera

    exif = exif_camera(photo)
    if exif is not None:
        return {"fov_deg": round(exif.fov_deg, 3), "fov_source": "exif", "how": exif.how}
    return None


def warn_out_of_frame(photo: Path, camera: dict) -> None:
    """One :class:`ImageWarning` naming ``photo`` and the camera assumed when ``camera`` (from :func:`image_camera`)
    says the flash highlight is out of frame; nothing otherwise."""
    if camera.get("highlight") == "out of frame":
        warnings.warn(ImageWarning(f"{photo}: the flash highlight is out of frame; the maps assume a camera of "
                                   f"{camera['fov_deg']:.1f} deg ({camera['fov_source']}) with the flash above the "
                                   f"photo's centre"), stacklevel=3)


def image_camera(image: np.ndarray) -> dict:
    """The camera of a photo without ``--fov`` or EXIF, from its pixels: ``{"fov_deg", "fov_source", "how"}``
    and, where the fit says where the flash was (``FovEstimate.out_of_frame``), ``"highlight"`` (``"out of
    frame"`` or ``"absent"``: no fall-off at all).

    1. The flash's fall-off (``"estimated"``, :func:`svbrdf.runtime.core.falloff.estimate_fov` on ``image`` in
       block means to about :data:`CAMERA_ESTIMATE_SIZE` px, long side) where the estimate is reliable;
    2. else a phone's main camera across a photo of this shape (``"default"``, :func:`svbrdf.runtime.io.exif.phone_fov`:
       67.3 deg for a 4:3 photo, 53.1 deg for a square one; ``how`` says why the estimate was not used).
       Why: docs/decisions/055-fov-estimate.md.

    Args:
        image: linear (H, W, 3) photo, any size.
    """
    from ..core.falloff import estimate_fov
    from ..io.exif import PHONE_F35_MM, phone_fov

    height, width = image.shape[:2]
    k = round(max(height, width) / CAMERA_ESTIMATE_SIZE)
    if k >= 2:
        image = block_mean(image, k, partial=True)
    try:
        found, why = estimate_fov(image), ""
    except ValueError as exc:  # a photo too small for the grid
        found, why = None, str(exc)
    if found is not None and found.reliable:
        camera = {"fov_deg": round(found.fov_deg, 3), "fov_source": "estimated",
                  "how": f"the flash's fall-off ({found.cells[0]} of {found.cells[1]} cells, fall-off "
                         f"{found.contrast:.1f} sigma, foot point ({found.centre[0]:.2f}, {found.centre[1]:.2f}))"}
    else:
        why = found.reason if found is not None else why
        camera = {"fov_deg": round(phone_fov(width, height), 3), "fov_source": "default",
                  "how": f"a phone's main camera ({PHONE_F35_MM:g} mm equivalent, 4:3 frame) across a {width}x{height} "
                         f"photo (no EXIF focal length; no estimate from the fall-off: {why})"}
    if found is not None and found.out_of_frame:
        camera["highlight"] = found.out_of_frame
    return camera
