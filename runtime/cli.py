"""``svbrdf-preview``: flash photo(s) -> texture set(s) with the ONNX preview model (optionally refined with torch).

Exit codes: 0 success, 2 usage error (or ``--refine`` without the training side installed), 1 if any photo
failed (each failure is one line ``svbrdf-preview: error: <message>`` on stderr; ``--verbose`` adds the
traceback). Progress on stderr (:mod:`svbrdf.runtime.progress`): a bar for the batch and for each ``--refine``
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

from . import __version__
from .choices import SUPPORTED_NORMAL_CONVENTIONS, TARGETS, normal_convention
from .errors import MissingExtraError, SvbrdfError, cli_message, parse_command_line
from .install import missing_train_module, train_hint
from .maps import MAP_NAMES, select_maps
from .preview_check import SKIP_REFINE_BURN_IN, SKIP_REFINE_RMSE

PROG = "svbrdf-preview"

EXAMPLES = f"""\
examples:
  {PROG} wood.jpg                      maps in wood_svbrdf/ beside the photo
  {PROG} photos/*.png -o maps/         a batch into one folder (files named after each photo)
  {PROG} tiles.png --normal dx --format exr --max-size 4096
  {PROG} wood.jpg --model my.onnx      a model of your own (or set SVBRDF_MODEL)
  {PROG} wood.jpg --refine --iters 300 fine-tune the model on this photo first (needs torch)
  {PROG} wood.jpg --maps normal        only the normal map (runs only the normal/roughness decoder)
  {PROG} wood.jpg --tileable --view    maps that repeat without a seam, and wood_view.html to relight them

Each texture set is <name>_basecolor.png, <name>_normal, <name>_roughness, <name>_specular (.png 16-bit or
.exr), <name>.json (sidecar) and <name>_relit.png (renders under the flash and two other lights). With
--maps only those maps' files and the sidecar are written (no relit panel: it needs all four maps).
--view adds <name>_view.html: the maps relit in the browser under a light that follows the pointer (one file,
no network).
"""



def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def _map_list(text: str) -> tuple:
    """``--maps``: comma list of map names (or aliases) -> names in packing order."""
    try:
        return select_maps(part.strip() for part in text.split(",") if part.strip())
    except SvbrdfError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Estimate SVBRDF maps (diffuse, specular, roughness, normal) from flash photos of flat materials.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("photos", nargs="+", metavar="PHOTO", help="flash photo(s): PNG, JPEG, TIFF, EXR, ...")
    p.add_argument("-o", "--out", metavar="DIR", type=Path,
                   help="output folder (default: <photo folder>/<photo name>_svbrdf/)")
    add_texture_options(p)
    return p


def add_texture_options(p: argparse.ArgumentParser, prog: str = PROG) -> None:
    """The options of how one photo becomes a texture set (model, threads, target, maps, refine, ...), shared by
    ``svbrdf-preview`` and ``svbrdf-batch``; :func:`check_options` checks what argparse cannot."""
    p.add_argument("--model", metavar="PATH", help="ONNX model (default: $SVBRDF_MODEL, else the packaged model)")
    p.add_argument("--threads", metavar="N", type=_positive, help="CPU threads (default: all cores)")
    p.add_argument("--fov", metavar="DEG", type=float,
                   help="camera field of view across the photo width, for the relit preview "
                        "(default: the model's training value)")
    p.add_argument("--normal", type=normal_convention, choices=SUPPORTED_NORMAL_CONVENTIONS, default="opengl",
                   help="normal map convention: opengl (or gl) = green up; dx = DirectX, green down (default: opengl)")
    p.add_argument("--format", choices=("png", "exr"), default="png",
                   help="normal/roughness/specular files: 16-bit png or float exr (default: png)")
    p.add_argument("--max-size", metavar="N", type=_positive, default=2048,
                   help="downsize photos whose long side exceeds N pixels (default: 2048)")
    p.add_argument("--tile", metavar="N", type=_positive, default=1024,
                   help="process larger images in overlapping N x N tiles to bound memory (default: 1024; "
                        f"at least {min_tile()})")
    p.add_argument("--target", choices=TARGETS, default="generic",
                   help="output preset: file names, normal convention, packing and material document "
                        "(generic, gltf, blender, unreal, unity, usd, mtlx; see docs/targets.md)")
    p.add_argument("--maps", metavar="LIST", type=_map_list, default=MAP_NAMES,
                   help="comma list of the maps to compute and write: diffuse (or basecolor), specular, roughness, "
                        "normal (default: all). roughness/normal alone run only the normal-roughness decoder, "
                        "diffuse/specular only the diffuse-specular one; no relit panel; --target generic only")
    p.add_argument("--tileable", action="store_true",
                   help="make the maps repeat without a visible seam, at the same size and scale (all four cut "
                        "the same way; the sidecar records the join and seam scores)")
    p.add_argument("--view", action="store_true",
                   help="also write <name>_view.html: the maps relit in the browser with the project's renderer, "
                        "one tile and repeated (--target generic, all four maps)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.add_argument("--refine", action="store_true",
                   help="fine-tune the model's training checkpoint on each photo with torch before predicting")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--iters", metavar="N", type=_positive, help="--refine iterations (default: the checkpoint's)")
    how.add_argument("--quality", choices=("auto",),
                     help="--refine until the label-free re-render error stops improving (at most the preset's "
                          "length); skipped altogether when "
                          "the preview already re-renders the photo as well as a typical fine-tune "
                          f"(sRGB RMSE <= {SKIP_REFINE_RMSE} under the flash) and keeps the flash highlight out of "
                          f"its maps (burn-in <= {SKIP_REFINE_BURN_IN})")
    p.add_argument("-q", "--quiet", action="store_true", help="print errors only")
    p.add_argument("-v", "--verbose", action="store_true", help="print model details, and tracebacks on errors")
    p.add_argument("--version", action="version", version=f"{prog} {__version__}")


def check_options(args) -> Optional[str]:
    """The usage error of the options of :func:`add_texture_options` that argparse cannot check, or None."""
    if args.fov is not None and not 1.0 <= args.fov <= 170.0:
        return f"--fov must be in [1, 170] degrees, got {args.fov}"
    if args.max_size < 8:
        return f"--max-size must be >= 8, got {args.max_size}"
    if args.tile < min_tile():
        return (f"--tile must be >= {min_tile()} (4 x the {min_tile() // 4} px overlap of neighbouring tiles; "
                f"smaller tiles leave a grid in the maps), got {args.tile}")
    if (args.iters or args.quality) and not args.refine:
        return "--iters and --quality need --refine"
    if args.maps != MAP_NAMES and args.target != "generic":
        return f"--maps needs --target generic: the {args.target} preset converts all four maps"
    if getattr(args, "view", False) and (args.maps != MAP_NAMES or args.target != "generic"):
        return "--view needs all four maps and --target generic (it relights the project's own texture set)"
    return None


def _error(msg: str) -> None:
    from .progress import write

    write(f"{PROG}: error: {cli_message(msg)}")


def min_tile() -> int:
    """The smallest ``--tile``: each tile keeps the full blending overlap
    (:data:`~svbrdf.runtime.tiling.DEFAULT_OVERLAP`) on both sides and as much again of its own. Smaller tiles
    see too little of the photo (the generator normalises each tile by its own statistics) and leave a grid in
    the maps."""
    from .tiling import DEFAULT_OVERLAP

    return 4 * DEFAULT_OVERLAP


def _load_refine():
    """The runtime's one call into the trainer, :func:`svbrdf.trainer.refine.refine`, imported only for ``--refine``.

    Raises:
        MissingExtraError: torch or kornia (the training side) is not installed; the message names the pip command
            for this installation (:func:`svbrdf.runtime.install.train_hint`).
    """
    try:
        from svbrdf.trainer.refine import refine
    except ImportError as exc:
        module = missing_train_module(exc)
        if module is None:
            raise
        raise MissingExtraError(train_hint("--refine", module)) from None
    return refine


def _refine(refine, image, session, config, args, name: str):
    """Fine-tune the model's training checkpoint on ``image`` ((H, W, 3) linear), or with ``--quality auto`` keep
    the preview when it already explains the photo; returns the Maps (``meta["refine"]`` says which)."""
    from .imageio import ImageWarning
    from .manifest import find_checkpoint
    from .progress import Progress, loss_postfix
    from .session import estimate

    preview = None
    if args.quality == "auto":  # the skip rule compares the instant preview with the photo
        with warnings.catch_warnings():  # the photo itself was checked (and named) by the caller
            warnings.simplefilter("ignore", ImageWarning)
            preview = estimate(image, session, max_size=args.max_size, tile=args.tile, maps=MAP_NAMES)

    bar = None

    def progress(trainer, record):  # the Progress is made at the first iteration, when the length is known
        nonlocal bar
        if bar is None:
            bar = Progress(trainer.iters, f"refine {name}", quiet=args.quiet, initial=record["step"] - 1)
        bar.update(record["step"], **loss_postfix(record))

    try:
        return refine(image, lambda: find_checkpoint(session.info), quality=args.quality or "fixed",
                      iters=args.iters, threads=args.threads, name=name, callback=progress, preview=preview,
                      render_config=config)
    finally:
        if bar is not None:
            bar.close()


def photo_maps(photo: Path, session, config, args, refine=None, name: Optional[str] = None):
    """The texture set of one photo with the options ``args`` (:func:`add_texture_options`): the preview, or the
    refine with ``refine`` (see :func:`_load_refine`). The one per-photo path of ``svbrdf-preview`` and
    ``svbrdf-batch``.

    Returns:
        ``(maps, relit, detail)``: the :class:`~svbrdf.runtime.maps.Maps` (the requested maps, at the processed
        size, ``render_config`` = ``config``), the relit panel (sRGB (h, 3 w, 3), None without all four maps) and a
        short report (``"model 0.41 s"``, ``"refined 300 it"``, ...).

    Raises:
        SvbrdfError: the photo cannot be read or processed; with ``args.tileable``, maps smaller than
            :data:`~svbrdf.runtime.tileable.MIN_SIZE` a side (the message names ``photo``).
    """
    from .session import estimate
    from .texture_set import relit_panel

    if args.refine:
        from .imageio import read_image
        from .session import warn_if_greyscale

        image = read_image(photo, max_size=args.max_size)
        warn_if_greyscale(image, str(photo))
        maps = _refine(refine, image, session, config, args, name or photo.name)
        record = maps.meta["refine"]
        if record.get("skipped"):
            detail = f"refine skipped: the preview explains the photo (RMSE {record['preview_input_rmse']:.3f}, " \
                     f"burn-in {record['preview_burn_in']:.2f})"
        else:
            detail = f"refined {record['iterations']} it"
        # The fine-tune trains (and its losses render) every map; only the requested ones are written.
        maps = maps.subset(args.maps)
        maps.meta.update(source=str(photo), model={"path": str(session.path), "sha256": session.info.sha256},
                         maps=list(args.maps))
    else:
        maps = estimate(photo, session, max_size=args.max_size, tile=args.tile, maps=args.maps)
        tiles = maps.meta["tiles"]
        detail = f"model {maps.meta['timings']['infer']:.2f} s" + (f", {tiles} tiles" if tiles > 1 else "")
    maps.render_config = config
    if getattr(args, "tileable", False):
        from .tileable import make_tileable

        try:
            maps = make_tileable(maps)
        except SvbrdfError as exc:  # a photo too small for it: say which one
            raise SvbrdfError(f"{photo}: --tileable: {exc}") from None
        worst = [s["after"] for s in maps.meta["tileable"]["join"].values() if s["after"] is not None]
        detail += f", tileable (join score {max(worst):.2f})" if worst else ", tileable"
    relit = relit_panel(maps, config) if maps.complete else None  # the panel renders all four maps
    return maps, relit, detail


def write_maps(maps, relit, out_dir: Path, name: str, args, extra_meta: dict):
    """Write ``maps`` (and ``relit``) as the texture set ``name`` in ``out_dir`` for ``args.target`` (all or
    nothing, :mod:`svbrdf.runtime.texture_set`), and with ``args.view`` its viewer page
    (:func:`svbrdf.runtime.viewer.write_viewer`); returns the written paths by role."""
    from .targets import write_target
    from .texture_set import write_texture_set

    if args.target != "generic":
        return write_target(maps, out_dir, name, args.target, force=args.force, extra_meta=extra_meta, relit=relit)
    paths = write_texture_set(maps, out_dir, name, normal=args.normal, fmt=args.format,
                              force=args.force, extra_meta=extra_meta, relit=relit)
    if getattr(args, "view", False):
        from .viewer import write_viewer

        paths["viewer"] = write_viewer(paths["sidecar"], force=args.force)
    return paths


def _process(photo: Path, session, config, args, out_dir: Path, refine=None) -> str:
    """Estimate (or refine with ``refine``, see :func:`_load_refine`), render and write one texture set; returns the
    report line."""
    from .errors import exists_message

    start = time.perf_counter()
    name = photo.stem
    # Cheap early refusal before minutes of inference; write_texture_set re-checks every file it writes.
    if not args.force:
        from .viewer import VIEWER_FILE

        for early in [f"{name}.json"] + ([VIEWER_FILE.format(name=name)] if args.view else []):
            if (out_dir / early).exists():
                raise SvbrdfError(exists_message(out_dir / early))
    maps, relit, detail = photo_maps(photo, session, config, args, refine)
    write_maps(maps, relit, out_dir, name, args, {"tool": f"{PROG} {__version__}"})
    h, w = maps.shape
    burn = f"burn-in {maps.meta['burn_in']['burn_in']:.2f}"
    if "burn_in_model" in maps.meta:  # the network's maps before the post-processing
        fill = maps.meta.get("highlight_fill") or {}
        steps = "highlight fill and flash-trend removal" if fill.get("filled") else "flash-trend removal"
        burn += f", {maps.meta['burn_in_model']['burn_in']:.2f} before {steps}"
    return f"{photo} -> {out_dir}/{name}_*  {w}x{h}  {time.perf_counter() - start:.2f} s ({detail}; {burn})"


def _run(args) -> int:
    if args.target != "generic" and (args.normal != "opengl" or args.format != "png"):
        raise SvbrdfError("--normal and --format apply to --target generic only; the other targets fix them")
    refine = _load_refine() if args.refine else None  # before any work: every photo would fail the same way
    from .session import load_session

    session = load_session(args.model, threads=args.threads, maps=args.maps)
    config = session.render_config
    if args.fov is not None:
        config = config.replace(fov_deg=args.fov)
    if args.verbose:
        info = session.info
        state = "verified" if info.verified else info.note
        print(f"model: {info.path} ({info.source}, sha256 {info.sha256[:12]}, {state}); "
              f"{', '.join(session.providers)}, {session.threads} threads; graph {session.graph_for()}")
    if args.maps != MAP_NAMES and not args.quiet:
        print(f"{PROG}: note: no relit panel with --maps (it renders all four maps)", file=sys.stderr)

    from .progress import Progress, write

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
                line = _process(photo, session, config, args, out_dir, refine)
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


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``svbrdf-preview``; returns the exit code (see the module docstring)."""
    parser = build_parser()
    args, code = parse_command_line(parser, argv)
    if args is None:  # --help / --version (0) or a usage error (2)
        return code
    problem = check_options(args)
    if problem:
        return _usage(parser, problem)
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
