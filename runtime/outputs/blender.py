"""Blender: the add-on's zip, a .blend with a set's material, and our renderer against Cycles (``svbrdf-blender``).

::

    svbrdf-blender addon -o DIR                 DIR/svbrdf_material.zip: install it in Blender (Preferences >
                                                Add-ons > Install...), enable "svbrdf: material from a flash photo"
    svbrdf-blender blend SET.json -o m.blend    a .blend with the set's material on a plane, under the flash camera
                                                and light (for artists without the add-on; runs blender -b)
    svbrdf-blender proof --json J --image P     Cycles against our renderer (docs/results/blender.json,
                                                docs/images/blender.jpg)

The add-on's source is ``runtime/outputs/blender_addon`` (package data; Blender's Python has no numpy, so it
imports only the standard library and bpy). The headless commands run ``blender -b --factory-startup`` (found on
``PATH``, or ``$SVBRDF_BLENDER``, or ``--blender``) with the add-on's own material code: what a .blend holds and
what the proof renders is what the add-on builds.

**The proof** (:func:`proof`): texture sets written with ``--target blender`` are rendered by Cycles in our
renderer's scene (``blender_addon/scene.py``: the plane over [-1, 1], the camera at ``d = 1 / tan(fov / 2)``, a point
light of power ``4 pi I d^2`` at the flash and at two other positions, one sample position per pixel, direct light
only) and by :func:`svbrdf.runtime.core.render.render` with the set's render config; the figure is the sRGB RMSE
of the two (clipped to [0, 1], as :func:`~svbrdf.runtime.core.render.rerender_rmse`) per light. Controls: the same
sets built with a deliberate mistake (the normal map's green axis flipped, the roughness squared, F0 given as
Specular unconverted) must differ clearly more. Our light always falls off with distance here (a point light
does), so a config without ``falloff`` is compared with it turned on.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
import zipfile
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..errors import SvbrdfError, cli_message, exists_message, parse_command_line

PROG = "svbrdf-blender"
#: The add-on's module name in Blender (the folder inside the zip).
ADDON_MODULE = "svbrdf_material"
#: The zip's file name.
ADDON_ZIP = f"{ADDON_MODULE}.zip"
#: Environment variable naming the Blender executable (else ``blender`` on ``PATH``).
BLENDER_ENV = "SVBRDF_BLENDER"
#: The mistakes of the proof's negative controls (:func:`blender_addon.sets.wrong_convention`).
CONTROLS = ("flip_green", "roughness_squared", "specular_as_f0")
#: What each figure of :func:`proof` is (sRGB RMSE: both renders clipped to [0, 1] and sRGB-encoded, per light).
LEGEND = {
    "rmse": "sRGB RMSE, Cycles (the add-on's material from the --target blender files) against our renderer on the "
            "maps themselves: what a person would see differ",
    "rmse_stored_maps": "the same against our renderer on the maps decoded back from the files (8-bit base colour, "
                        "16-bit data): the renderers' difference alone",
    "rmse_stored_maps_smith_g": "the same with our renderer's exact Smith G (geometry='smith', Cycles' own) instead "
                                "of the default Smith-Schlick",
    "noise": "Cycles' own noise per render: sRGB RMSE of two seeds / sqrt 2",
    "exposure_fit": "least-squares scale of ours against Cycles in linear values (1 = the same absolute brightness; "
                    "no scale is applied anywhere)",
    "controls": "sRGB RMSE of Cycles against ours when the material is built with a deliberate mistake",
}
_CONTROL_NAMES = {"flip_green": "normal map green axis flipped", "roughness_squared": "roughness squared",
                  "specular_as_f0": "F0 given as Specular (not / 0.08)"}


def addon_source() -> Path:
    """The folder of the add-on's source (package data of ``svbrdf.runtime.outputs``)."""
    return Path(__file__).resolve().parent / "blender_addon"


def _addon_files() -> List[Path]:
    files = sorted(p for p in addon_source().glob("*.py"))
    if not any(p.name == "__init__.py" for p in files):
        raise SvbrdfError(f"the add-on's source is missing from this installation ({addon_source()})")
    return files


def write_addon_zip(out, *, force: bool = False) -> Path:
    """Write the add-on as a zip Blender installs (*Preferences > Add-ons > Install...*): ``svbrdf_material/*.py``.

    Args:
        out: a folder (the zip is ``out/svbrdf_material.zip``; created when missing) or a path ending in ``.zip``.
        force: replace an existing zip.

    Returns:
        The zip's path.

    Raises:
        SvbrdfError: the zip exists (and not ``force``) or cannot be written (one line).
    """
    out = Path(out)
    path = out if out.suffix.lower() == ".zip" else out / ADDON_ZIP
    if path.exists() and not force:
        raise SvbrdfError(exists_message(path))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.tmp")
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as z:
            for f in _addon_files():
                z.write(f, f"{ADDON_MODULE}/{f.name}")
        os.replace(tmp, path)
    except OSError as exc:
        raise SvbrdfError(f"{path}: cannot write the add-on ({exc.strerror or exc})") from None
    return path


def find_blender(blender: Optional[str] = None) -> str:
    """The Blender executable: ``blender``, else ``$SVBRDF_BLENDER``, else ``blender`` on ``PATH``.

    Raises:
        SvbrdfError: none found (one line saying how to install it).
    """
    name = blender or os.environ.get(BLENDER_ENV) or "blender"
    found = shutil.which(name)
    if found is None:
        raise SvbrdfError(f"Blender not found ({name!r}): install Blender 3.4 or newer (Debian/Ubuntu: apt-get "
                          f"install blender) or give its path with --blender or ${BLENDER_ENV}")
    return found


def blender_version(blender: Optional[str] = None) -> str:
    """``"3.4.1"``: the version line of ``blender --version``."""
    res = subprocess.run([find_blender(blender), "--version"], capture_output=True, text=True, timeout=60)
    for line in res.stdout.splitlines():
        if line.startswith("Blender "):
            return line.split()[1]
    raise SvbrdfError(f"cannot read the version of {find_blender(blender)}: {res.stdout.strip()[:200]}")


def run_job(job: dict, *, blender: Optional[str] = None, threads: int = 0, timeout: float = 600.0) -> str:
    """Run one job of ``blender_addon/scene.py`` (``{"renders": ...}`` or ``{"blend": ...}``) in headless Blender.

    The add-on is copied into a temporary folder as ``svbrdf_material`` and imported from there; Blender starts
    with its factory settings (the user's preferences and add-ons play no part).

    Returns:
        Blender's output (stdout and stderr).

    Raises:
        SvbrdfError: Blender missing, the job's one-line error, or Blender failing or taking over ``timeout`` s.
    """
    exe = find_blender(blender)
    with tempfile.TemporaryDirectory(prefix="svbrdf-blender-") as tmp:
        pkg = Path(tmp) / ADDON_MODULE
        pkg.mkdir()
        for f in _addon_files():
            shutil.copy2(f, pkg / f.name)
        job_file = Path(tmp) / "job.json"
        job_file.write_text(json.dumps(job), encoding="utf-8")
        code = (f"import sys; sys.path.insert(0, {tmp!r}); from {ADDON_MODULE} import scene; "
                f"scene.run_job_file({str(job_file)!r})")
        cmd = [exe, "-b", "--factory-startup", "--python-exit-code", "1"]
        if threads:
            cmd += ["-t", str(int(threads))]
        cmd += ["--python-expr", code]
        env = dict(os.environ)
        for key in ("PYTHONHOME", "PYTHONPATH"):
            env.pop(key, None)
        try:
            res = subprocess.run(cmd, capture_output=True, text=True, errors="replace", timeout=timeout, env=env)
        except subprocess.TimeoutExpired:
            raise SvbrdfError(f"Blender took more than {timeout:.0f} s; stopped") from None
    out = res.stdout + res.stderr
    for line in out.splitlines():
        if line.startswith(f"{PROG}: error: "):
            raise SvbrdfError(line[len(PROG) + 9:])
    if res.returncode != 0:
        last = [line for line in res.stderr.splitlines() if line.strip()] or ["no output"]
        raise SvbrdfError(f"Blender failed (exit code {res.returncode}): {last[-1].strip()}")
    return out


def _render_settings(sidecar) -> dict:
    from .blender_addon.sets import SetError, read_sidecar

    try:
        meta = read_sidecar(sidecar)
    except SetError as exc:
        raise SvbrdfError(str(exc)) from None
    config = (meta.get("brdf") or {}).get("render_config") or {}
    return {"fov_deg": float(config.get("fov_deg", 66.0)), "intensity": float(config.get("intensity", math.pi))}


def write_blend(sidecar, out, *, ao: str = "NONE", displacement: bool = True, pack: bool = False,
                blender: Optional[str] = None, force: bool = False, samples: int = 64) -> Path:
    """Save a .blend holding the material of the texture set ``sidecar`` (any target the add-on reads) on a plane
    two units wide, with the flash camera and light of our renderer (F12 renders the flash view in Cycles).

    Args:
        sidecar: the set's JSON sidecar.
        out: the .blend to write.
        ao: ``"NONE"`` (AO image unconnected) or ``"MULTIPLY"`` (into the base colour).
        displacement: wire the height as true displacement.
        pack: pack the images into the .blend (else it refers to them by relative paths).
        blender: Blender executable (default :func:`find_blender`).
        force: replace an existing file.
        samples: Cycles samples of the saved scene.

    Returns:
        The path written.

    Raises:
        SvbrdfError: Blender missing, the file exists, a bad set (one line).
    """
    out = Path(out).resolve()
    if out.suffix.lower() != ".blend":
        raise SvbrdfError(f"{out}: the output must end in .blend")
    if out.exists() and not force:
        raise SvbrdfError(exists_message(out))
    if not out.parent.is_dir():
        raise SvbrdfError(f"{out}: folder {out.parent} does not exist")
    if ao.upper() not in ("NONE", "MULTIPLY"):
        raise SvbrdfError(f"unknown AO mode {ao!r}; expected none or multiply")
    job = {"blend": {"sidecar": str(Path(sidecar).resolve()), "out": str(out), "ao": ao.upper(),
                     "displacement": bool(displacement), "pack": bool(pack), "samples": int(samples),
                     **_render_settings(sidecar)}}
    run_job(job, blender=blender)
    if not out.is_file():
        raise SvbrdfError(f"Blender wrote no {out}")
    return out


def _read_exr(path: Path) -> np.ndarray:
    from ..io.images import read_image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # an alpha channel dropped
        return read_image(path)


def cycles_renders(requests: Sequence[dict], lights: Sequence[Optional[Sequence[float]]], *, samples: int = 16,
                   threads: int = 1, seed: int = 0, blender: Optional[str] = None,
                   timeout: float = 600.0) -> List[List[np.ndarray]]:
    """Render texture sets with Cycles in our renderer's scene, in one Blender run.

    Args:
        requests: ``{"sidecar": path, "wrong": None or a control of :data:`CONTROLS`}`` each.
        lights: light positions in our scene units, ``None`` = the flash.
        samples, threads, seed: Cycles' samples per pixel, CPU threads and seed.

    Returns:
        For each request, one (H, W, 3) float32 linear render per light.
    """
    with tempfile.TemporaryDirectory(prefix="svbrdf-cycles-") as tmp:
        renders, outs = [], []
        for i, req in enumerate(requests):
            files = [str(Path(tmp) / f"r{i}_l{j}.exr") for j in range(len(lights))]
            outs.append(files)
            renders.append({"sidecar": str(Path(req["sidecar"]).resolve()), "wrong": req.get("wrong"),
                            "lights": [None if p is None else [float(v) for v in p] for p in lights],
                            "outputs": files, **_render_settings(req["sidecar"])})
        run_job({"renders": renders, "samples": int(samples), "threads": int(threads), "seed": int(seed)},
                blender=blender, threads=threads, timeout=timeout)
        return [[_read_exr(Path(f)) for f in files] for files in outs]


def proof_maps(size: int = 128):
    """Synthetic maps with structure for the proof: a coloured base colour, a specular ramp from 0.02 to 0.5 across
    x (F0 above 0.08: Specular above 1), a roughness ramp from 0.15 to 0.9 down the image, and a bumpy normal map
    on a strong slope that rises up the image (so a flipped green axis shows). Tilts stay under 25 degrees, where
    Cycles keeps the shading normal as given (it bends normals whose mirror direction would go below the surface)."""
    from ..core.maps import Maps, normalize_normals

    t = (np.arange(size, dtype=np.float64) + 0.5) / size
    u, v = np.meshgrid(t, t)  # u across, v down the image
    diffuse = np.stack([0.12 + 0.55 * u, 0.45 - 0.3 * v + 0.1 * np.sin(6 * math.pi * u), 0.55 - 0.4 * u * v], -1)
    checker = ((np.floor(u * 8) + np.floor(v * 8)) % 2)[..., None]
    diffuse = diffuse * (0.75 + 0.25 * checker)
    specular = (0.02 + 0.48 * u)[..., None]
    roughness = (0.15 + 0.75 * v)[..., None]
    # height slopes: d/dx and d/dy (y up the image) of h = 0.18 y + bumps, in map half-widths
    x, y = 2 * u - 1, 1 - 2 * v
    k = 3.0 * math.pi
    dhdx = 0.16 * k / 3.0 * np.cos(k * x / 1.0) * np.sin(k * y / 1.5) * 0.6
    dhdy = 0.18 + 0.16 * k / 4.5 * np.sin(k * x) * np.cos(k * y / 1.5) * 0.6
    normal = normalize_normals(np.stack([-dhdx, -dhdy, np.ones_like(x)], -1).astype(np.float32))
    return Maps(diffuse=diffuse.astype(np.float32), specular=specular.astype(np.float32),
                roughness=roughness.astype(np.float32), normal=normal, meta={"source": "synthetic (proof_maps)"})


def read_principled_set(sidecar, config=None):
    """The maps a blender-target set stores, decoded back to our model (the inverse conversions of
    :mod:`svbrdf.runtime.outputs.conversions`): ``rho_d = base / w_d``, ``F0 = 0.08 x scale x spec``, roughness and
    normals as stored. ``config``: the render config of ``w_d`` (default: the sidecar's)."""
    from ..core.maps import Maps, decode_normal
    from ..core.render_config import RenderConfig
    from ..io.images import read_image
    from .conversions import from_principled_base, from_principled_specular

    folder = Path(sidecar).parent
    meta = json.loads(Path(sidecar).read_text(encoding="utf-8"))
    files = meta["files"]
    if config is None:
        config = RenderConfig(**meta["brdf"]["render_config"])
    spec = from_principled_specular(read_image(folder / files["specular"]["file"], raw=True)[..., :1],
                                    files["specular"].get("principled_specular_scale", 1.0))
    base = read_image(folder / files["basecolor"]["file"])
    return Maps(diffuse=from_principled_base(base, spec, config), specular=spec,
                roughness=read_image(folder / files["roughness"]["file"], raw=True)[..., :1],
                normal=decode_normal(read_image(folder / files["normal"]["file"], raw=True)), render_config=config)


def _exposure_fit(cycles: np.ndarray, ours: np.ndarray) -> float:
    """The least-squares scale ``k`` of ``k x ours`` against Cycles (linear; 1 when the brightness matches)."""
    o = ours.astype(np.float64)
    return float(np.sum(cycles * o) / max(np.sum(o * o), 1e-30))


def _srgb_rmse(a: np.ndarray, b: np.ndarray) -> float:
    from ..core.colour import linear_to_srgb

    return float(np.sqrt(np.mean((linear_to_srgb(a, clip=True).astype(np.float64)
                                  - linear_to_srgb(b, clip=True)) ** 2)))


def _example_maps(threads: int = 1):
    """The bundled example's maps as ``svbrdf-preview`` writes them (its generic set read back) and its config."""
    from ..outputs.viewer import read_texture_set

    example = Path(__file__).resolve().parents[1] / "examples" / "carved_wood.png"
    tmp = tempfile.mkdtemp(prefix="svbrdf-example-")
    cmd = [sys.executable, "-m", "svbrdf.runtime.cli.preview", str(example), "-o", tmp, "-q", "--threads",
           str(max(1, threads))]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise SvbrdfError(f"svbrdf-preview failed on {example}: {res.stderr.strip()[-300:]}")
    maps, config = read_texture_set(Path(tmp) / "carved_wood.json")
    shutil.rmtree(tmp, ignore_errors=True)
    return maps.__class__(maps.diffuse, maps.specular, maps.roughness, maps.normal,
                          meta={"source": str(example.name)}, render_config=config)


def proof(*, size: int = 128, samples: int = 16, threads: int = 1, blender: Optional[str] = None,
          sets: Optional[Dict[str, object]] = None, controls: Sequence[str] = CONTROLS, keep: Optional[Path] = None):
    """Cycles against our renderer on texture sets of the blender target (module docstring).

    Args:
        size: side of the synthetic maps (:func:`proof_maps`), pixels.
        samples, threads: Cycles' samples per pixel and CPU threads.
        sets: name -> :class:`~svbrdf.runtime.core.maps.Maps` (with their ``render_config``) to compare; default the
            synthetic maps (render config of the preview: fov 66, fall-off) and the bundled example's set.
        controls: the wrong conventions to render as negative controls.
        keep: a folder to keep the sets and the renders in (``<set>/...``; default: a temporary folder).

    Returns:
        ``{"sets": {name: {"rmse": {light: value}, "controls": {control: {light: value}}, "noise": {light: value},
        ...}}, "lights": {...}, "blender": version, "seconds": ...}`` and the renders ``{name: {"cycles": [...],
        "ours": [...], control: [...]}}`` (linear (H, W, 3) per light).
    """
    from ..core.render import novel_lights, render
    from ..core.render_config import ZHAO
    from .targets import write_target

    start = time.perf_counter()
    if sets is None:
        synthetic = proof_maps(size)
        synthetic.render_config = ZHAO.replace(falloff=True)
        sets = {"synthetic": synthetic, "carved_wood": _example_maps(threads)}
    folder = Path(keep) if keep is not None else Path(tempfile.mkdtemp(prefix="svbrdf-proof-"))
    requests, index, configs = [], [], {}
    lights_by_set = {}
    for name, maps in sets.items():
        config = (maps.render_config or ZHAO)
        config = config if config.falloff else config.replace(falloff=True)
        configs[name] = config
        paths = write_target(maps.__class__(maps.diffuse, maps.specular, maps.roughness, maps.normal, meta=maps.meta,
                                            render_config=config), folder / name, name, "blender", force=True)
        corners = novel_lights(config)
        lights_by_set[name] = [None, corners[0].tolist(), corners[-1].tolist()]
        for wrong in (None, *controls):
            requests.append({"sidecar": paths["sidecar"], "wrong": wrong})
            index.append((name, wrong or "cycles"))
        requests.append({"sidecar": paths["sidecar"], "wrong": None})  # rendered again with seed 1: the noise
        index.append((name, "cycles_seed1"))
    # one Blender run per light set (all sets share the same three lights when their configs share the fov)
    renders: Dict[str, Dict[str, list]] = {name: {} for name in sets}
    groups: Dict[str, List[int]] = {}
    for i, (name, _) in enumerate(index):
        groups.setdefault(json.dumps(lights_by_set[name]), []).append(i)
    for key, members in groups.items():
        lights = json.loads(key)
        main_req = [requests[i] for i in members if index[i][1] != "cycles_seed1"]
        main_idx = [i for i in members if index[i][1] != "cycles_seed1"]
        for i, imgs in zip(main_idx, cycles_renders(main_req, lights, samples=samples, threads=threads,
                                                    blender=blender)):
            renders[index[i][0]][index[i][1]] = imgs
        seed_idx = [i for i in members if index[i][1] == "cycles_seed1"]
        for i, imgs in zip(seed_idx, cycles_renders([requests[i] for i in seed_idx], lights, samples=samples,
                                                    threads=threads, seed=1, blender=blender)):
            renders[index[i][0]][index[i][1]] = imgs
    light_names = ("flash", "upper left", "lower right")
    out = {"legend": LEGEND, "sets": {}, "lights": {}, "samples": samples}
    for name, maps in sets.items():
        config = configs[name]
        ours = [render(maps.clipped(), p, config) for p in lights_by_set[name]]
        renders[name]["ours"] = ours
        stored = read_principled_set(folder / name / f"{name}.json", config)
        ours_stored = [render(stored, p, config) for p in lights_by_set[name]]
        smith = config.replace(geometry="smith")
        ours_smith = [render(stored, p, smith) for p in lights_by_set[name]]
        cyc = renders[name]["cycles"]
        entry = {
            "size": list(maps.shape[::-1]),
            "render_config": config.to_dict(),
            "specular_range": [float(maps.specular.min()), float(maps.specular.max())],
            "roughness_range": [float(maps.roughness.min()), float(maps.roughness.max())],
            "rmse": {ln: round(_srgb_rmse(c, o), 5) for ln, c, o in zip(light_names, cyc, ours)},
            "rmse_stored_maps": {ln: round(_srgb_rmse(c, o), 5) for ln, c, o in zip(light_names, cyc, ours_stored)},
            "rmse_stored_maps_smith_g": {ln: round(_srgb_rmse(c, o), 5)
                                         for ln, c, o in zip(light_names, cyc, ours_smith)},
            "noise": {ln: round(_srgb_rmse(c, c1) / math.sqrt(2.0), 5)
                      for ln, c, c1 in zip(light_names, cyc, renders[name]["cycles_seed1"])},
            "exposure_fit": {ln: round(_exposure_fit(c, o), 5) for ln, c, o in zip(light_names, cyc, ours)},
            "controls": {_CONTROL_NAMES[w]: {ln: round(_srgb_rmse(c, o), 5)
                                             for ln, c, o in zip(light_names, renders[name][w], ours)}
                         for w in controls},
        }
        out["sets"][name] = entry
        out["lights"][name] = dict(zip(light_names, [None if p is None else [round(v, 6) for v in p]
                                                     for p in lights_by_set[name]]))
    out["blender"] = blender_version(blender)
    out["seconds"] = round(time.perf_counter() - start, 1)
    if keep is None:
        shutil.rmtree(folder, ignore_errors=True)
    return out, renders


def _label_bar(width: int, text: str, height: int = 22) -> np.ndarray:
    import OpenImageIO as oiio

    bar = oiio.ImageBuf(oiio.ImageSpec(width, height, 3, oiio.FLOAT))
    oiio.ImageBufAlgo.fill(bar, (0.12, 0.12, 0.12))
    oiio.ImageBufAlgo.render_text(bar, 4, height - 7, text, 14, "", (0.92, 0.92, 0.92))
    return bar.get_pixels(oiio.FLOAT)[..., :3]


def proof_picture(renders: dict, name: str, out, rmse: Optional[dict] = None, quality: int = 75) -> Path:
    """The picture of :func:`proof`'s renders of set ``name``: rows Cycles, ours and Cycles with the green axis
    flipped; columns the three lights; one exposure for all (the flash render's 99th percentile of ours maps to 1,
    as the relit panel); written as JPEG (``.jpg``) or PNG."""
    import OpenImageIO as oiio

    from ..core.colour import linear_to_srgb

    r = renders[name]
    exposure = 1.0 / max(float(np.percentile(r["ours"][0], 99)), 1e-6)
    rows = [("Blender 3.4 Cycles", r["cycles"]), ("ours (core/render.py)", r["ours"])]
    if "flip_green" in r:
        rows.append(("Cycles, normal green flipped (wrong)", r["flip_green"]))
    lights = ("flash", "light upper left", "light lower right")
    gap = 4
    tiles = []
    for label, imgs in rows:
        cells = []
        for j, img in enumerate(imgs):
            text = f"{label}: {lights[j]}"
            if rmse is not None and label.startswith("Blender"):
                text = f"Cycles, {lights[j]}: RMSE {rmse[('flash', 'upper left', 'lower right')[j]]:.4f}"
            elif label.startswith("ours"):
                text = f"ours, {lights[j]}"
            elif label.startswith("Cycles, normal"):
                text = f"green flipped, {lights[j]}"
            cell = np.clip(linear_to_srgb(np.clip(img * exposure, 0, 1)), 0, 1)
            cells.append(np.concatenate([_label_bar(cell.shape[1], text), cell], 0))
        row = np.concatenate([c for cell in cells for c in (cell, np.full((cell.shape[0], gap, 3), 0.12))][:-1], 1)
        tiles += [row, np.full((gap, row.shape[1], 3), 0.12)]
    pic = np.concatenate(tiles[:-1], 0).astype(np.float32)
    out = Path(out)
    buf = oiio.ImageBuf(oiio.ImageSpec(pic.shape[1], pic.shape[0], 3, oiio.UINT8))
    buf.set_pixels(oiio.ROI(), np.round(pic * 255).astype(np.uint8))
    if out.suffix.lower() in (".jpg", ".jpeg"):
        buf.specmod().attribute("compression", f"jpeg:{int(quality)}")
    if not buf.write(str(out)):
        raise SvbrdfError(f"{out}: cannot write ({buf.geterror()})")
    return out


# ------------------------------------------------------------------------------------------------ command line


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    p = argparse.ArgumentParser(prog=PROG, description="svbrdf in Blender: the add-on, a .blend of a texture set, "
                                                       "and our renderer checked against Cycles.")
    p.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    a = sub.add_parser("addon", help="write the add-on's zip (install it in Blender: Preferences > Add-ons > "
                                     "Install...)")
    a.add_argument("-o", "--out", type=Path, default=Path("."), metavar="DIR",
                   help=f"folder of {ADDON_ZIP}, or a .zip path (default: the current folder)")
    a.add_argument("--force", action="store_true", help="replace an existing zip")
    b = sub.add_parser("blend", help="a .blend with a texture set's material (runs blender -b)")
    b.add_argument("sidecar", type=Path, metavar="SET.json", help="the texture set's sidecar (any --target)")
    b.add_argument("-o", "--out", type=Path, required=True, metavar="FILE.blend")
    b.add_argument("--ao", choices=("none", "multiply"), default="none",
                   help="the AO: left unconnected (default) or multiplied into the base colour")
    b.add_argument("--no-displacement", action="store_true", help="do not wire the height as displacement")
    b.add_argument("--pack", action="store_true", help="pack the images into the .blend")
    b.add_argument("--blender", metavar="PATH", help=f"Blender executable (default: ${BLENDER_ENV}, else blender)")
    b.add_argument("--force", action="store_true", help="replace an existing .blend")
    c = sub.add_parser("proof", help="render texture sets with Cycles and with ours; per-light sRGB RMSE")
    c.add_argument("--json", type=Path, metavar="FILE", help="write the figures (e.g. docs/results/blender.json)")
    c.add_argument("--image", type=Path, metavar="FILE", help="write the picture (e.g. docs/images/blender.jpg)")
    c.add_argument("--size", type=int, default=128, help="side of the synthetic maps (default 128)")
    c.add_argument("--samples", type=int, default=16, help="Cycles samples per pixel (default 16)")
    c.add_argument("--threads", type=int, default=1, help="CPU threads (default 1)")
    c.add_argument("--blender", metavar="PATH", help=f"Blender executable (default: ${BLENDER_ENV}, else blender)")
    return p


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``svbrdf-blender``: 0 success, 1 failure (one line on stderr), 2 usage error."""
    args, code = parse_command_line(build_parser(), argv)
    if args is None:
        return code
    try:
        if args.command == "addon":
            path = write_addon_zip(args.out, force=args.force)
            print(f"{path}  (Blender: Edit > Preferences > Add-ons > Install..., then enable "
                  f"\"{_addon_title()}\")")
        elif args.command == "blend":
            path = write_blend(args.sidecar, args.out, ao=args.ao.upper(), displacement=not args.no_displacement,
                               pack=args.pack, blender=args.blender, force=args.force)
            print(path)
        else:
            command = " ".join([PROG, *(argv if argv is not None else sys.argv[1:])])
            figures, renders = proof(size=args.size, samples=args.samples, threads=args.threads,
                                     blender=args.blender)
            figures = {"command": command, **figures}
            if args.image is not None:
                proof_picture(renders, "carved_wood", args.image, figures["sets"]["carved_wood"]["rmse"])
                figures["image"] = str(args.image)
            text = json.dumps(figures, indent=2) + "\n"
            if args.json is not None:
                args.json.write_text(text, encoding="utf-8")
            print(text, end="")
    except SvbrdfError as exc:
        print(f"{PROG}: error: {cli_message(exc)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{PROG}: error: interrupted", file=sys.stderr)
        return 130
    return 0


def _addon_title() -> str:
    text = (addon_source() / "__init__.py").read_text(encoding="utf-8")
    start = text.index('"name": "') + 9
    return text[start:text.index('"', start)]


__all__ = ["write_addon_zip", "write_blend", "find_blender", "blender_version", "run_job", "cycles_renders",
           "proof", "proof_maps", "proof_picture", "addon_source", "ADDON_MODULE", "ADDON_ZIP", "CONTROLS", "main"]


if __name__ == "__main__":
    sys.exit(main())
