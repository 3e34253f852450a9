"""The per-photo path of both CLIs: one photo file -> its maps and relit panel with :class:`PhotoOptions`
(:func:`process_photo`): the preview (:func:`~svbrdf.runtime.inference.pipeline.estimate`) or the refine
(:func:`svbrdf.trainer.refine.refine`, passed in by the caller from
:func:`svbrdf.runtime.inference.refine.load_refine`), at the photo's camera, made tileable and given its relief as
asked."""

from __future__ import annotations

import functools
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable, Optional

from ..core.maps import MAP_NAMES, Maps
from ..errors import SvbrdfError
from ..inference.pipeline import estimate
from ..inference.reading import warn_if_greyscale
from ..inference.session import PreviewSession
from ..io.images import ImageWarning, read_image
from .camera import declared_camera, image_camera, warn_out_of_frame
from .options import PhotoOptions

__all__ = ["process_photo"]


def _refine(refine, image, session, config, options: PhotoOptions, name: str):
    """The preview of ``image`` ((H, W, 3) linear), then ``refine`` (:func:`svbrdf.trainer.refine.refine`) with the
    photo's ``config`` (its field of view); returns the Maps, the refined ones or the preview
    (``meta["refine"]["kept"]`` says which)."""
    from ..progress import Progress

    with warnings.catch_warnings():  # the photo itself was checked (and named) by the caller
        warnings.simplefilter("ignore", ImageWarning)
        preview = estimate(image, session, max_size=options.max_size, tile=options.tile, maps=MAP_NAMES,
                           post=options.post, upsampling=options.upsampling, fov_deg=config.fov_deg)
    bar = None

    def progress(step, total, error):  # the Progress is made at the first step, when the length is known
        nonlocal bar
        if bar is None:
            bar = Progress(total, f"refine {name}", quiet=options.quiet, initial=step - 1)
        bar.update(step, rmse=f"{error:.4f}")

    try:
        return refine(image, preview, config, quality=options.quality or "fixed", iters=options.iters,
                      threads=options.threads, callback=progress)
    finally:
        if bar is not None:
            bar.close()


def process_photo(photo: Path, options: PhotoOptions, session: PreviewSession, config=None,
                  refine: Optional[Callable] = None, name: Optional[str] = None, later: bool = False):
    """The texture set of one photo file with ``options``: the preview, or the refine with ``refine`` (see
    :func:`svbrdf.runtime.inference.refine.load_refine`). The one per-photo path of ``svbrdf-preview`` and
    ``svbrdf-batch`` (each builds its :class:`PhotoOptions` from its arguments).

    Args:
        photo: the photo file (PNG, JPEG, TIFF, EXR, ...; read as linear RGB).
        options: what to compute (:class:`PhotoOptions`; ``refine`` needs ``refine``).
        session: the loaded model (:func:`~svbrdf.runtime.inference.session.load_session`).
        config: the :class:`~svbrdf.runtime.core.render_config.RenderConfig` of the maps and the relit panel
            (default: :meth:`PhotoOptions.render_config` of the session).
        refine: :func:`svbrdf.trainer.refine.refine`, for ``options.refine``.
        name: the photo's name in the refine's progress bar (default: the file name).
        later: leave the relief and the relit panel to :func:`~svbrdf.runtime.workflow.write.write_maps`, which computes them while the maps'
            files are written (the maps come without their relief, the panel as a function that renders it).

    Returns:
        ``(maps, relit, detail)``: the :class:`~svbrdf.runtime.core.maps.Maps` (the requested maps, at the processed
        size, ``render_config`` = ``config``), the relit panel (sRGB (h, 3 w, 3), None without all four maps) and a
        short report (``"model 0.41 s"``, ``"refined (100 it): held-out error ..."``, ...).

    Raises:
        SvbrdfError: the photo cannot be read or processed; with ``options.tileable``, maps smaller than
            :data:`~svbrdf.runtime.post.tileable.MIN_SIZE` a side (the message names ``photo``).
    """
    from ..outputs.texture_set import relit_panel

    if config is None:
        config = options.render_config(session)
    image = None
    if options.refine:
        if refine is None:
            raise ValueError("options.refine needs the refine function (svbrdf.runtime.inference.refine.load_refine)")
        image = read_image(photo, max_size=options.max_size)  # read once: the camera's estimate takes it too
    camera = declared_camera(photo, options.fov)  # --fov or EXIF; else the pixels tell, read once
    if camera is None and options.refine:
        camera = image_camera(image)
        warn_out_of_frame(photo, camera)
    if camera is not None:
        config = config.replace(fov_deg=camera["fov_deg"])
    if options.refine:
        warn_if_greyscale(image, str(photo))
        maps = _refine(refine, image, session, config, options, name or photo.name)
        record = maps.meta["refine"]
        if record["kept"] == "refined":
            detail = f"refined ({record['iterations']} it): held-out error {record['heldout_rmse_refined']:.3f} " \
                     f"vs the preview's {record['heldout_rmse_preview']:.3f}"
        else:
            detail = f"refine kept the preview: held-out error {record['heldout_rmse_refined']:.3f} vs the " \
                     f"preview's {record['heldout_rmse_preview']:.3f}"
            if record["reason"] == "held-out error":
                detail += f", the fit not better on held-out fold {record['folds']}"
            if record["reason"] == "burn-in":
                detail += f", but its burn-in {record['burn_in_refined']:.4f} is above the preview's " \
                          f"{record['burn_in_preview']:.4f}"
        # The refine fits (and renders) every map; only the requested ones are written.
        maps = maps.subset(options.maps)
        maps.meta.update(source=str(photo), model={"path": str(session.path), "sha256": session.info.sha256},
                         maps=list(options.maps))
    else:
        found = {}

        def fov_of(pixels):  # the camera from the photo as estimate() reads it: no second read
            found.update(image_camera(pixels))
            return found["fov_deg"]

        maps = estimate(photo, session, max_size=options.max_size, tile=options.tile, maps=options.maps,
                        post=options.post, upsampling=options.upsampling,
                        fov_deg=config.fov_deg if camera is not None else fov_of)
        if camera is None:
            camera = found
            warn_out_of_frame(photo, camera)
            config = config.replace(fov_deg=camera["fov_deg"])
        tiles = maps.meta["tiles"]
        detail = f"model {maps.meta['timings']['infer']:.2f} s" + (f", {tiles} tiles" if tiles > 1 else "")
    maps.render_config = config
    maps.meta["camera"] = camera
    if options.tileable:
        from ..post.tileable import make_tileable

        try:
            maps = make_tileable(maps)
        except SvbrdfError as exc:  # a photo too small for it: say which one
            raise SvbrdfError(f"{photo}: --tileable: {exc}") from None
        worst = [s["after"] for s in maps.meta["tileable"]["join"].values() if s["after"] is not None]
        detail += f", tileable (join score {max(worst):.2f})" if worst else ", tileable"
    if later:
        return maps, functools.partial(relit_panel, maps, config) if maps.complete else None, detail
    # The relief (height and AO from the normals) and the relit panel need only the final maps: on two threads (numpy
    # leaves the GIL in their large operations; at 1024 px the relief takes 0.09 s and the panel 0.15 s on their own).
    relit_job = None
    with ThreadPoolExecutor(1) as pool:
        if maps.complete:
            relit_job = pool.submit(relit_panel, maps, config)  # at its display size (block means)
        if options.relief:
            maps = _with_relief(maps, options)
    relit = relit_job.result() if relit_job is not None else None
    return maps, relit, detail


def _with_relief(maps: Maps, options: PhotoOptions) -> Maps:
    """``maps`` with the relief ``options`` ask for, timed in their meta; errors name the photo."""
    t = time.perf_counter()
    try:
        maps = maps.with_relief(tileable=options.tileable, maps=options.relief, ao_strength=options.ao_strength)
    except SvbrdfError as exc:
        raise SvbrdfError(f"{maps.meta.get('source', '<maps>')}: {exc}") from None
    maps.meta.setdefault("timings", {})["relief"] = time.perf_counter() - t
    return maps
