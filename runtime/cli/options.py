"""The per-photo options of ``svbrdf-preview`` and ``svbrdf-batch``: the arguments (:func:`add_texture_options`),
the checks argparse cannot make (:func:`check_options`) and the :class:`~svbrdf.runtime.workflow.options.PhotoOptions`
built from them (:func:`photo_options`). Light: heavy modules are imported only once the arguments are parsed."""

from __future__ import annotations

import argparse
from typing import Optional

from .. import __version__
from ..core.maps import MAP_NAMES, select_maps
from ..core.relief import AO_STRENGTH, RELIEF_NAMES
from ..errors import SvbrdfError
from ..inference.guided import Upsampling
from ..outputs.choices import SUPPORTED_NORMAL_CONVENTIONS, TARGETS, normal_convention

PROG = "svbrdf-preview"

__all__ = ["add_texture_options", "check_options", "photo_options", "min_tile"]


def _at_least(text: str, low: int, what: str = "an integer") -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
    if value < low:
        raise argparse.ArgumentTypeError(f"must be >= {low}, got {value}")
    return value


def _positive(text: str) -> int:
    return _at_least(text, 1)


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def _network_size(text: str):
    """``--network-size``: ``full`` or a long side >= 8 -> :class:`~svbrdf.runtime.inference.guided.Upsampling`."""
    if text.strip().lower() == "full":
        return Upsampling(network_size=None)
    return Upsampling(network_size=_at_least(text, 8, "an integer or 'full'"))


def _map_list(text: str) -> tuple:
    """``--maps``: comma list of map names (or aliases), relief names included -> ``(maps, relief)``: the maps to
    compute in packing order (with the normal map when a relief map is asked for) and the relief maps."""
    parts = [part.strip() for part in text.split(",") if part.strip()]
    relief = tuple(n for n in RELIEF_NAMES if n in parts)
    rest = [n for n in parts if n not in RELIEF_NAMES] + (["normal"] if relief else [])
    try:
        return select_maps(rest), relief
    except SvbrdfError as exc:
        raise argparse.ArgumentTypeError(f"{exc}; relief maps: {', '.join(RELIEF_NAMES)}") from None


class _MapsAction(argparse.Action):
    """``--maps LIST`` sets ``maps`` (the network's maps) and ``relief`` (the maps derived from the normals)."""

    def __call__(self, parser, namespace, values, option_string=None):
        namespace.maps, namespace.relief = values


def add_texture_options(p: argparse.ArgumentParser, prog: str = PROG) -> None:
    """The options of how one photo becomes a texture set (model, threads, target, maps, refine, ...), shared by
    ``svbrdf-preview`` and ``svbrdf-batch``; :func:`check_options` checks what argparse cannot."""
    p.add_argument("--model", metavar="PATH", help="ONNX model (default: $SVBRDF_MODEL, else the packaged model)")
    p.add_argument("--threads", metavar="N", type=_positive, help="CPU threads (default: all cores)")
    p.add_argument("--fov", metavar="DEG", type=float,
                   help="camera field of view across the photo width, for the relit panel, the viewer and the "
                        "refine's renderer (default: from the photo's EXIF focal length, else the model's training "
                        "value; the sidecar's camera says which)")
    p.add_argument("--normal", type=normal_convention, choices=SUPPORTED_NORMAL_CONVENTIONS, default="opengl",
                   help="normal map convention: opengl (or gl) = green up; dx = DirectX, green down (default: opengl)")
    p.add_argument("--format", choices=("png", "exr"), default="png",
                   help="normal/roughness/specular/height/ao files: 16-bit png or float exr (default: png)")
    p.add_argument("--max-size", metavar="N", type=_positive, default=2048,
                   help="downsize photos whose long side exceeds N pixels (default: 2048)")
    p.add_argument("--network-size", metavar="N", dest="upsampling", type=_network_size, default=Upsampling(),
                   help="the network sees the photo in pixel blocks, at most N px long, and the maps get the "
                        "photo's own detail back at its size (default: 512: better maps than at 1024 px, in half "
                        "the time); 'full': the network at the photo's own size, in tiles (the reference)")
    p.add_argument("--tile", metavar="N", type=_positive, default=1024,
                   help="process larger images in overlapping N x N tiles to bound memory (default: 1024; "
                        f"at least {min_tile()})")
    p.add_argument("--target", choices=TARGETS, default="generic",
                   help="output preset: file names, normal convention, packing and material document "
                        "(generic, gltf, blender, unreal, unity, usd, mtlx, ambientcg; see docs/targets.md)")
    p.add_argument("--maps", metavar="LIST", type=_map_list, default=MAP_NAMES, action=_MapsAction,
                   help="comma list of the maps to compute and write: diffuse (or basecolor), specular, roughness, "
                        "normal, height, ao (default: all). height and ao are derived from the normal map, which "
                        "is written with them (white = high; AO 1 = open). roughness/normal alone run only the "
                        "normal-roughness decoder, diffuse/specular only the diffuse-specular one; no relit panel "
                        "without all four of diffuse, specular, roughness, normal; other targets need those four")
    p.set_defaults(relief=RELIEF_NAMES)
    p.add_argument("--ao-strength", metavar="K", type=_positive_float, default=AO_STRENGTH,
                   help=f"the AO is that of the height x K (default: {AO_STRENGTH:g}, the measured flatness of the "
                        "model's normal maps against ground truth; 1 = the depth the normal map implies)")
    p.add_argument("--tileable", action="store_true",
                   help="make the maps repeat without a visible seam, at the same size and scale (all four cut "
                        "the same way; the sidecar records the join and seam scores)")
    p.add_argument("--view", action="store_true",
                   help="also write <name>_view.html: the maps relit in the browser with the project's renderer, "
                        "one tile and repeated, with relief (parallax from the height) and ambient (occluded by "
                        "the AO) controls (all four maps; with any --target)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.add_argument("--refine", action="store_true",
                   help="correct the preview on each photo with torch (about 2 s a photo on one core): its specular "
                        "and roughness maps shifted, one level each, to fit the photo under its flash and camera "
                        "(--fov); base colour and normals stay the preview's. The result is the preview unless the "
                        "fit re-renders held-out blocks of the photo at least 1%% better in each of 4 "
                        "cross-validation folds without raising the burn-in (the terminal line and the sidecar's "
                        "refine record say which)")
    how = p.add_mutually_exclusive_group()
    how.add_argument("--iters", metavar="N", type=_positive,
                     help="--refine: Adam steps of each of its fits (at most 4 cross-validation folds, judged in turn "
                          "until one is lost, and the final one; default 25)")
    how.add_argument("--quality", choices=("auto",),
                     help="--refine: each fit until its error on the photo stops improving (at most 25 steps); the "
                          "held-out check still decides between the fit and the preview")
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
    capture = getattr(args, "capture", None)
    if capture is not None and (args.refine or args.quality):
        return "--capture fits the views itself: no --refine or --quality with it"
    if (args.iters and not (args.refine or capture is not None)) or (args.quality and not args.refine):
        return "--iters and --quality need --refine" + (" (--iters: or --capture)" if hasattr(args, "capture") else "")
    if args.maps != MAP_NAMES and args.target != "generic":
        return (f"--maps needs --target generic: the {args.target} preset converts all four maps "
                f"({', '.join(MAP_NAMES)})")
    if getattr(args, "view", False) and args.maps != MAP_NAMES:
        return "--view needs all four maps (it relights them)"
    return None


def min_tile() -> int:
    """The smallest ``--tile``: each tile keeps the full blending overlap
    (:data:`~svbrdf.runtime.inference.tiling.DEFAULT_OVERLAP`) on both sides and as much again of its own. Smaller tiles
    see too little of the photo (the generator normalises each tile by its own statistics) and leave a grid in
    the maps."""
    from ..inference.tiling import DEFAULT_OVERLAP

    return 4 * DEFAULT_OVERLAP


def photo_options(args: argparse.Namespace, **changes):
    """The :class:`~svbrdf.runtime.workflow.options.PhotoOptions` of parsed arguments (:func:`add_texture_options`),
    with ``changes``."""
    from ..workflow.options import PhotoOptions

    return PhotoOptions.from_mapping(args).replace(**changes) if changes else PhotoOptions.from_mapping(args)
