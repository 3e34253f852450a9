"""The camera of a photo for every physical step (the relit panel, the viewer, the refine's renderer):
:func:`photo_camera`, from ``--fov``, the EXIF record, the flash's fall-off or the model's default."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Optional

import numpy as np

from ..io.images import ImageWarning, read_image, resize_long_side

__all__ = ["CAMERA_ESTIMATE_SIZE", "photo_camera"]

#: The photo's long side (pixels) at which :func:`photo_camera` estimates the field of view from the fall-off.
CAMERA_ESTIMATE_SIZE = 256


def photo_camera(photo: Path, fov: Optional[float], default: float, image: Optional[np.ndarray] = None) -> dict:
    """The camera of ``photo`` for every physical step (the relit panel, the viewer, the refine's renderer):
    ``{"fov_deg", "fov_source", "how"}``, the field of view across the photo's width, from the first of

    1. ``fov`` (``"option"``);
    2. the file's EXIF record (``"exif"``, :func:`svbrdf.runtime.io.exif.exif_camera`; an absurd record is a
       warning and goes on to 3.);
    3. the flash's fall-off in the photo (``"estimated"``, :func:`svbrdf.runtime.core.falloff.estimate_fov` on the
       photo at :data:`CAMERA_ESTIMATE_SIZE` px, or on ``image`` when given), where the estimate is reliable;
    4. ``default`` (the model's, ``"default"``; ``how`` says why the estimate was not used).

    In cases 3 and 4 the fit also says where the flash was (``FovEstimate.out_of_frame``), recorded as
    ``"highlight"`` (``"out of frame"`` or ``"absent"``: no fall-off at all); a highlight out of frame is also one
    :class:`ImageWarning` naming the photo and the camera assumed. Its maps are made as any other's.

    Args:
        photo: the photo file.
        fov: ``--fov`` (degrees) or None.
        default: the model's field of view (degrees).
        image: the photo already read (linear (H, W, 3), any size), to save reading it again.

    Raises:
        ImageError: the photo cannot be read (step 3 reads it; one line naming the file).
    """
    if fov is not None:
        return {"fov_deg": float(fov), "fov_source": "option", "how": "--fov"}
    from ..core.falloff import estimate_fov
    from ..io.exif import exif_camera

    exif = exif_camera(photo)
    if exif is not None:
        return {"fov_deg": round(exif.fov_deg, 3), "fov_source": "exif", "how": exif.how}
    if image is None:
        with warnings.catch_warnings():  # the photo itself is read (and its problems said) by the caller
            warnings.simplefilter("ignore", ImageWarning)
            image = read_image(photo, max_size=CAMERA_ESTIMATE_SIZE)
    elif max(image.shape[:2]) > 2 * CAMERA_ESTIMATE_SIZE:
        image = resize_long_side(image, CAMERA_ESTIMATE_SIZE)
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
        camera = {"fov_deg": float(default), "fov_source": "default",
                  "how": f"the model's training camera (no EXIF focal length; no estimate from the fall-off: {why})"}
    if found is not None and found.out_of_frame:
        camera["highlight"] = found.out_of_frame
    if camera.get("highlight") == "out of frame":
        warnings.warn(ImageWarning(f"{photo}: the flash highlight is out of frame; the maps assume a camera of "
                                   f"{camera['fov_deg']:.1f} deg ({camera['fov_source']}) with the flash above the "
                                   f"photo's centre"), stacklevel=2)
    return camera
