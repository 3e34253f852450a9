"""Trainer checkpoint (or Generator module) -> one self-describing ONNX file, checked against torch.

The graph (torch.onnx dynamo exporter, opset :data:`OPSET`, one file: ``external_data=False``):

* input ``"image"``: (1, 3, H, W) float32, **linear** RGB photo (the runtime removes the sRGB curve first),
  any H, W >= 8 (dynamic ``torch.export.Dim``; the Generator pads to a multiple of 4 and crops back inside
  the graph, so odd sizes come back at input size);
* output ``"maps"``: (1, 8, H, W) float32, packed maps in their final ranges (layout of
  :mod:`svbrdf.runtime.core.maps`: diffuse 0:3 linear [0, 1], specular 3:4 linear [0, 1], roughness 4:5 [0, 1],
  normal 5:8 unit OpenGL).

Part graphs (maps on demand, docs/decisions/018-maps-on-demand.md): beside ``NAME.onnx`` the same generator is
exported once per decoder, ``NAME.<part>.onnx`` for each part of :data:`svbrdf.runtime.inference.manifest.PARTS`
(encoder + that decoder only; the other decoder's weights are not in the file). Same input and output contract,
the channels of the maps a part does not compute are NaN (specified in :mod:`svbrdf.runtime.inference.manifest`).
Each part is checked like the full graph (checker; onnxruntime against torch on its own channels, NaN on the others).

Provenance goes twice: into the ONNX ``metadata_props`` (every manifest key except ``file``/``sha256``/
``parts``, values JSON-encoded; a part adds ``"part": {"name", "maps"}``) and into a manifest ``NAME.json``
beside ``NAME.onnx`` (schema :data:`svbrdf.runtime.inference.manifest.MANIFEST_SCHEMA`, with the file's sha256, the parity
result and the ``"parts"`` entry), which the runtime verifies at load. Every file is written atomically, and
none before all the checks pass; existing files are refused (all of them) unless ``force``.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import time
from pathlib import Path
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import onnx
import torch
from torch import nn

from svbrdf.runtime.errors import ModelError, SvbrdfError, exists_message
from svbrdf.runtime.io.files import staged_write
from svbrdf.runtime.core.maps import MAP_CHANNELS, MAP_NAMES, N_CHANNELS, SLICES
from svbrdf.runtime.inference.manifest import (
    INPUT_NAME, MANIFEST_SCHEMA, MIN_SIZE, OUTPUT_NAME, PARTS, input_contract, map_layout, part_file_name,
    sha256_file,
)
from svbrdf.runtime.core.render import ZHAO, RenderConfig
from svbrdf.trainer.models import pack_maps

#: ONNX opset written. 18 is torchlib's native opset in torch 2.13
#: (``torch.onnx._internal.exporter._constants.TORCHLIB_OPSET``): no version-conversion pass is involved.
OPSET = 18
#: Largest accepted |onnxruntime - torch| on the parity sizes (float32).
PARITY_ATOL = 1e-4
#: Parity sizes (H, W): square, odd and non-square, wide.
DEFAULT_SIZES: Tuple[Tuple[int, int], ...] = ((64, 64), (75, 101), (96, 160))

PathLike = Union[str, os.PathLike]


class _Graph(nn.Module):
    """Fixes the graph signature: one input named ``image``, the Generator's packed maps out.

    With ``maps`` a part's maps, only the decoder of those maps runs and the other channels are NaN.
    """

    def __init__(self, generator: nn.Module, maps: Tuple[str, ...] = MAP_NAMES):
        super().__init__()
        self.generator = generator
        self.maps = tuple(maps)

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        if self.maps == MAP_NAMES:
            return self.generator(image)
        g = self.generator
        done = g.decode(g.forward_features(image), maps=self.maps, size=(image.shape[-2], image.shape[-1]))
        blank = torch.full_like(next(iter(done.values()))[:, :1], float("nan"))
        return pack_maps({**{n: blank.expand(-1, MAP_CHANNELS[n], -1, -1) for n in MAP_NAMES}, **done})


def _versions() -> Dict[str, str]:
    import onnxscript

    try:
        from importlib.metadata import version

        svbrdf_version = version("svbrdf")
    except Exception:  # source tree without an install
        svbrdf_version = "0.0.0+local"
    return {"svbrdf": svbrdf_version, "torch": str(torch.__version__), "onnx": onnx.__version__,
            "onnxscript": onnxscript.__version__, "exporter": "torch.onnx.export(dynamo=True)"}


def _provenance(meta: Mapping[str, Any], generator: nn.Module) -> Dict[str, Any]:
    """Manifest keys that come from the checkpoint metadata (or defaults for a bare module)."""
    train = dict(meta.get("train_config") or {})
    post = train.get("post")
    if isinstance(post, Mapping):  # the runtime reads a fine-tuned network's input at train_config.even_lighting
        train["even_lighting"] = float(post.get("even_lighting") or 0.0)  # (PreviewSession.input_lighting)
    render = RenderConfig(**train["render"]) if "render" in train else ZHAO
    cfg = getattr(generator, "cfg", None)
    photo = dict(meta.get("photo") or {})
    return {
        "render_config": render.to_dict(),
        "training": {
            "preset": train.get("preset"),
            "stage": meta.get("stage"),
            "step": meta.get("step"),
            "iters": meta.get("iters"),
            "generator_config": meta.get("generator_config") or (cfg.to_dict() if cfg is not None else None),
            "train_config": train or None,
            "date": meta.get("date"),
        },
        "photo": {"name": photo.get("name"), "sha256": photo.get("sha256"),
                  "height": photo.get("height"), "width": photo.get("width")},
        # what the runtime shows a stage one (svbrdf.runtime.inference.manifest.recorded_even_lighting); absent: its default
        **({"network_input": dict(meta["network_input"])} if meta.get("network_input") else {}),
    }


def _parity(path: Path, generator: nn.Module, sizes: Sequence[Tuple[int, int]],
            maps: Tuple[str, ...] = MAP_NAMES) -> list:
    """onnxruntime against torch on the channels of ``maps``; the other channels must be NaN."""
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.enable_cpu_mem_arena = False
    sess = ort.InferenceSession(str(path), so, providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(0)
    own = np.zeros(N_CHANNELS, bool)
    for n in maps:
        own[SLICES[n]] = True
    out = []
    for h, w in sizes:
        x = rng.random((1, 3, h, w), dtype=np.float32)
        with torch.inference_mode():
            ref = generator(torch.from_numpy(x)).numpy()
        got = sess.run([OUTPUT_NAME], {INPUT_NAME: x})[0]
        if got.shape != (1, N_CHANNELS, h, w):
            raise ModelError(f"{path}: exported graph returns {got.shape} for a {h}x{w} input, "
                             f"expected (1, {N_CHANNELS}, {h}, {w})")
        if not np.isnan(got[:, ~own]).all():
            raise ModelError(f"{path}: channels of maps the graph does not compute are not NaN")
        out.append({"size": [h, w], "max_abs_diff": float(np.abs(got[:, own] - ref[:, own]).max())})
    return out


def _export(graph: nn.Module, tmp: Path, opset: int, source: Any) -> onnx.ModelProto:
    """Trace ``graph`` to ``tmp`` with dynamic H, W and return the loaded model (output sizes named H, W)."""
    dim = torch.export.Dim
    example = torch.rand(1, 3, 64, 64)
    try:
        torch.onnx.export(
            graph, (example,), str(tmp), input_names=[INPUT_NAME], output_names=[OUTPUT_NAME],
            dynamic_shapes={"image": {2: dim("H", min=MIN_SIZE), 3: dim("W", min=MIN_SIZE)}},
            opset_version=opset, dynamo=True, external_data=False, verbose=False,
        )
    except Exception as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise ModelError(f"{source}: ONNX export failed ({first[:200]})") from exc
    model = onnx.load(str(tmp))
    # The exporter names the output sizes after its symbolic padding arithmetic (Min(H, 4*...)); they
    # equal the input's, so say so.
    for axis, name in ((2, "H"), (3, "W")):
        model.graph.output[0].type.tensor_type.shape.dim[axis].dim_param = name
    return model


def _check(tmp: Path, out: Path, generator: nn.Module, sizes, maps: Tuple[str, ...]) -> list:
    """onnx.checker then :func:`_parity`; ModelError naming ``out`` on failure; returns the parity results."""
    try:
        onnx.checker.check_model(str(tmp), full_check=True)
    except onnx.checker.ValidationError as exc:
        first = (str(exc).strip().splitlines() or ["invalid model"])[0]
        raise ModelError(f"{out}: exported graph fails onnx.checker ({first[:200]})") from None
    parity = _parity(tmp, generator, sizes, maps)
    worst = max(parity, key=lambda p: p["max_abs_diff"])
    if not worst["max_abs_diff"] <= PARITY_ATOL:
        raise ModelError(
            f"{out}: onnxruntime and torch differ by {worst['max_abs_diff']:.2e} at "
            f"{worst['size'][0]}x{worst['size'][1]} (tolerance {PARITY_ATOL:g})"
        )
    return parity


def export_generator(
    source: Union[PathLike, nn.Module],
    out_path: PathLike,
    *,
    opset: int = OPSET,
    check: bool = True,
    sizes: Sequence[Tuple[int, int]] = DEFAULT_SIZES,
    force: bool = False,
    meta: Optional[Mapping[str, Any]] = None,
) -> Dict[str, Any]:
    """Export a generator to ``out_path`` (one ``.onnx`` file), its part graphs ``NAME.<part>.onnx`` and its
    manifest ``out_path.with_suffix('.json')``.

    Args:
        source: a training checkpoint path (read with :func:`svbrdf.trainer.checkpoint.load_generator`; its
            name, absolute path and sha256 go into the manifest's ``checkpoint`` entry, used by
            ``svbrdf-preview --refine``) or a :class:`~svbrdf.trainer.models.Generator` module.
        out_path: the ``.onnx`` file to write.
        opset: ONNX opset (default :data:`OPSET`).
        check: run ``onnx.checker.check_model(full_check=True)`` and the onnxruntime-vs-torch parity check on
            ``sizes`` for every graph; the export fails if any |difference| exceeds :data:`PARITY_ATOL`.
        sizes: (H, W) input sizes of the parity check, each >= 8.
        force: replace existing output files.
        meta: checkpoint-style metadata for a module ``source`` (keys ``train_config``, ``stage``, ``step``,
            ``photo``, ...); ignored for a checkpoint path, whose own metadata is used.

    Returns:
        Report: ``path``, ``manifest_path``, ``sha256``, ``bytes``, ``opset``, ``parity`` (list of
        ``{"size", "max_abs_diff"}``, empty without ``check``), ``max_abs_diff`` (or None) of the full graph,
        ``parts`` (``{part: {"path", "sha256", "bytes", "max_abs_diff"}}``), ``seconds``.

    Raises:
        SvbrdfError: an output exists and not ``force`` (nothing is written then).
        ModelError: unreadable checkpoint, export failure, checker failure or parity above tolerance.
    """
    start = time.perf_counter()
    out = Path(out_path)
    manifest_path = out.with_suffix(".json")
    if out.suffix != ".onnx":
        raise SvbrdfError(f"{out}: the output file name must end in .onnx")
    graphs = {"full": (out, MAP_NAMES),
              **{p: (out.with_name(part_file_name(out.name, p)), m) for p, m in PARTS.items()}}
    if not force:
        for p in [path for path, _ in graphs.values()] + [manifest_path]:
            if p.exists():
                raise SvbrdfError(exists_message(p))
    if (check and not sizes) or any(min(s) < MIN_SIZE for s in sizes):
        raise ValueError(f"parity sizes must be given and >= {MIN_SIZE}, got {list(sizes)}")

    checkpoint = None
    if isinstance(source, nn.Module):
        generator, meta = source, dict(meta or {})
    else:
        from svbrdf.trainer.checkpoint import load_generator

        generator, meta = load_generator(source)
        # `svbrdf-preview --refine` fine-tunes from this file: found beside the model, else at this path.
        checkpoint = {"file": Path(source).name, "path": str(Path(source).resolve()),
                      "sha256": sha256_file(source)}
    generator = generator.eval()

    out.parent.mkdir(parents=True, exist_ok=True)
    # The graphs before the manifest that lists their sha256; the full graph after its parts.
    order = [path.name for g, (path, _) in graphs.items() if g != "full"] + [out.name, manifest_path.name]
    with staged_write(out.parent, order, force=force) as stage:
        manifest: Dict[str, Any] = {
            "schema": MANIFEST_SCHEMA,
            "file": out.name,
            "sha256": "",
            "maps": map_layout(),
            "input": input_contract(),
            **_provenance(meta, generator),
            "checkpoint": checkpoint,
            "opset": opset,
            "exporter": _versions(),
            "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        }
        props = {k: json.dumps(v) for k, v in manifest.items() if k not in ("file", "sha256")}
        results: Dict[str, Dict[str, Any]] = {}
        for g, (path, maps) in graphs.items():
            tmp = stage / path.name
            model = _export(_Graph(generator, maps).eval(), tmp, opset, source)
            part = {} if g == "full" else {"part": json.dumps({"name": g, "maps": list(maps)})}
            onnx.helper.set_model_props(model, {**props, **part})
            onnx.save(model, str(tmp))
            parity = _check(tmp, path, generator, sizes, maps) if check else []
            results[g] = {"path": path, "sha256": sha256_file(tmp), "bytes": tmp.stat().st_size,
                          "parity": parity, "max_abs_diff": max((p["max_abs_diff"] for p in parity), default=None)}
        full = results["full"]
        manifest["sha256"] = full["sha256"]
        manifest["parity"] = {"atol": PARITY_ATOL, "results": full["parity"]}
        manifest["parts"] = {
            p: {"file": results[p]["path"].name, "sha256": results[p]["sha256"], "maps": list(PARTS[p]),
                "parity": {"atol": PARITY_ATOL, "results": results[p]["parity"]}}
            for p in PARTS
        }
        (stage / manifest_path.name).write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return {
        "path": out,
        "manifest_path": manifest_path,
        "sha256": full["sha256"],
        "bytes": full["bytes"],
        "opset": opset,
        "parity": full["parity"],
        "max_abs_diff": full["max_abs_diff"],
        "parts": {p: {k: results[p][k] for k in ("path", "sha256", "bytes", "max_abs_diff")} for p in PARTS},
        "seconds": time.perf_counter() - start,
    }


__all__ = ["export_generator", "OPSET", "PARITY_ATOL", "DEFAULT_SIZES"]
