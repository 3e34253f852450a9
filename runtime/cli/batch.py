"""``svbrdf-batch``: a folder (or list) of flash photos -> a material library, resumable, locally or on Ray.

A thin command over :func:`svbrdf.runtime.batch.run_batch`; the per-photo options are ``svbrdf-preview``'s
(:func:`svbrdf.runtime.cli.options.add_texture_options`, a :class:`~svbrdf.runtime.workflow.options.PhotoOptions`), ``--tileable`` (maps that repeat without a seam) and ``--view``
(``LIBRARY/<name>/<name>_view.html``, the set relit in the browser, linked from the contact sheet) included. Exit
codes: 0 every photo done (now or before), 1 a photo failed or was refused (one line ``svbrdf-batch: error: ...``
each; the others are done), 2 a usage error (``--view`` without all four maps included;
nothing is written), ``--refine`` without torch or ``--ray`` without Ray, 130 interrupted (what finished is kept;
run the command again to go on).
"""

from __future__ import annotations

import argparse
import sys
import traceback
from pathlib import Path
from typing import List, Optional

from ..errors import MissingExtraError, SvbrdfError, cli_message, parse_command_line
from .options import _positive, add_texture_options, check_options, photo_options

PROG = "svbrdf-batch"

EXAMPLES = f"""\
examples:
  {PROG} photos/ -o library/                 every photo of the folder, a preview each
  {PROG} 'scans/*.jpg' @more.txt -o library/  a glob and a list file (one photo per line)
  {PROG} photos/ -o library/ --refine --quality auto   fine-tune where the preview is not enough (needs torch)
  {PROG} photos/ -o library/ --ray auto --threads 4    on the Ray cluster this machine belongs to
  {PROG} photos/ -o library/ --tileable --view         seamless maps, and a page to relight each in the browser

Run the same command again to go on after an interruption or a crash: done photos (same content, same options)
are skipped, failed ones retried. LIBRARY/<name>/ holds each texture set (with --view also <name>_view.html),
LIBRARY/library.json the manifest, LIBRARY/index.html (open it from disk; a "view" link per viewer page) and
index.png the contact sheet, worst re-render first. Adding or dropping --tileable or --view changes the options:
the done photos are then redone only with --force. Each set has its height and AO maps by default; a library made
before they existed (or with --maps) is redone with them only with --force.
"""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description="Make a material library: one texture set per flash photo, resumable, on a local process pool "
                    "or a Ray cluster.",
        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("photos", nargs="+", metavar="PHOTOS",
                   help="photo files, folders (their photos), glob patterns, or @LIST (a file with one per line)")
    p.add_argument("-o", "--out", metavar="LIBRARY", type=Path, required=True, help="the library folder")
    add_texture_options(p, PROG)
    p.add_argument("--workers", metavar="N", type=_positive,
                   help="photos at a time in the local pool (default: cores / --threads; one with --refine on a "
                        "GPU); with --ray and no ADDRESS, the CPUs of the local Ray instance")
    p.add_argument("--ray", metavar="ADDRESS", nargs="?", const="local",
                   help="run the photos as Ray tasks (the [cluster] extra): on the cluster at ADDRESS "
                        "('auto': the one this machine joined), or on a new local instance without ADDRESS; "
                        "each task takes --threads CPUs (default 1)")
    p.add_argument("--gpus-per-task", metavar="F", type=float, default=0.0,
                   help="with --ray: GPUs each task asks for (e.g. 1 for --refine on GPU nodes; default 0)")
    p.epilog = EXAMPLES
    return p


def _error(msg: str) -> None:
    from ..progress import write

    write(f"{PROG}: error: {cli_message(msg)}")


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``svbrdf-batch``; returns the exit code (see the module docstring)."""
    parser = build_parser()
    args, code = parse_command_line(parser, argv)
    if args is None:
        return code
    problem = check_options(args)
    if problem is None and args.target != "generic" and (args.normal != "opengl" or args.format != "png"):
        problem = "--normal and --format apply to --target generic only; the other targets fix them"
    if problem is None and args.gpus_per_task and not args.ray:
        problem = "--gpus-per-task needs --ray"
    if problem is None and args.gpus_per_task < 0:
        problem = f"--gpus-per-task must be >= 0, got {args.gpus_per_task}"
    if problem:
        parser.print_usage(sys.stderr)
        _error(problem)
        return 2
    from ..batch import collect_photos, run_batch
    from ..progress import write

    try:
        photos = collect_photos(args.photos)
        summary = run_batch(
            photos, args.out, photo_options(args), engine="ray" if args.ray else "local", workers=args.workers,
            ray_address=None if args.ray == "local" else args.ray, gpus_per_task=args.gpus_per_task,
            report=(lambda line: None) if args.quiet else (lambda line: write(line, file=sys.stdout)),
            warn=(lambda line: None) if args.quiet else (lambda line: write(f"{PROG}: warning: {line}")),
            error=_error)
    except KeyboardInterrupt:
        _error("interrupted (run the same command again to go on)")
        return 130
    except MissingExtraError as exc:
        _error(str(exc))
        return 2
    except SvbrdfError as exc:
        _error(str(exc))
        if args.verbose:
            traceback.print_exc()
        return 1
    if not args.quiet:
        total = len(summary.records)
        done = sum(r.get("status") == "done" for r in summary.records.values())
        write(f"{PROG}: {summary.done} done, {summary.failed} failed, {summary.skipped} already done"
              f"{f', {summary.refused} refused' if summary.refused else ''}; library {args.out}: {done}/{total} "
              f"done; contact sheet {args.out / 'index.html'}")
    return 1 if summary.failed or summary.refused else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
