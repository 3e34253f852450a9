"""Our renderer's scene in Blender, and the headless jobs of ``svbrdf.runtime.outputs.blender`` (bpy in each function).

The scene of :func:`svbrdf.runtime.core.render.render`, rebuilt exactly (lengths in half the map width):

* the material on the plane z = 0 spanning x in [-1, 1] and y in [-H/W, H/W] (:func:`.material.make_plane`, width 2);
* a perspective camera at (0, 0, d), ``d = 1 / tan(fov / 2)``, looking down -z with +y up the image, the
  horizontal field of view ``fov`` across the width, the render W x H pixels (one per texel);
* a point light (radius 0) at the flash, (0, 0, d), or at a given position. Our fall-off ``I d^2 / |p_l - p|^2`` is
  that of a point source of radiant intensity ``I d^2``, and Cycles gives a point light of power P the intensity
  ``P / (4 pi)`` (checked: a white Lambertian plane under the flash renders at our value to 0.1 %), so
  ``P = 4 pi I d^2`` (:func:`point_light_power`);
* Cycles on the CPU: direct light only (no bounce: our renderer has none), the pixel filter 0.01 px wide (every
  sample at the pixel's centre, where ours samples; the centre of a pixel is the centre of its texel), no
  denoising (this build has no OpenImageDenoise), the Standard view transform; the result written as a 32-bit
  linear OpenEXR.

A job is a JSON file (``svbrdf.runtime.outputs.blender`` writes it and runs ``blender -b --python-expr``):
``{"renders": [...]}`` renders sets under lights, ``{"blend": {...}}`` saves a .blend with a set's material.
"""

from __future__ import annotations

import json
import math
import sys

from .material import build_material, make_plane
from .sets import SetError, read_set, version_problem, wrong_convention


def point_light_power(intensity: float, camera_distance: float) -> float:
    """Cycles point-light power (W) whose fall-off equals our renderer's ``falloff=True`` light of ``intensity``."""
    return 4.0 * math.pi * float(intensity) * float(camera_distance) ** 2


def empty_scene():
    """A new empty scene (every object, material, image, light and camera of the file removed), made current."""
    import bpy

    for collection in (bpy.data.objects, bpy.data.meshes, bpy.data.materials, bpy.data.images, bpy.data.lights,
                       bpy.data.cameras, bpy.data.worlds):
        for block in list(collection):
            collection.remove(block)
    scene = bpy.context.scene
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    if bg is not None:
        bg.inputs["Strength"].default_value = 0.0
    scene.world = world
    return scene


def flash_scene(plan: dict, fov_deg: float, intensity: float, *, size=None, ao: str = "NONE",
                displacement: bool = False, samples: int = 16, threads: int = 0, seed: int = 0):
    """Build our renderer's scene (module docstring) for ``plan`` in the current (emptied) scene.

    Args:
        plan: the material plan (:func:`.sets.read_set`).
        fov_deg: horizontal field of view, degrees (the set's ``brdf.render_config.fov_deg``).
        intensity: our light intensity I (``render_config.intensity``).
        size: (width, height) of the render in pixels (default: the set's size).
        ao, displacement: as :func:`.material.build_material` (default: no displacement, our renderer has none).
        samples: Cycles samples per pixel; threads: CPU threads (0: all); seed: Cycles' seed.

    Returns:
        ``(scene, light object, camera distance d)``.
    """
    import bpy

    scene = empty_scene()
    w, h = size or plan["size"]
    d = 1.0 / math.tan(math.radians(fov_deg) / 2.0)
    plane = make_plane(plan["name"], 2.0, h / w, collection=scene.collection)
    plane.data.materials.append(build_material(plan, ao=ao, displacement=displacement, width=2.0))

    cam = bpy.data.cameras.new("flash camera")
    cam.sensor_fit = "HORIZONTAL"
    cam.angle = math.radians(fov_deg)
    cam.clip_start = 0.01
    cam.clip_end = 100.0
    cam_obj = bpy.data.objects.new("flash camera", cam)
    cam_obj.location = (0.0, 0.0, d)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj

    light = bpy.data.lights.new("flash", "POINT")
    light.shadow_soft_size = 0.0
    light.energy = point_light_power(intensity, d)
    light_obj = bpy.data.objects.new("flash", light)
    light_obj.location = (0.0, 0.0, d)
    scene.collection.objects.link(light_obj)

    scene.render.engine = "CYCLES"
    cyc = scene.cycles
    cyc.device = "CPU"
    cyc.samples = int(samples)
    cyc.use_adaptive_sampling = False
    cyc.use_denoising = False
    cyc.max_bounces = 0
    cyc.filter_width = 0.01
    cyc.seed = int(seed)
    if threads:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = int(threads)
    scene.render.resolution_x, scene.render.resolution_y = int(w), int(h)
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_mode = "RGB"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.exr_codec = "ZIP"
    return scene, light_obj, d


def render_job(job: dict) -> None:
    """Render each entry of ``job["renders"]``: ``{"sidecar", "wrong" (None or a :func:`.sets.wrong_convention`
    kind), "fov_deg", "intensity", "lights" ([x, y, z] or None for the flash), "outputs" (one .exr per light),
    "size" (optional)}``, with ``job["samples"]``, ``job["threads"]``, ``job["seed"]``."""
    import bpy

    for entry in job["renders"]:
        plan = read_set(entry["sidecar"])
        if entry.get("wrong"):
            plan = wrong_convention(plan, entry["wrong"])
        scene, light, d = flash_scene(plan, entry["fov_deg"], entry["intensity"], size=entry.get("size"),
                                      samples=job.get("samples", 16), threads=job.get("threads", 0),
                                      seed=job.get("seed", 0))
        for pos, out in zip(entry["lights"], entry["outputs"]):
            light.location = (0.0, 0.0, d) if pos is None else tuple(float(v) for v in pos)
            scene.render.filepath = out
            bpy.ops.render.render(write_still=True)


def blend_job(job: dict) -> None:
    """Save a .blend with a set's material on a plane, under the flash camera and light:
    ``{"sidecar", "out", "ao", "displacement", "pack", "fov_deg", "intensity", "samples"}``."""
    import bpy

    plan = read_set(job["sidecar"])
    flash_scene(plan, job.get("fov_deg", 66.0), job.get("intensity", math.pi), ao=job.get("ao", "NONE"),
                displacement=job.get("displacement", True), samples=job.get("samples", 64))
    scene = bpy.context.scene
    scene.cycles.max_bounces = 12  # an artist's scene: the usual light paths
    scene.cycles.filter_width = 1.5
    if job.get("pack"):
        bpy.ops.file.pack_all()
    bpy.ops.wm.save_as_mainfile(filepath=job["out"], check_existing=False, relative_remap=not job.get("pack"))


def run_job_file(path: str) -> None:
    """Run the job in the JSON file ``path``; a problem is one line ``svbrdf-blender: error: ...`` on stderr and
    exit code 1 (the caller shows the line)."""
    import bpy

    try:
        problem = version_problem(bpy.app.version)
        if problem:
            raise SetError(problem)
        with open(path, encoding="utf-8") as f:
            job = json.load(f)
        if "renders" in job:
            render_job(job)
        elif "blend" in job:
            blend_job(job["blend"])
        else:
            raise SetError(f"{path}: no job")
    except SetError as exc:
        print(f"svbrdf-blender: error: {exc}", file=sys.stderr, flush=True)
        sys.exit(1)


__all__ = ["point_light_power", "empty_scene", "flash_scene", "render_job", "blend_job", "run_job_file"]
