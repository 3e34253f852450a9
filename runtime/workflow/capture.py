"""One texture set fitted to every view of a calibrated multi-view flash capture (``svbrdf-preview --capture``):
:func:`process_capture`."""

from __future__ import annotations

import functools
import warnings
from pathlib import Path
from typing import Callable, Optional

from ..core.maps import MAP_NAMES
from ..errors import SvbrdfError
from ..inference.pipeline import estimate
from ..inference.session import PreviewSession
from ..io.images import read_image
from .options import PhotoOptions

__all__ = ["process_capture"]


def process_capture(folder: Path, options: PhotoOptions, session: PreviewSession, capture, config=None,
                    progress: Optional[Callable[[int, float], None]] = None):
    """One texture set fitted to every view of a calibrated multi-view flash capture (``svbrdf-preview
    --capture``; :mod:`svbrdf.trainer.capture`, passed as ``capture`` by
    :func:`svbrdf.runtime.inference.refine.load_capture`): the views' previews averaged, then fitted to all
    views at once, in the capture's plane frame.

    Returns:
        ``(maps, relit, detail)`` as :func:`~svbrdf.runtime.workflow.photo.process_photo` (``later``): the maps carry ``meta["capture"]`` and the
        capture's ``camera`` (the field of view of its mean camera height, ``fov_source`` ``"calibration"``).

    Raises:
        SvbrdfError: no calibration in ``folder``, none of its views on disk, a view photo on disk that the
            calibration does not list, views of different sizes or not square, or a view that cannot be read (one
            line naming the file).
    """
    from ..outputs.texture_set import relit_panel

    folder = Path(folder)
    if not folder.is_dir():
        raise SvbrdfError(f"{folder}: --capture needs a folder of views (NN.png) and their calibration")
    calib = capture.read_calibration(folder)
    if calib is None:
        raise SvbrdfError(f"{folder}: not a calibrated capture (no parameters.json or optim.json beside the views)")
    unlisted = sorted(p.name for p in folder.iterdir() if p.stem.isdigit() and int(p.stem) not in calib.views
                      and int(p.stem) not in calib.missing and capture.view_file(folder, int(p.stem)) == p)
    if unlisted:
        raise SvbrdfError(f"{folder}: {', '.join(unlisted)} {'is' if len(unlisted) == 1 else 'are'} not in "
                          f"{calib.path.name} (it lists views {', '.join(str(i) for i in sorted(calib.views))}): a view "
                          f"without its camera and light cannot be fitted; add it to the calibration or move it away")
    with warnings.catch_warnings(record=True) as caught:  # said once for all the views, not once per view
        warnings.simplefilter("always")
        photos = {i: read_image(capture.view_file(folder, i), max_size=options.max_size) for i in sorted(calib.views)}
    said: dict = {}
    for w in caught:
        said.setdefault(str(w.message).split(": ", 1)[-1], []).append(w)
    for text, ws in said.items():
        message = ws[0].message if len(ws) == 1 else f"{folder}: {len(ws)} views: {text}"
        warnings.warn(message if isinstance(message, Warning) else ws[0].category(message), stacklevel=2)
    sizes = {p.shape[:2] for p in photos.values()}
    if len(sizes) > 1:
        raise SvbrdfError(f"{folder}: the views are of different sizes ({', '.join(f'{w}x{h}' for h, w in sorted(sizes))}); "
                          f"a capture's views are rectified to one square of the plane")
    (h, w), = sizes
    if h != w:
        raise SvbrdfError(f"{folder}: the views are {w}x{h} px, not square: {calib.path.name} gives the camera and "
                          f"light over one square of the plane {calib.width_cm:g} cm wide, which a view shows whole")
    previews = [estimate(p, session, max_size=options.max_size, tile=options.tile, post=options.post,
                         upsampling=options.upsampling) for p in photos.values()]
    prior = capture.average_maps(previews)
    fitted = capture.fit_capture(photos, calib, prior, iters=options.iters or capture.ITERS,
                                 threads=options.threads, callback=progress)
    fov = capture.capture_fov(calib)
    config = (config or options.render_config(session)).replace(fov_deg=fov)
    maps = fitted.subset(options.maps) if options.maps != MAP_NAMES else fitted
    maps.render_config = config
    maps.meta.update(source=str(folder), model={"path": str(session.path), "sha256": session.info.sha256},
                     maps=list(options.maps),
                     camera={"fov_deg": round(fov, 3), "fov_source": "calibration",
                             "how": f"{calib.path.name}: the mean camera height over the {calib.width_cm:g} cm width"})
    if options.tileable:
        from ..post.tileable import make_tileable

        try:
            maps = make_tileable(maps)
        except SvbrdfError as exc:
            raise SvbrdfError(f"{folder}: --tileable: {exc}") from None
    detail = (f"{len(photos)} views fitted together, {fitted.meta['capture']['iterations']} it "
              f"(photo error {fitted.meta['capture']['loss']:.4f})")
    return maps, functools.partial(relit_panel, maps, config) if maps.complete else None, detail
