"""A material plan (:func:`.sets.read_set`) -> a Principled BSDF node tree in Blender (bpy, imported in each function).

The node graph is the plan's arithmetic, one node per step, labelled so that an artist sees what each does:

* base colour: the colour file (sRGB), times ``1 - F0`` where the plan says so (``F0 = 0.08 x Specular``), times
  the AO when the artist asks for it (``ao="MULTIPLY"``; by default the AO image is added unconnected);
* Specular: the file's channel (Non-Color) times the plan's scale (Math node, not clamped: values above 1 are the
  F0 above 0.08 the texture could not hold); Specular Tint 0; Metallic 0 unless the plan has a metallic map;
* Roughness: the channel (Non-Color), ``1 - value`` for a smoothness channel, ``value ** power`` (1);
* Normal: the normal file (Non-Color) through a Normal Map node in tangent space (the green channel flipped
  first for a DirectX map);
* Displacement: the height (Non-Color) through a Displacement node, midlevel 0.5, Scale ``height_scale x width``
  (the surface's width in scene units), into the Material Output, with the material's displacement method set to
  *Displacement Only*: it moves a subdivided surface and never adds a bump on top of the normal map (the height is
  the normal map's own integral).

The Principled BSDF uses the GGX distribution (single scattering, as our renderer; Multiscatter GGX adds the
energy of the inter-reflections). Blender 4.x (untested here) names the specular input *Specular IOR Level*; it
takes the same value at IOR 1.5.
"""

from __future__ import annotations

import os

from .sets import F0_PER_SPECULAR, SetError

#: Where the AO goes: into the base colour, or loaded but left unconnected (our base colour holds no occlusion).
AO_MODES = ("NONE", "MULTIPLY")


def _colourspace(image, colour: bool) -> None:
    want = "sRGB" if colour else "Non-Color"
    try:
        image.colorspace_settings.name = want
    except TypeError:  # a configuration without that name
        image.colorspace_settings.is_data = not colour


class _Graph:
    """Node creation helpers on one material's node tree."""

    def __init__(self, material):
        self.tree = material.node_tree
        self.nodes = self.tree.nodes
        self.links = self.tree.links
        self.images = {}
        self.separated = {}

    def node(self, kind: str, x: float, y: float, label: str = "", **settings):
        n = self.nodes.new(kind)
        n.location = (x, y)
        if label:
            n.label = label
        for key, value in settings.items():
            setattr(n, key, value)
        return n

    def link(self, out, inp) -> None:
        self.links.new(out, inp)

    def image(self, source: dict, y: float, label: str):
        """The Image Texture node of a source's file: one per file and colour space (an alpha channel reads any)."""
        path, colour, alpha = source["file"], bool(source["colour"]), source.get("channel") == "A"
        for node_colour, node in self.images.get(path, ()):
            if alpha or node_colour == colour:
                if alpha:
                    node.image.alpha_mode = "CHANNEL_PACKED"
                return node
        import bpy

        try:
            img = bpy.data.images.load(path, check_existing=False)
        except RuntimeError as exc:
            raise SetError(f"Blender cannot read {path}: {str(exc).splitlines()[0]}")
        _colourspace(img, colour)
        if alpha:
            img.alpha_mode = "CHANNEL_PACKED"  # the alpha is data: no premultiplication
        node = self.node("ShaderNodeTexImage", -1400, y, label or os.path.basename(path), image=img,
                         interpolation="Linear")
        self.images.setdefault(path, []).append((colour, node))
        return node

    def value(self, source: dict, y: float, label: str = ""):
        """The output socket of a source: the image's colour, its alpha, or one channel."""
        tex = self.image(source, y, label)
        channel = source.get("channel")
        if channel is None:
            return tex.outputs["Color"]
        if channel == "A":
            return tex.outputs["Alpha"]
        sep = self.separated.get(tex.name)
        if sep is None:
            sep = self.node("ShaderNodeSeparateColor", -1100, tex.location.y)
            self.link(tex.outputs["Color"], sep.inputs[0])
            self.separated[tex.name] = sep
        return sep.outputs[{"R": "Red", "G": "Green", "B": "Blue"}[channel]]

    def math(self, op: str, a, b=None, c=None, x: float = -850, y: float = 0, label: str = ""):
        n = self.node("ShaderNodeMath", x, y, label, operation=op, use_clamp=False)
        for i, v in enumerate((a, b, c)):
            if v is None:
                continue
            if isinstance(v, (int, float)):
                n.inputs[i].default_value = float(v)
            else:
                self.link(v, n.inputs[i])
        return n.outputs[0]

    def multiply_colour(self, colour, factor, x: float, y: float, label: str):
        n = self.node("ShaderNodeVectorMath", x, y, label, operation="MULTIPLY")
        self.link(colour, n.inputs[0])
        self.link(factor, n.inputs[1])
        return n.outputs[0]


def _socket(bsdf, *names):
    for name in names:
        if name in bsdf.inputs:
            return bsdf.inputs[name]
    raise SetError(f"this Blender's Principled BSDF has no {names[0]!r} input")


def build_material(plan: dict, *, ao: str = "NONE", displacement: bool = True, width: float = 2.0,
                   name: str = ""):
    """A new material with the Principled BSDF of ``plan`` (module docstring).

    Args:
        plan: :func:`.sets.read_set`'s plan.
        ao: ``"NONE"`` (the AO image loaded, unconnected) or ``"MULTIPLY"`` (multiplied into the base colour).
        displacement: connect the height to the Material Output's displacement (when the set has one).
        width: the width of the surface in scene units (the Displacement node's Scale is ``height_scale x width``).
        name: the material's name (default: the set's).

    Returns:
        The ``bpy.types.Material``.

    Raises:
        SetError: an unknown ``ao``, or an image Blender cannot read (the message is one line).
    """
    import bpy

    if ao not in AO_MODES:
        raise SetError(f"unknown AO mode {ao!r}; expected one of {', '.join(AO_MODES)}")
    mat = bpy.data.materials.new(name or plan["name"])
    mat.use_nodes = True
    g = _Graph(mat)
    g.nodes.clear()
    out = g.node("ShaderNodeOutputMaterial", 400, 0)
    bsdf = g.node("ShaderNodeBsdfPrincipled", 0, 0, distribution="GGX")
    g.link(bsdf.outputs["BSDF"], out.inputs["Surface"])
    tint = _socket(bsdf, "Specular Tint")
    if tint.type == "VALUE":
        tint.default_value = 0.0
    else:  # Blender 4.x: a colour, white = no tint
        tint.default_value = (1.0, 1.0, 1.0, 1.0)

    # Specular (and F0 for the base colour's 1 - F0)
    spec_value = None
    if plan.get("specular") is not None:
        s = plan["specular"]
        raw = g.value(s, 300, "specular")
        spec_value = g.math("MULTIPLY", raw, float(s["scale"]), x=-850, y=300,
                            label=f"Specular = {s['scale']:.6g} x texture")
        level = _socket(bsdf, "Specular", "Specular IOR Level")
        if level.name != "Specular" and "IOR" in bsdf.inputs:
            bsdf.inputs["IOR"].default_value = 1.5  # 4.x: F0 = 0.08 x level at IOR 1.5
        g.link(spec_value, level)
    if plan.get("metallic") is not None:
        g.link(g.value(plan["metallic"], 150, "metallic"), _socket(bsdf, "Metallic"))

    # Base colour
    b = plan["base"]
    base = g.value(b, 600, "base colour")
    if b.get("times_one_minus_f0"):
        if spec_value is None:
            raise SetError("the base colour needs 1 - F0 but the set has no specular map")
        one_minus = g.math("MULTIPLY_ADD", spec_value, -F0_PER_SPECULAR, 1.0, x=-600, y=450, label="1 - F0")
        base = g.multiply_colour(base, one_minus, -400, 600, "base x (1 - F0)")
    if plan.get("ao") is not None:
        ao_value = g.value(plan["ao"], 850, "ambient occlusion")
        if ao == "MULTIPLY":
            base = g.multiply_colour(base, ao_value, -250, 750, "base x AO")
    g.link(base, _socket(bsdf, "Base Color"))

    # Roughness
    r = plan["roughness"]
    rough = g.value(r, 0, "roughness")
    if r.get("invert"):
        rough = g.math("SUBTRACT", 1.0, rough, x=-850, y=0, label="roughness = 1 - smoothness")
    if float(r.get("power", 1.0)) != 1.0:
        rough = g.math("POWER", rough, float(r["power"]), x=-650, y=0, label=f"roughness ^ {r['power']:g}")
    g.link(rough, _socket(bsdf, "Roughness"))

    # Normal
    n = plan["normal"]
    tex = g.image(n, -300, "normal")
    colour = tex.outputs["Color"]
    if n.get("flip_green"):
        sep = g.node("ShaderNodeSeparateColor", -1100, -300)
        g.link(colour, sep.inputs[0])
        comb = g.node("ShaderNodeCombineColor", -650, -300, "green flipped (DirectX)")
        g.link(sep.outputs["Red"], comb.inputs[0])
        g.link(g.math("SUBTRACT", 1.0, sep.outputs["Green"], x=-850, y=-350), comb.inputs[1])
        g.link(sep.outputs["Blue"], comb.inputs[2])
        colour = comb.outputs[0]
    nmap = g.node("ShaderNodeNormalMap", -300, -300, "normal map (tangent space)", space="TANGENT")
    g.link(colour, nmap.inputs["Color"])
    g.link(nmap.outputs["Normal"], _socket(bsdf, "Normal"))

    # Height and displacement
    h = plan.get("height")
    if h is not None:
        height = g.value(h, -650, "height")
        scale = float(h.get("height_scale", 0.0)) * float(width)
        disp = g.node("ShaderNodeDisplacement", 150, -500, f"height x {h.get('height_scale', 0.0):.4g} x width "
                                                           f"{width:g}")
        disp.inputs["Midlevel"].default_value = 0.5
        disp.inputs["Scale"].default_value = scale
        g.link(height, disp.inputs["Height"])
        if displacement:
            g.link(disp.outputs["Displacement"], out.inputs["Displacement"])
            _displacement_only(mat)
    return mat


def _displacement_only(mat) -> None:
    """The material's displacement method: true displacement only (Cycles), never a bump on top of the normal map."""
    holder = mat if hasattr(mat, "displacement_method") else getattr(mat, "cycles", None)
    if holder is not None and hasattr(holder, "displacement_method"):
        holder.displacement_method = "DISPLACEMENT"


def make_plane(name: str, width: float = 2.0, aspect: float = 1.0, location=(0.0, 0.0, 0.0), collection=None):
    """A plane object ``width`` wide and ``width x aspect`` high (aspect = height / width of the set), UVs over
    [0, 1] (the texture's bottom-left at the plane's bottom-left, +x right and +y up: OpenGL tangents), linked to
    ``collection`` (default: the scene's)."""
    import bpy

    hw, hh = width / 2.0, width * aspect / 2.0
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(-hw, -hh, 0.0), (hw, -hh, 0.0), (hw, hh, 0.0), (-hw, hh, 0.0)], [], [(0, 1, 2, 3)])
    uv = mesh.uv_layers.new(name="UVMap")
    for loop, co in zip(mesh.loops, ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))):
        uv.data[loop.index].uv = co
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def assign_material(obj, mat) -> None:
    """Put ``mat`` in the object's active material slot (a new slot when it has none)."""
    if obj.data is None or not hasattr(obj.data, "materials"):
        raise SetError(f"the active object {obj.name!r} cannot hold a material (select a mesh)")
    if len(obj.material_slots) == 0:
        obj.data.materials.append(mat)
    else:
        obj.material_slots[obj.active_material_index].material = mat


def surface_width(obj) -> float:
    """The width of ``obj`` in scene units for the displacement scale: its larger horizontal dimension (2 without
    one)."""
    if obj is None:
        return 2.0
    w = max(float(obj.dimensions[0]), float(obj.dimensions[1]))
    return w if w > 0.0 else 2.0


__all__ = ["build_material", "make_plane", "assign_material", "surface_width", "AO_MODES"]
