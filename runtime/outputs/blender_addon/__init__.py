"""svbrdf for Blender: a Principled BSDF material from one flash photo, or from an svbrdf texture set.

Two operators, in the 3D view (Object menu and the sidebar's *svbrdf* tab) and in the Shader Editor (Node menu and
the sidebar's *svbrdf* tab):

* **Material from flash photo** (``svbrdf.material_from_photo``): runs ``svbrdf-preview PHOTO --target blender``
  (optionally ``--tileable``, ``--refine``) as a subprocess, the path of the executable found on ``PATH`` or set in
  the add-on's preferences, polled on a timer so Blender stays live (progress in the status bar, Esc stops it;
  headless Blender runs it to the end), then builds the material from the set it wrote;
* **Material from texture set** (``svbrdf.material_from_set``): builds the material from a set's sidecar JSON, of
  any ``--target`` (:mod:`.sets`).

The material goes into the active object's active slot, or onto a new plane of the set's aspect when no mesh is
active; the AO can be multiplied into the base colour or left unconnected (default), the height is wired as true
displacement (:mod:`.material`). Problems are reported in Blender with one line (``self.report({'ERROR'}, ...)``).

Blender's Python has no numpy: the add-on imports only the standard library and bpy, and bpy only inside Blender
(this package imports outside it, for the tests of :mod:`.sets` and :mod:`.preview`). Source of truth: the
``svbrdf`` package (``runtime/outputs/blender_addon``); ``svbrdf-blender addon -o DIR`` writes the zip to install.
"""

bl_info = {
    "name": "svbrdf: material from a flash photo",
    "author": "svbrdf",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D View and Shader Editor > Sidebar > svbrdf; Object menu; Node menu",
    "description": "A Principled BSDF material from one flash photo (svbrdf-preview) or from an svbrdf texture set",
    "category": "Material",
}

_CLASSES = []
_MENUS = []


def _addon_preferences(context):
    entry = context.preferences.addons.get(__name__)
    return entry.preferences if entry is not None else None


def _classes():
    """The add-on's classes, defined here so that the package imports without bpy."""
    import bpy
    from bpy.props import BoolProperty, EnumProperty, StringProperty
    from bpy_extras.io_utils import ImportHelper

    from . import material, preview, sets

    ao_items = [("NONE", "Unconnected", "Load the AO image but leave it unconnected (our base colour holds no "
                                        "occlusion)"),
                ("MULTIPLY", "Multiply base colour", "Multiply the AO into the base colour (an extra darkening)")]

    class SVBRDF_AddonPreferences(bpy.types.AddonPreferences):
        bl_idname = __name__

        executable: StringProperty(
            name="svbrdf-preview", subtype="FILE_PATH", default="",
            description="Path of the svbrdf-preview executable of your svbrdf installation (empty: look it up on "
                        "PATH), e.g. /home/me/svbrdf/.venv/bin/svbrdf-preview")

        def draw(self, context):
            layout = self.layout
            layout.prop(self, "executable")
            try:
                found = preview.find_executable(self.executable)
                layout.label(text=f"Using {found}", icon="CHECKMARK")
            except sets.SetError as exc:
                layout.label(text=str(exc), icon="ERROR")
            problem = sets.version_problem(bpy.app.version)
            if problem:
                layout.label(text=problem, icon="ERROR")

    def _target_object(context):
        obj = context.active_object
        return obj if obj is not None and obj.type == "MESH" else None

    def _finish(op, context, sidecar) -> set:
        """Build the material of ``sidecar`` and put it on the active mesh (or a new plane)."""
        plan = sets.read_set(sidecar)
        obj = _target_object(context)
        w, h = plan["size"]
        if obj is None:
            obj = material.make_plane(plan["name"], 2.0, h / max(w, 1), location=tuple(context.scene.cursor.location),
                                      collection=context.collection)
            for other in context.view_layer.objects:
                other.select_set(False)
            obj.select_set(True)
            context.view_layer.objects.active = obj
        mat = material.build_material(plan, ao=op.ao, displacement=op.displacement,
                                      width=material.surface_width(obj))
        material.assign_material(obj, mat)
        if plan["approximate"]:
            op.report({"WARNING"}, f"svbrdf: material {mat.name!r} is approximate: {plan['approximate']}")
        else:
            op.report({"INFO"}, f"svbrdf: material {mat.name!r} on {obj.name!r} from {sidecar}")
        return {"FINISHED"}

    class _Options:
        ao: EnumProperty(name="Ambient occlusion", items=ao_items, default="NONE")
        displacement: BoolProperty(name="Displacement", default=True,
                                   description="Wire the height into the Material Output as true displacement "
                                               "(Displacement Only; it shows on a subdivided surface)")

    class SVBRDF_OT_material_from_set(_Options, bpy.types.Operator, ImportHelper):
        """A Principled BSDF material from an svbrdf texture set (its sidecar JSON, any target)"""

        bl_idname = "svbrdf.material_from_set"
        bl_label = "Material from texture set"
        bl_options = {"REGISTER", "UNDO"}
        filename_ext = ".json"
        filter_glob: StringProperty(default="*.json", options={"HIDDEN"})

        def execute(self, context):
            try:
                problem = sets.version_problem(bpy.app.version)
                if problem:
                    raise sets.SetError(problem)
                return _finish(self, context, self.filepath)
            except sets.SetError as exc:
                self.report({"ERROR"}, f"svbrdf: {exc}")
                return {"CANCELLED"}

    class SVBRDF_OT_material_from_photo(_Options, bpy.types.Operator, ImportHelper):
        """Run svbrdf-preview on a flash photo of a flat material, then build its Principled BSDF material"""

        bl_idname = "svbrdf.material_from_photo"
        bl_label = "Material from flash photo"
        bl_options = {"REGISTER", "UNDO"}
        filter_glob: StringProperty(default="*.jpg;*.jpeg;*.png;*.tif;*.tiff;*.exr", options={"HIDDEN"})
        tileable: BoolProperty(name="Tileable", default=False, description="Maps that repeat without a seam")
        refine: BoolProperty(name="Refine", default=False,
                             description="Fine-tune the model on the photo (needs svbrdf's training side, torch; "
                                         "about 20 s at 256 px)")
        overwrite: BoolProperty(name="Overwrite", default=False,
                                description="Replace a texture set already written for this photo")
        out_dir: StringProperty(name="Output folder", subtype="DIR_PATH", default="",
                                description="Where the texture set goes (empty: <photo name>_svbrdf beside the photo)")

        _run = None
        _timer = None

        def _start(self, context):
            problem = sets.version_problem(bpy.app.version)
            if problem:
                raise sets.SetError(problem)
            prefs = _addon_preferences(context)
            exe = preview.find_executable(prefs.executable if prefs is not None else "")
            return dict(executable=exe, photo=self.filepath, out_dir=bpy.path.abspath(self.out_dir),
                        tileable=self.tileable, refine=self.refine, overwrite=self.overwrite)

        def execute(self, context):
            try:
                args = self._start(context)
                if bpy.app.background or context.window is None:  # headless: run it to the end
                    sidecar = preview.run_preview(**args)
                    return _finish(self, context, sidecar)
                self._run = preview.PreviewRun(**args)
            except sets.SetError as exc:
                self.report({"ERROR"}, f"svbrdf: {exc}")
                return {"CANCELLED"}
            wm = context.window_manager
            self._timer = wm.event_timer_add(0.25, window=context.window)
            wm.modal_handler_add(self)
            context.workspace.status_text_set(self._run.status)
            return {"RUNNING_MODAL"}

        def _end(self, context):
            context.window_manager.event_timer_remove(self._timer)
            context.workspace.status_text_set(None)

        def modal(self, context, event):
            if event.type == "ESC":
                self._run.cancel()
                self._end(context)
                self.report({"WARNING"}, "svbrdf: stopped; no texture set written")
                return {"CANCELLED"}
            if event.type != "TIMER":
                return {"PASS_THROUGH"}
            if self._run.poll() is None:
                context.workspace.status_text_set(self._run.status + "  (Esc: stop)")
                return {"RUNNING_MODAL"}
            self._end(context)
            try:
                return _finish(self, context, self._run.result())
            except sets.SetError as exc:
                self.report({"ERROR"}, f"svbrdf: {exc}")
                return {"CANCELLED"}

    class _Panel:
        bl_region_type = "UI"
        bl_category = "svbrdf"
        bl_label = "svbrdf"

        def draw(self, context):
            col = self.layout.column(align=True)
            col.operator(SVBRDF_OT_material_from_photo.bl_idname, icon="IMAGE_DATA")
            col.operator(SVBRDF_OT_material_from_set.bl_idname, icon="MATERIAL")
            problem = sets.version_problem(bpy.app.version)
            if problem:
                self.layout.label(text=problem, icon="ERROR")

    class SVBRDF_PT_view3d(_Panel, bpy.types.Panel):
        bl_space_type = "VIEW_3D"
        bl_idname = "SVBRDF_PT_view3d"

    class SVBRDF_PT_shader(_Panel, bpy.types.Panel):
        bl_space_type = "NODE_EDITOR"
        bl_idname = "SVBRDF_PT_shader"

        @classmethod
        def poll(cls, context):
            return getattr(context.space_data, "tree_type", "") == "ShaderNodeTree"

    return [SVBRDF_AddonPreferences, SVBRDF_OT_material_from_set, SVBRDF_OT_material_from_photo,
            SVBRDF_PT_view3d, SVBRDF_PT_shader]


def _menu(self, context):
    self.layout.separator()
    self.layout.operator("svbrdf.material_from_photo", icon="IMAGE_DATA")
    self.layout.operator("svbrdf.material_from_set", icon="MATERIAL")


def register():
    import bpy

    from .sets import version_problem

    problem = version_problem(bpy.app.version)
    if problem:  # still registered: the panels and operators show the message where the artist looks
        print(f"svbrdf: {problem}")
    _CLASSES[:] = _classes()
    for cls in _CLASSES:
        bpy.utils.register_class(cls)
    for menu in (bpy.types.VIEW3D_MT_object, bpy.types.NODE_MT_node):
        menu.append(_menu)
        _MENUS.append(menu)


def unregister():
    import bpy

    for menu in _MENUS:
        menu.remove(_menu)
    _MENUS.clear()
    for cls in reversed(_CLASSES):
        bpy.utils.unregister_class(cls)
    _CLASSES.clear()
