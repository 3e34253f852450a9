"""``svbrdf-preview``: flash photo(s) -> texture set(s) with the ONNX preview model (optionally refined with torch).

Exit codes: 0 success, 2 usage error (or ``--refine`` without the training side installed), 1 if any photo
failed (each failure is one line ``svbrdf-preview: error: <message>`` on stderr; ``--verbose`` adds the
traceback). The per-photo work is :func:`svbrdf.runtime.workflow.photo.process_photo` with the
:class:`~svbrdf.runtime.workflow.options.PhotoOptions` of the arguments. Progress on stderr
(:mod:`svbrdf.runtime.progress`): a bar for the batch and for each ``--refine``
on a terminal, plain lines otherwise, nothing with ``--quiet``. Heavy modules
(onnxruntime, OpenImageIO, torch) are imported only after the arguments are parsed, so ``--version`` and
``--help`` stay instant.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
import warnings
from pathlib import Path
from typing import List, Optional

from .. import __version__
from ..core.maps import MAP_NAMES
from ..errors import MissingExtraError, SvbrdfError, cli_message, parse_command_line
from .options import add_texture_options, check_options, photo_options

PROG = "svbrdf-preview"

EXAMPLES = f"""\
examples:
  {PROG} wood.jpg                      maps in wood_svbrdf/ beside the photo
  {PROG} photos/*.png -o maps/         a batch into one folder (files named after each photo)
  {PROG} tiles.png --normal dx --format exr --max-size 4096
  {PROG} wood.jpg --model my.onnx      a model of your own (or set SVBRDF_MODEL)
  {PROG} wood.jpg --refine      correct the preview's gloss by fitting this photo (needs torch)
  {PROG} wood.jpg --maps normal        only the normal map (runs only the normal/roughness decoder)
  {PROG} wood.jpg --tileable --view    maps that repeat without a seam, and wood_view.html to relight them
  {PROG} wood.jpg --maps height,ao     the normal map and its height and ambient occlusion
  {PROG} wood.jpg --target ambientcg   Color, NormalGL/NormalDX, Roughness, Displacement, AmbientOcclusion, .mtlx
  {PROG} --capture bath_tile/ -o maps/ several calibrated views of one material fitted together (needs torch)

Each texture set is <name>_basecolor.png, <name>_normal, <name>_roughness, <name>_specular, <name>_height
(white = high, mid-grey = the mean level) and <name>_ao (ambient occlusion, 1 = open) (.png 16-bit or .exr),
<name>.json (sidecar: the height's scale in map widths, how height and AO were made) and <name>_relit.png
(renders under the flash and two other lights). Height and AO come from the normal map (periodic with
--tileable); the base colour is never darkened by the AO. With --maps only those maps' files and the sidecar are
written (no relit panel: it needs all four maps). --view adds <name>_view.html: the maps relit in the browser
under a light that follows the pointer, with relief and ambient-occlusion controls (one file, no network).
"""



def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Estimate SVBRDF maps (diffuse, specular, roughness, normal) from flash photos of flat materials.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("photos", nargs="*", metavar="PHOTO", help="flash photo(s): PNG, JPEG, TIFF, EXR, ...")
    p.add_argument("-o", "--out", metavar="DIR", type=Path,
                   help="output folder (default: <photo folder>/<photo name>_svbrdf/)")
    p.add_argument("--capture", metavar="DIR", type=Path,
                   help="instead of photos: a calibrated multi-view flash capture (views NN.png rectified to the "
                        "plane, parameters.json or optim.json with each view's camera and light), fitted together "
                        "into one texture set named after the folder (needs torch; --iters: the fit's steps)")
    add_texture_options(p)
    return p


def _error(msg: str) -> None:
    from ..progress import write

    write(f"{PROG}: error: {cli_message(msg)}")


def _process(photo: Path, session, config, options, out_dir: Path, refine=None) -> str:
    """Estimate (or refine with ``refine``, see :func:`~svbrdf.runtime.inference.refine.load_refine`), render and
    write one texture set with ``options`` (:class:`~svbrdf.runtime.workflow.options.PhotoOptions`); returns the
    report line."""
    from ..errors import exists_message
    from ..io.process import processed_pixels, reuse_memory
    from ..workflow.photo import process_photo
    from ..workflow.write import write_maps

    start = time.perf_counter()
    name = photo.stem
    # Cheap early refusal before minutes of inference; write_texture_set re-checks every file it writes.
    if not options.force:
        early_files = [f"{name}.json"]
        if options.view:
            from ..outputs.viewer import VIEWER_FILE

            early_files.append(VIEWER_FILE.format(name=name))
        for early in early_files:
            if (out_dir / early).exists():
                raise SvbrdfError(exists_message(out_dir / early))
    try:
        reuse_memory(processed_pixels(photo, options.max_size))
    except SvbrdfError:  # an unreadable photo: process_photo says so
        pass
    maps, relit, detail = process_photo(photo, options, session, config, refine, later=True)  # relief beside the writes
    write_maps(maps, relit, out_dir, name, options, {"tool": f"{PROG} {__version__}"})
    h, w = maps.shape
    burn = f"burn-in {maps.meta['burn_in']['burn_in']:.2f}"
    if "burn_in_model" in maps.meta:  # the network's maps before the post-processing
        fill = maps.meta.get("highlight_fill") or {}
        steps = "highlight fill and flash-trend removal" if fill.get("filled") else "flash-trend removal"
        burn += f", {maps.meta['burn_in_model']['burn_in']:.2f} before {steps}"
    return f"{photo} -> {out_dir}/{name}_*  {w}x{h}  {time.perf_counter() - start:.2f} s ({detail}; {burn})"


def _import_photo_modules(options) -> None:
    """Import what the per-photo work uses before the first photo's clock starts (0.1-0.2 s: numpy's FFT, the
    post-processing, the writers): the time each photo reports is its own work, as it is for the second photo on."""
    import numpy.fft  # noqa: F401  (the relief's DCT)

    from ..inference import pipeline  # noqa: F401
    from ..workflow import photo, write  # noqa: F401
    from ..outputs import texture_set  # noqa: F401
    from ..post import flash_trend, photo_colour  # noqa: F401

    if options.target != "generic":
        from ..outputs import targets  # noqa: F401
    if options.view:
        from ..outputs import viewer  # noqa: F401


def _run(args) -> int:
    if args.target != "generic" and (args.normal != "opengl" or args.format != "png"):
        raise SvbrdfError("--normal and --format apply to --target generic only; the other targets fix them")
    from ..inference.refine import load_refine

    refine = load_refine() if args.refine else None  # before any work: every photo would fail the same way
    from ..inference.session import load_session

    options = photo_options(args)
    session = load_session(options.model, threads=options.threads, maps=options.maps)
    config = options.render_config(session)
    _import_photo_modules(options)
    if args.verbose:
        info = session.info
        state = "verified" if info.verified else info.note
        print(f"model: {info.path} ({info.source}, sha256 {info.sha256[:12]}, {state}); "
              f"{', '.join(session.providers)}, {session.threads} threads; graph {session.graph_for()}")
    if options.maps != MAP_NAMES and not options.quiet:
        print(f"{PROG}: note: no relit panel with --maps (it renders all four maps)", file=sys.stderr)

    from ..progress import Progress, write

    if args.capture is not None:
        return _run_capture(args, session, config, options)
    failed = 0
    seen = {}
    batch = Progress(len(args.photos), PROG, quiet=args.quiet or len(args.photos) == 1, unit="photo")
    for text in args.photos:
        photo = Path(text)
        out_dir = args.out if args.out is not None else photo.parent / f"{photo.stem}_svbrdf"
        key = (out_dir.resolve(), photo.stem)
        try:
            if key in seen:
                raise SvbrdfError(f"{photo}: same output name as {seen[key]} in {out_dir}; process it separately")
            seen[key] = photo
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                line = _process(photo, session, config, options, out_dir, refine)
            if not args.quiet:
                for w in caught:
                    write(f"{PROG}: warning: {w.message}")
                write(line, file=sys.stdout)
        except Exception as exc:  # per photo: report, go on with the batch, exit 1 at the end
            failed += 1
            _error(str(exc) if isinstance(exc, SvbrdfError) else f"{photo}: {type(exc).__name__}: {exc}")
            if args.verbose:
                traceback.print_exc()
        batch.update(failed=failed) if failed else batch.update()
    batch.close()
    return 1 if failed else 0


def _run_capture(args, session, config, options) -> int:
    """``--capture DIR``: one texture set of every view (:func:`svbrdf.runtime.workflow.capture.process_capture`)."""
    from ..errors import exists_message
    from ..workflow.capture import process_capture
    from ..workflow.write import write_maps
    from ..inference.refine import load_capture
    from ..progress import Progress, write

    capture = load_capture()
    folder = args.capture
    name = folder.resolve().name
    out_dir = args.out if args.out is not None else folder.parent / f"{name}_svbrdf"
    if not options.force and (out_dir / f"{name}.json").exists():
        raise SvbrdfError(exists_message(out_dir / f"{name}.json"))
    start = time.perf_counter()
    bar = Progress(options.iters or capture.ITERS, f"capture {name}", quiet=args.quiet)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            maps, relit, detail = process_capture(folder, options, session, capture, config,
                                                  progress=lambda step, loss: bar.update(step, loss=f"{loss:.4f}"))
    except (SvbrdfError, KeyboardInterrupt):
        raise
    except Exception as exc:  # one line, as for a photo
        raise SvbrdfError(f"{folder}: {type(exc).__name__}: {exc}") from exc
    finally:
        bar.close()
    if not args.quiet:
        for w in caught:
            write(f"{PROG}: warning: {w.message}")
    write_maps(maps, relit, out_dir, name, options, {"tool": f"{PROG} {__version__} --capture"})
    h, w = maps.shape
    if not args.quiet:
        write(f"{folder} -> {out_dir}/{name}_*  {w}x{h}  {time.perf_counter() - start:.2f} s ({detail})",
              file=sys.stdout)
    return 0


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``svbrdf-preview``; returns the exit code (see the module docstring)."""
    parser = build_parser()
    args, code = parse_command_line(parser, argv)
    if args is None:  # --help / --version (0) or a usage error (2)
        return code
    problem = check_options(args)
    if not problem and bool(args.photos) == (args.capture is not None):
        problem = "give photos or --capture DIR (not both)" if args.photos else "no photo given (or --capture DIR)"
    if problem:
        return _usage(parser, problem)
    from ..io.process import small_pages

    small_pages()
    try:
        return _run(args)
    except KeyboardInterrupt:
        _error("interrupted")
        return 130
    except MissingExtraError as exc:  # --refine without torch: what to install, like a usage error
        _error(str(exc))
        return 2
    except SvbrdfError as exc:  # model not found / not loadable
        _error(str(exc))
        if args.verbose:
            traceback.print_exc()
        return 1


def _usage(parser: argparse.ArgumentParser, msg: str) -> int:
    parser.print_usage(sys.stderr)
    _error(msg)
    return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
