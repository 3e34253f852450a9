"""What a texture set's files mean as Principled BSDF inputs: a sidecar -> a material plan (plain Python, no bpy).

The add-on runs inside Blender's own Python, which has neither numpy nor svbrdf: this module reads a set's JSON
sidecar (any ``--target``: the file roles of ``svbrdf.runtime.outputs.targets``, ``docs/targets.md``) with the
standard library only and says, for each input of Blender's Principled BSDF, which file and channel feed it and
which arithmetic the node graph applies (:mod:`.material` builds the nodes). It is importable outside Blender, so
the tests evaluate a plan with numpy and compare it with ``svbrdf.runtime.outputs.conversions``, the one place of
the conversions (``to_principled_base``, ``to_principled_specular``).

A plan (:func:`read_set`) is a dict:

* ``name``, ``folder``, ``target``, ``size`` (width, height in pixels), ``sidecar`` (its path);
* ``base``: source of the base colour, ``times_one_minus_f0``: multiply it by ``1 - F0`` (the targets whose base
  colour is weighted by ``1 - F0``, and a generic set of the Deschaintre convention): Principled 2.8-3.x adds its
  diffuse lobe unweighted, so its base colour is ``rho_d w_d``;
* ``specular``: source of the Principled ``Specular`` input, ``value = scale x texture`` (F0 = 0.08 x value):
  scale 12.5 for a file that stores F0, the sidecar's ``principled_specular_scale`` for the blender target;
  ``None`` for a metal-rough set (Specular stays 0.5, F0 0.04);
* ``metallic``: source or ``None``; ``roughness``: source with ``invert`` (a smoothness channel) and ``power``;
* ``normal``: source with ``flip_green`` (a DirectX map);
* ``height``: source with ``height_scale`` (map widths black to white) or ``None``; ``ao``: source or ``None``;
* ``approximate``: ``None``, or one line saying why the material only approximates our model (metal-rough sets).

A source is ``{"file": absolute path, "colour": True for an sRGB-encoded colour (Blender's sRGB), False for data
(Non-Color), "channel": None (the image's colour) or one of "R", "G", "B", "A"}``.

Every problem is a :class:`SetError` with a one-line message meant for the artist.
"""

from __future__ import annotations

import json
import os

#: F0 per unit of the Principled ``Specular`` input (``svbrdf.runtime.outputs.conversions.PRINCIPLED_F0_PER_SPECULAR``;
#: the tests check the two are equal).
F0_PER_SPECULAR = 0.08
#: The oldest Blender the add-on supports (Debian's package; the Principled BSDF's sockets and the Separate Color
#: node it uses).
MIN_BLENDER = (3, 4, 0)
#: The Principled inputs every material needs, by file role of the project's own layout.
NEEDED = ("basecolor", "normal", "roughness", "specular")


class SetError(Exception):
    """A texture set the add-on cannot turn into a material; the message is one line for the artist."""


def version_problem(version) -> "str | None":
    """``None`` when Blender ``version`` (a tuple such as ``bpy.app.version``) is supported, else the one-line
    message to show."""
    v = tuple(int(x) for x in tuple(version)[:3])
    if v < MIN_BLENDER:
        need = ".".join(map(str, MIN_BLENDER[:2]))
        return f"the svbrdf add-on needs Blender {need} or newer; this is Blender {'.'.join(map(str, v))}"
    return None


def _source(folder: str, entry: dict, colour: bool, channel=None) -> dict:
    return {"file": os.path.join(folder, entry["file"]), "colour": colour, "channel": channel}


def read_sidecar(path) -> dict:
    """The sidecar JSON at ``path`` as a dict; :class:`SetError` when it is missing or not one of our sidecars."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise SetError(f"texture set not found: {path}")
    try:
        with open(path, encoding="utf-8") as f:
            meta = json.load(f)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SetError(f"{path}: not a texture-set sidecar ({type(exc).__name__}: {str(exc).splitlines()[0]})")
    if not isinstance(meta, dict) or not isinstance(meta.get("files"), dict):
        raise SetError(f"{path}: not a texture-set sidecar of svbrdf (no 'files' entry)")
    return meta


def read_set(path) -> dict:
    """The material plan (module docstring) of the texture set whose sidecar is ``path``.

    Raises:
        SetError: the sidecar is missing or not ours, its target is unknown, a map the material needs was not
            written (a ``--maps`` subset) or one of its files is missing.
    """
    path = os.path.abspath(os.fspath(path))
    meta = read_sidecar(path)
    folder = os.path.dirname(path)
    files = meta["files"]
    target = (meta.get("target") or {}).get("name", "generic")
    name = meta.get("name") or os.path.splitext(os.path.basename(path))[0]
    size = meta.get("size") or {}
    plan = {"name": name, "folder": folder, "target": target, "sidecar": path,
            "size": (int(size.get("width", 1)), int(size.get("height", 1))), "metallic": None, "height": None,
            "ao": None, "approximate": None}
    builder = _TARGETS.get(target)
    if builder is None:
        raise SetError(f"{path}: unknown target {target!r}; expected one of {', '.join(_TARGETS)}")
    builder(plan, meta, folder, files)
    if plan.get("height") is None and "height" in files:
        plan["height"] = dict(_source(folder, files["height"], False, "R"), height_scale=_height_scale(meta))
    if plan.get("ao") is None and "ao" in files:
        plan["ao"] = _source(folder, files["ao"], False, "R")
    missing = [s["file"] for s in _sources(plan) if not os.path.isfile(s["file"])]
    if missing:
        more = f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""
        raise SetError(f"texture set {name}: file missing: {missing[0]}{more}")
    return plan


def _sources(plan: dict):
    for key in ("base", "specular", "metallic", "roughness", "normal", "height", "ao"):
        if plan.get(key) is not None:
            yield plan[key]


def _require(files: dict, roles, name: str, path: str) -> None:
    missing = [r for r in roles if r not in files]
    if missing:
        raise SetError(f"texture set {name} ({path}) has no {', '.join(missing)} map: the material needs "
                       f"{', '.join(roles)} (was it written with --maps?)")


def _height_scale(meta: dict) -> float:
    relief = meta.get("relief") or {}
    scale = relief.get("height_scale", (meta["files"].get("height") or {}).get("height_scale", 0.0))
    return float(scale or 0.0)


def _convention(meta: dict) -> str:
    return (meta.get("normal_convention") or {}).get("name", "opengl")


def _has_ao(meta: dict) -> bool:
    return "ao" in ((meta.get("relief") or {}).get("maps") or ())


def _diffuse_conservation(meta: dict) -> bool:
    return bool(((meta.get("brdf") or {}).get("render_config") or {}).get("diffuse_conservation", False))


def _f0_file(plan, folder, entry, colour=False, channel="R"):
    """Specular = F0 / 0.08 from a file that stores F0."""
    plan["specular"] = dict(_source(folder, entry, colour, channel), scale=1.0 / F0_PER_SPECULAR)


def _common(plan, folder, files, flip_green=False):
    plan["roughness"] = dict(_source(folder, files["roughness"], False, "R"), invert=False, power=1.0)
    plan["normal"] = dict(_source(folder, files["normal"], False), flip_green=flip_green)


def _generic(plan, meta, folder, files):
    _require(files, NEEDED, plan["name"], plan["sidecar"])
    plan["base"] = dict(_source(folder, files["basecolor"], True), times_one_minus_f0=_diffuse_conservation(meta))
    _f0_file(plan, folder, files["specular"])
    _common(plan, folder, files, flip_green=_convention(meta) == "dx")


def _weighted(plan, meta, folder, files):
    """usd, mtlx, ambientcg: base colour weighted by 1 - F0, F0 file, OpenGL normal (ambientcg: NormalGL)."""
    _require(files, NEEDED, plan["name"], plan["sidecar"])
    plan["base"] = dict(_source(folder, files["basecolor"], True), times_one_minus_f0=True)
    _f0_file(plan, folder, files["specular"])
    _common(plan, folder, files)


def _blender(plan, meta, folder, files):
    if "specular" not in files and "metallic" in files:  # written when the blender target was metal-rough
        _require(files, ("basecolor", "normal", "roughness", "metallic"), plan["name"], plan["sidecar"])
        plan["base"] = dict(_source(folder, files["basecolor"], True), times_one_minus_f0=False)
        plan["specular"] = None
        plan["metallic"] = _source(folder, files["metallic"], False, "R")
        plan["approximate"] = ("a metal-rough set (Khronos conversion): Specular 0.5 and Metallic from the file; "
                               "write it again with --target blender for the exact material")
        _common(plan, folder, files)
        return
    _require(files, NEEDED, plan["name"], plan["sidecar"])
    plan["base"] = dict(_source(folder, files["basecolor"], True), times_one_minus_f0=False)
    scale = float(files["specular"].get("principled_specular_scale", 1.0))
    plan["specular"] = dict(_source(folder, files["specular"], False, "R"), scale=scale)
    _common(plan, folder, files)


def _gltf(plan, meta, folder, files):
    _require(files, ("basecolor", "normal", "orm", "specularcolor", "gltf"), plan["name"], plan["sidecar"])
    doc_path = os.path.join(folder, files["gltf"]["file"])
    try:
        with open(doc_path, encoding="utf-8") as f:
            doc = json.load(f)
        ext = doc["materials"][0]["extensions"]["KHR_materials_specular"]
        factor = float(ext.get("specularColorFactor", [1.0])[0]) * float(ext.get("specularFactor", 1.0))
    except (OSError, ValueError, KeyError, IndexError, TypeError) as exc:
        raise SetError(f"texture set {plan['name']}: cannot read the specular factor of {doc_path} "
                       f"({type(exc).__name__})")
    plan["base"] = dict(_source(folder, files["basecolor"], True), times_one_minus_f0=True)
    # F0 = 0.04 factor texture (KHR_materials_specular, the texture sRGB-encoded) = 0.08 Specular
    plan["specular"] = dict(_source(folder, files["specularcolor"], True, "R"), scale=0.04 * factor / F0_PER_SPECULAR)
    plan["roughness"] = dict(_source(folder, files["orm"], False, "G"), invert=False, power=1.0)
    plan["normal"] = dict(_source(folder, files["normal"], False), flip_green=False)
    if _has_ao(meta):  # the ORM's red channel (1 without a relief)
        plan["ao"] = _source(folder, files["orm"], False, "R")


def _unreal(plan, meta, folder, files):
    _require(files, ("basecolor", "normal", "orm"), plan["name"], plan["sidecar"])
    plan["base"] = dict(_source(folder, files["basecolor"], True), times_one_minus_f0=False)
    plan["specular"] = None
    plan["metallic"] = _source(folder, files["orm"], False, "B")
    plan["roughness"] = dict(_source(folder, files["orm"], False, "G"), invert=False, power=1.0)
    plan["normal"] = dict(_source(folder, files["normal"], False), flip_green=_convention(meta) == "dx")
    if _has_ao(meta):
        plan["ao"] = _source(folder, files["orm"], False, "R")
    plan["approximate"] = ("Unreal's metal-rough set (Khronos conversion): Specular 0.5 and Metallic from the ORM; "
                           "write the set with --target blender for the exact material")


def _unity(plan, meta, folder, files):
    _require(files, ("basecolor", "normal", "specular_smoothness"), plan["name"], plan["sidecar"])
    plan["base"] = dict(_source(folder, files["basecolor"], True), times_one_minus_f0=True)
    spec = files["specular_smoothness"]
    _f0_file(plan, folder, spec, colour=True, channel="R")  # RGB: F0, sRGB-encoded
    plan["roughness"] = dict(_source(folder, spec, False, "A"), invert=True, power=1.0)
    plan["normal"] = dict(_source(folder, files["normal"], False), flip_green=False)
    if "mask" in files:
        plan["ao"] = _source(folder, files["mask"], False, "G")


_TARGETS = {"generic": _generic, "gltf": _gltf, "blender": _blender, "unreal": _unreal, "unity": _unity,
            "usd": _weighted, "mtlx": _weighted, "ambientcg": _weighted}
#: The targets whose sets the add-on loads (every ``--target``).
TARGETS = tuple(_TARGETS)


def wrong_convention(plan: dict, kind: str) -> dict:
    """A copy of ``plan`` with one deliberate mistake, for the negative controls of the renderer comparison:
    ``"flip_green"`` (the normal map read as DirectX), ``"roughness_squared"`` (alpha given as the Principled
    roughness), ``"specular_as_f0"`` (F0 given as the Principled Specular, unconverted)."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in plan.items()}
    if kind == "flip_green":
        out["normal"]["flip_green"] = not out["normal"]["flip_green"]
    elif kind == "roughness_squared":
        out["roughness"]["power"] = 2.0 * out["roughness"]["power"]
    elif kind == "specular_as_f0":
        out["specular"]["scale"] = out["specular"]["scale"] * F0_PER_SPECULAR
    else:
        raise ValueError(f"unknown wrong convention {kind!r}")
    return out


__all__ = ["SetError", "read_set", "read_sidecar", "version_problem", "wrong_convention", "TARGETS",
           "F0_PER_SPECULAR", "MIN_BLENDER"]
