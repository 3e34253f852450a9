"""Picture grid of real photos refined with two presets: photo, the four maps, and renders under three lights.

::

    python -m svbrdf.trainer.tools.before_after PHOTO [PHOTO ...] --presets fast-v1,fast --out grid.png

One row per photo and preset (photos outer, presets inner): the photo (centre square at ``--size``), base colour,
normal, roughness, specular, then the maps re-lit by the flash and by two lights from the upper left and the
lower right (:func:`svbrdf.runtime.outputs.texture_set.relit_panel`). Where the highlight is out of the maps it moves
with the light; where it is burnt in, it stays at the centre. Every row is a fine-tune from the same stage-one
checkpoint (default: the packaged one), as ``svbrdf-train finetune`` runs it. A JSON beside the PNG records the
rows' label-free burn-in (:func:`svbrdf.runtime.quality.burn_in.photo_burn_in`) and fine-tune times.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from svbrdf.runtime.quality.burn_in import photo_burn_in
from svbrdf.runtime.core.colour import linear_to_srgb
from svbrdf.trainer.bench.datasets import Case
from svbrdf.runtime.errors import SvbrdfError
from svbrdf.runtime.io.images import WRITE_EXTENSIONS, write_image
from svbrdf.runtime.core.maps import Maps, encode_normal
from svbrdf.runtime.core.render import ZHAO
from svbrdf.runtime.outputs.texture_set import relit_panel


def row_image(photo: np.ndarray, maps: Maps) -> np.ndarray:
    """(S, 8 S, 3) sRGB-encoded row: photo, base colour, normal, roughness, specular, three relit panels (rendered
    at the maps' size, so that a square larger than the texture set's panel size lines up)."""
    grey = lambda a: np.repeat(a, 3, axis=-1)  # noqa: E731
    parts = [linear_to_srgb(np.clip(photo, 0, 1)), linear_to_srgb(maps.diffuse), encode_normal(maps.normal),
             grey(maps.roughness), grey(linear_to_srgb(maps.specular)), relit_panel(maps, ZHAO, size=None)]
    return np.concatenate([np.asarray(p, np.float32) for p in parts], axis=1)


def split_presets(text: str) -> List[str]:
    """``--presets`` as a list: split at the commas outside brackets, so a setting may hold a JSON list
    (``fast,fast+anchor_maps=["normal","roughness"]`` is two presets)."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        depth += {"[": 1, "{": 1, "]": -1, "}": -1}.get(ch, 0)
        if ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p for p in parts if p]


def _preset_spec(spec: str) -> Tuple[str, Dict[str, Any]]:
    """``"fast+flash_trend=false+lr=1e-4"`` -> ``("fast", {"flash_trend": False, "lr": 0.0001})``
    (:func:`svbrdf.trainer.config.parse_settings`)."""
    from svbrdf.trainer.config import parse_settings

    name, *pairs = spec.split("+")
    try:
        return name, parse_settings(pairs)
    except ValueError as e:
        raise SvbrdfError(f"--presets {spec}: {e}") from None


def main(argv: Optional[Sequence[str]] = None) -> int:
    from svbrdf.trainer import train as T
    from svbrdf.trainer.stage import make_trainer
    from svbrdf.trainer.bench.cases import prepare_case
    from svbrdf.trainer.checkpoint import default_checkpoint
    from svbrdf.trainer.checkpoint import load_checkpoint
    from svbrdf.trainer.config import resolve

    p = argparse.ArgumentParser(prog="python -m svbrdf.trainer.tools.before_after", description=__doc__.split("\n\n")[0])
    p.add_argument("photos", nargs="+", type=Path)
    p.add_argument("--presets", default="fast-v1,fast",
                   help="comma list, one row per preset (default fast-v1,fast); a preset may carry settings after "
                        "'+', e.g. fast+flash_trend=false or fast+anchor_maps=[\"normal\",\"roughness\"] (JSON values)")
    p.add_argument("--iters", type=int, default=600, help="fine-tune iterations (default 600)")
    p.add_argument("--size", type=int, default=256, help="side of the centre square, px (default 256)")
    p.add_argument("--init", type=Path, default=None, help="stage-one checkpoint (default: the packaged model's)")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--out", type=Path, required=True, help="PNG path (a JSON is written beside it)")
    p.add_argument("--force", action="store_true", help="overwrite existing outputs")
    args = p.parse_args(argv)
    try:
        if args.out.exists() and not args.force:
            raise SvbrdfError(f"{args.out}: exists (use --force to overwrite)")
        if args.out.suffix.lower() not in WRITE_EXTENSIONS:  # before minutes of fine-tunes, not after
            raise SvbrdfError(f"{args.out}: unsupported output format {args.out.suffix or '(none)'!r} "
                              f"(use {', '.join(WRITE_EXTENSIONS)})")
        init = args.init or default_checkpoint()
        if init is None:
            raise SvbrdfError("no stage-one checkpoint: pass --init CKPT")
        ckpt = load_checkpoint(init)
        presets = split_presets(args.presets)
        rows: List[np.ndarray] = []
        record = {"command": " ".join(["python -m svbrdf.trainer.tools.before_after"] + list(argv or sys.argv[1:])),
                  "init": str(init), "iters": args.iters, "presets": presets, "rows": []}
        for path in args.photos:
            if not path.is_file():
                raise SvbrdfError(f"{path}: no such file")
            case = prepare_case(Case(name=path.stem, path=path, kind="photo", format="photo"), args.size)
            photo = T.photo_to_tensor(case.photo)
            for preset in presets:
                name, settings = _preset_spec(preset)
                try:
                    cfg = resolve(name, **{"quality": "fixed", "checkpoint_every": 0, "iters_finetune": args.iters,
                                           **settings})
                except ValueError as e:
                    raise SvbrdfError(f"--presets {preset}: {e}") from None
                t = time.perf_counter()
                trainer = make_trainer(photo, "finetune", cfg, init=ckpt, threads=args.threads,
                                       photo_info=T.tensor_photo_info(photo, path.name))
                trainer.run()
                maps = trainer.predict_maps()
                burn = photo_burn_in(maps, case.photo)
                record["rows"].append({"photo": str(path), "preset": preset, "seconds": time.perf_counter() - t,
                                       **{k: v for k, v in burn.items() if k != "centre"}})
                print(f"{path.name} {preset}: burn-in {burn['burn_in']:.2f}", file=sys.stderr, flush=True)
                rows.append(row_image(case.photo, maps))
        write_image(args.out, np.concatenate(rows, axis=0), bits=8, force=args.force)
        args.out.with_suffix(".json").write_text(json.dumps(record, indent=1) + "\n")
    except SvbrdfError as e:
        print(f"before_after: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
