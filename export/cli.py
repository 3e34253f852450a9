"""``svbrdf-export``: training checkpoint -> ONNX preview model, its part graphs and a manifest (see
:mod:`svbrdf.export.onnx`).

Exit codes: 0 success, 2 usage error or the training side (torch, onnx) not installed (one line naming the pip
command), 1 failure (one line ``svbrdf-export: error: <message>`` on stderr; ``--verbose`` adds the traceback).
"""

from __future__ import annotations

import argparse
import logging
import sys
import traceback
import warnings
from pathlib import Path
from typing import List, Optional

from svbrdf.runtime.errors import SvbrdfError, cli_message, parse_command_line
from svbrdf.runtime.install import missing_train_module, train_hint
from svbrdf.runtime.inference.manifest import DECODERS, part_file_name

PROG = "svbrdf-export"

_PART_FILES = " and ".join(part_file_name("NAME.onnx", d.part) for d in DECODERS)
EXAMPLES = f"""\
examples:
  {PROG} runs/wood/checkpoint.pt                    writes runs/wood/checkpoint.onnx + checkpoint.json
  {PROG} runs/pretrain/final.pt -o models/svbrdf-v1.onnx --force

Besides NAME.onnx (all four maps) it writes one graph per decoder
({_PART_FILES}),
so that `svbrdf-preview --maps` runs only the decoder it needs; NAME.json lists them with their sha256.
Every graph is checked (onnx.checker, then onnxruntime against torch at 64x64, 75x101 and 96x160) before
anything is written; if any output file exists, nothing is written without --force. To ship a model as the
packaged default, put the three .onnx files and the checkpoint into models/ and rename NAME.json
to models/manifest.json.
"""


def _version() -> str:
    try:
        from importlib.metadata import version

        return version("svbrdf")
    except Exception:  # source tree without an install
        return "0.0.0+local"


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description="Export a trained generator to single-file ONNX models "
                                                       "(the full graph and one per decoder).",
                                epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("checkpoint", metavar="CKPT", type=Path, help="training checkpoint (.pt) from svbrdf-train")
    p.add_argument("-o", "--out", metavar="PATH", type=Path,
                   help="output .onnx file (default: CKPT with the suffix .onnx); the part graphs and the manifest "
                        "go beside it")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.add_argument("--opset", metavar="N", type=int, default=None, help="ONNX opset (default: 18)")
    p.add_argument("-q", "--quiet", action="store_true", help="print errors only")
    p.add_argument("-v", "--verbose", action="store_true", help="print tracebacks on errors")
    p.add_argument("--version", action="version", version=f"{PROG} {_version()}")
    return p


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``svbrdf-export``; returns the exit code."""
    parser = build_parser()
    args, code = parse_command_line(parser, argv)
    if args is None:  # --help / --version (0) or a usage error (2)
        return code
    out = args.out if args.out is not None else args.checkpoint.with_suffix(".onnx")
    if out.suffix != ".onnx":
        parser.print_usage(sys.stderr)
        print(f"{PROG}: error: the output file must end in .onnx, got {out}", file=sys.stderr)
        return 2
    try:
        from .onnx import OPSET, export_generator

        # The exporter's "torchvision is not installed" log lines and deprecation warnings are not the user's
        # business; real failures still raise.
        logging.getLogger("torch.onnx").setLevel(logging.ERROR)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            report = export_generator(args.checkpoint, out, opset=args.opset or OPSET, force=args.force)
    except KeyboardInterrupt:
        print(f"{PROG}: error: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        module = missing_train_module(exc)
        if module is not None:  # the light install: say what to install
            print(f"{PROG}: error: {train_hint('this command', module)}", file=sys.stderr)
            return 2
        msg = cli_message(exc) if isinstance(exc, SvbrdfError) else f"{type(exc).__name__}: {exc}"
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        if args.verbose:
            traceback.print_exc()
        return 1
    if not args.quiet:
        parts = ", ".join(f"{p['path'].name} {p['bytes'] / 1e6:.1f} MB (max |diff| {p['max_abs_diff']:.1e})"
                          for p in report["parts"].values())
        print(f"{report['path']}: {report['bytes'] / 1e6:.1f} MB, opset {report['opset']}, sha256 "
              f"{report['sha256'][:12]}, onnxruntime vs torch max |diff| {report['max_abs_diff']:.1e}; parts "
              f"{parts}; manifest {report['manifest_path']} ({report['seconds']:.1f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
