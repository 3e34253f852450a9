"""Finding a preview model and checking it against its manifest (no onnxruntime, no torch).

Lookup order (:func:`find_model`):

1. an explicit path (``--model PATH`` / ``load_session(model=...)``);
2. the ``SVBRDF_MODEL`` environment variable;
3. the packaged model: ``svbrdf.models/manifest.json`` names the default ``.onnx`` file next to it.

A manifest is a JSON object (schema :data:`MANIFEST_SCHEMA`, written by ``svbrdf-export``) that holds the
model file name, its sha256, the map layout and input contract, the render configuration and the training
provenance. The same keys except ``file`` and ``sha256`` are embedded in the ONNX ``metadata_props``
(each value JSON-encoded). The manifest of ``NAME.onnx`` is, in this order:

* ``NAME.json`` beside it (the file :func:`svbrdf.export.onnx.export_generator` writes), or
* ``manifest.json`` in the same folder, if its ``"file"`` is ``NAME.onnx``.

When a manifest is found, the sha256 of the model file must match it and its map layout must equal this
runtime's (:func:`map_layout`), else :class:`ModelError`. A model found through a path or the environment
variable may come without a manifest: it is loaded unverified and :attr:`ModelInfo.note` says so (the
session then reads the layout from the embedded metadata). The packaged model always needs its manifest.

Part graphs (maps on demand). onnxruntime runs the whole graph whatever outputs are fetched, so
``svbrdf-export`` also writes one graph per decoder of the generator, ``NAME.<part>.onnx`` for each part of
:data:`PARTS` (one per entry of :data:`DECODERS`, the table of decoder names): the encoder plus that decoder
only. A part has the same input and output names and shapes as the full graph (``image`` (1, 3, H, W) ->
``maps`` (1, 8, H, W), layout :data:`~svbrdf.runtime.core.maps.SLICES`): the channels of its own maps equal the
full graph's, **the channels of the other maps are NaN**. The
manifest lists them under ``"parts"``: ``{part: {"file", "sha256", "maps", "parity"}}``, file names relative to
the manifest's folder; each part file is verified against its sha256 when it is first used
(:meth:`ModelInfo.verify_part`). A model without ``"parts"`` (an older export) works as before with the full
graph. Each part file also embeds the manifest keys plus ``"part": {"name", "maps"}`` in its metadata.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Dict, Mapping, Optional, Tuple, Union

from ..errors import ModelError
from ..core.maps import MAP_COLOUR_SPACES, MAP_NAMES, MAP_RANGES, NORMAL_CONVENTION, SLICES

#: Manifest schema tag (bump when keys change meaning).
MANIFEST_SCHEMA = "svbrdf-model/1"
#: Environment variable naming a model file (step 2 of the lookup).
MODEL_ENV = "SVBRDF_MODEL"
#: Input contract of every exported generator: graph input/output names and the smallest side.
INPUT_NAME = "image"
OUTPUT_NAME = "maps"
MIN_SIZE = 8
#: ``training.stage`` of a stage one (a prior trained on procedural materials, :mod:`svbrdf.trainer.prior`); any
#: other stage is a model fine-tuned on one photo.
PRIOR_STAGE = "prior"
#: What a stage one is shown, recorded per model (checkpoint and manifest key ``network_input``, written when it is
#: shipped: :func:`svbrdf.trainer.checkpoint.clean_checkpoint`): ``"even"`` the photo divided by its own smooth
#: lighting (:func:`svbrdf.runtime.post.flash_trend.even_lighting`, v1), ``"photo"`` the photo as it is (v2).
#: Decision: docs/decisions/007-network-input-lighting.md.
NETWORK_INPUTS = ("even", "photo")


@dataclass(frozen=True)
class Decoder:
    """One decoder of the generator, and every name derived from it.

    Attributes:
        key: short name in training: the optimiser, the loss log prefix (``"nr/gan"``) and checkpoint keys.
        module: attribute of the torch generator (:class:`svbrdf.trainer.models.Generator`).
        part: name of its part graph: the file ``NAME.<part>.onnx`` (:func:`part_file_name`), the manifest's
            ``"parts"`` key and the ``graph`` a session reports.
        maps: the maps it computes, in :data:`~svbrdf.runtime.core.maps.MAP_NAMES` order.
    """

    key: str
    module: str
    part: str
    maps: Tuple[str, ...]


#: The generator's two decoders: the one table of their names (trainer, export, runtime) and maps.
DECODERS: Tuple[Decoder, ...] = (
    Decoder(key="nr", module="decoder_nr", part="normal_roughness", maps=("roughness", "normal")),
    Decoder(key="ds", module="decoder_ds", part="diffuse_specular", maps=("diffuse", "specular")),
)
#: Part graphs written beside every exported model, one per decoder: part name -> the maps it computes
#: (:data:`MAP_NAMES` order).
PARTS: Mapping[str, Tuple[str, ...]] = {d.part: d.maps for d in DECODERS}

__all__ = [
    "MANIFEST_SCHEMA", "MODEL_ENV", "INPUT_NAME", "OUTPUT_NAME", "MIN_SIZE", "PRIOR_STAGE", "NETWORK_INPUTS",
    "network_input_record", "recorded_even_lighting", "Decoder", "DECODERS", "PARTS",
    "part_file_name",
    "ModelInfo", "find_model",
    "manifest_path_for", "read_manifest", "sha256_file", "map_layout", "input_contract", "check_layout",
    "find_checkpoint",
]


@dataclass(frozen=True)
class ModelInfo:
    """A located model file and what is known about it.

    Attributes:
        path: the ``.onnx`` file.
        source: ``"argument"``, ``"env"`` or ``"packaged"``.
        sha256: hex digest of the file (always computed).
        manifest: the parsed manifest, or None when the model has none.
        manifest_path: where the manifest was read from, or None.
        note: empty when verified against a manifest; otherwise why not (shown by the CLI with --verbose).
    """

    path: Path
    source: str
    sha256: str
    manifest: Optional[dict]
    manifest_path: Optional[Path]
    note: str = ""

    @property
    def verified(self) -> bool:
        """True when the file's sha256 matched a manifest."""
        return self.manifest is not None

    @property
    def parts(self) -> Dict[str, dict]:
        """Part graphs listed in the manifest (``{part: {"file", "sha256", "maps", ...}}``; empty without)."""
        return dict((self.manifest or {}).get("parts") or {})

    def part_path(self, part: str) -> Path:
        """Where the file of a listed part graph is (beside the model); not checked."""
        return self.path.parent / self.parts[part]["file"]

    def verify_part(self, part: str) -> Path:
        """The file of a listed part graph, checked against its sha256 in the manifest.

        Raises:
            ModelError: the file is missing or its sha256 differs.
        """
        path = self.part_path(part)
        if not path.is_file():
            raise ModelError(f"{path}: part graph listed in {self.manifest_path.name} is missing")
        if sha256_file(path) != self.parts[part]["sha256"]:
            raise ModelError(f"{path}: sha256 does not match the {part} part recorded in {self.manifest_path.name}")
        return path


def part_file_name(model_file: str, part: str) -> str:
    """File name of a part graph of ``model_file``: ``NAME.onnx`` -> ``NAME.<part>.onnx``."""
    return f"{Path(model_file).stem}.{part}.onnx"


def map_layout() -> list:
    """This runtime's packed map layout as manifest data: one entry per map, in packing order."""
    return [
        {
            "name": name,
            "channels": [SLICES[name].start, SLICES[name].stop],
            "range": list(MAP_RANGES[name]),
            "colour_space": MAP_COLOUR_SPACES[name],
            **({"convention": NORMAL_CONVENTION} if name == "normal" else {}),
        }
        for name in MAP_NAMES
    ]


def input_contract() -> dict:
    """The graph's input/output contract as manifest data."""
    return {
        "input": INPUT_NAME,
        "output": OUTPUT_NAME,
        "layout": "NCHW",
        "batch": 1,
        "dtype": "float32",
        "colour_space": "linear Rec.709 (sRGB primaries, exact sRGB curve removed)",
        "min_size": MIN_SIZE,
        "any_size": True,
    }


def network_input_record(mode: str, width: float) -> dict:
    """The ``network_input`` record of a model shown ``mode`` (one of :data:`NETWORK_INPUTS`): ``{"mode",
    "even_lighting"}``, the low pass's width as a fraction of the photo width (0 for ``"photo"``)."""
    if mode not in NETWORK_INPUTS:
        raise ValueError(f"unknown network input {mode!r}; expected one of {', '.join(NETWORK_INPUTS)}")
    return {"mode": mode, "even_lighting": float(width) if mode == "even" else 0.0}


def recorded_even_lighting(meta: Mapping) -> Optional[float]:
    """The width of even lighting a model's metadata (a manifest or a checkpoint) records for its network's
    input: ``None`` when it records none (every model shipped before 2026-11-27: the runtime's default applies),
    0.0 for the photo as it is.

    Raises:
        ModelError: a ``network_input`` record that is not ``{"mode": "even" | "photo", "even_lighting": w >= 0}``.
    """
    record = meta.get("network_input")
    if record is None:
        return None
    try:
        mode, width = record["mode"], float(record["even_lighting"])
        ok = mode in NETWORK_INPUTS and width >= 0 and (mode == "even") == (width > 0)
    except (TypeError, KeyError, ValueError):
        ok = False
    if not ok:
        raise ModelError(f"invalid network_input in the model metadata: {record!r}")
    return width


def sha256_file(path: Union[str, Path], chunk: int = 1 << 20) -> str:
    """Hex sha256 of a file, read in chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(chunk), b""):
            h.update(block)
    return h.hexdigest()


def read_manifest(path: Union[str, Path]) -> dict:
    """Parse a manifest file; :class:`ModelError` if it is unreadable or not a manifest."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ModelError(f"{path}: cannot read model manifest: {exc}") from None
    if not isinstance(data, dict) or data.get("schema") != MANIFEST_SCHEMA:
        raise ModelError(f"{path}: not an svbrdf model manifest (expected schema {MANIFEST_SCHEMA!r})")
    for key in ("file", "sha256"):
        if not isinstance(data.get(key), str):
            raise ModelError(f"{path}: model manifest has no {key!r}")
    parts = data.get("parts")
    if parts is not None and not (
        isinstance(parts, dict)
        and all(name in PARTS and isinstance(e, dict) and isinstance(e.get("file"), str)
                and isinstance(e.get("sha256"), str) and e.get("maps") == list(PARTS[name])
                for name, e in parts.items())
    ):
        raise ModelError(f"{path}: invalid 'parts' entry (expected some of {', '.join(PARTS)} with file, sha256 "
                         f"and this runtime's maps)")
    return data


def check_layout(meta: dict, where: str) -> None:
    """Raise :class:`ModelError` unless ``meta["maps"]`` equals this runtime's :func:`map_layout`."""
    if meta.get("maps") != map_layout():
        names = [m.get("name") for m in meta.get("maps") or [] if isinstance(m, dict)]
        raise ModelError(
            f"{where}: model map layout {names or 'missing'} does not match this runtime's {list(MAP_NAMES)}"
        )


def manifest_path_for(model_path: Path) -> Optional[Path]:
    """The manifest that describes ``model_path`` (``NAME.json``, or a ``manifest.json`` naming it), or None."""
    sidecar = model_path.with_suffix(".json")
    if sidecar.is_file():
        return sidecar
    shared = model_path.parent / "manifest.json"
    if shared.is_file() and read_manifest(shared)["file"] == model_path.name:
        return shared
    return None


def _verify(path: Path, source: str, manifest_path: Optional[Path]) -> ModelInfo:
    digest = sha256_file(path)
    if manifest_path is None:
        return ModelInfo(path, source, digest, None, None, note=f"no manifest beside {path.name}: sha256 not verified")
    manifest = read_manifest(manifest_path)
    if manifest["sha256"] != digest:
        raise ModelError(
            f"{path}: sha256 {digest[:12]}... does not match {manifest_path.name} ({manifest['sha256'][:12]}...);"
            " the file is corrupt or not the model the manifest describes"
        )
    check_layout(manifest, str(manifest_path))
    return ModelInfo(path, source, digest, manifest, manifest_path)


def _user_model(value: Union[str, Path], source: str) -> ModelInfo:
    path = Path(value).expanduser()
    origin = f" (from {MODEL_ENV})" if source == "env" else ""
    if not path.is_file():
        raise ModelError(f"{path}: model file not found{origin}")
    return _verify(path, source, manifest_path_for(path))


def find_model(model: Union[str, Path, None] = None) -> ModelInfo:
    """Locate and verify the model (order: ``model``, ``$SVBRDF_MODEL``, packaged; see the module docstring).

    Raises:
        ModelError: missing file, unreadable or mismatching manifest, or no model anywhere.
    """
    if model is not None:
        return _user_model(model, "argument")
    env = os.environ.get(MODEL_ENV)
    if env:
        return _user_model(env, "env")
    package = resources.files("svbrdf.models")
    manifest = package / "manifest.json"
    if not manifest.is_file():
        raise ModelError(f"no packaged model (svbrdf.models has no manifest.json); pass --model or set {MODEL_ENV}")
    manifest_path = Path(str(manifest))
    path = manifest_path.parent / read_manifest(manifest_path)["file"]
    if not path.is_file():
        raise ModelError(f"{path}: packaged model file listed in manifest.json is missing")
    return _verify(path, "packaged", manifest_path)


def find_checkpoint(info: ModelInfo) -> Path:
    """The training checkpoint a model was exported from (for fine-tuning), verified against its sha256.

    Looked up from the manifest's ``checkpoint`` entry: the file of that name beside the model, else the
    absolute path recorded at export.

    Raises:
        ModelError: no manifest or no ``checkpoint`` entry, file not found, or sha256 mismatch.
    """
    entry = (info.manifest or {}).get("checkpoint")
    if not entry:
        raise ModelError(f"{info.path}: its manifest names no training checkpoint, so it cannot be refined")
    candidates = [info.path.parent / entry["file"], Path(entry["path"])]
    path = next((p for p in candidates if p.is_file()), None)
    if path is None:
        raise ModelError(
            f"{info.path}: training checkpoint {entry['file']} not found beside the model or at {entry['path']}"
        )
    if sha256_file(path) != entry["sha256"]:
        raise ModelError(f"{path}: sha256 does not match the checkpoint recorded in {info.manifest_path.name}")
    return path
