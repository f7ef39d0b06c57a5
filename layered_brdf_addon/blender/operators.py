"""Operators: thin wrappers over the functions of ``sync``, ``user_presets``, ``assets`` and
``looks_library``.

A ParameterError (an invalid value, a linked material, a bad preset file) is reported
as an error and the operator is cancelled with nothing changed.
"""
from __future__ import annotations

from bpy.props import BoolProperty, IntProperty, StringProperty
from bpy.types import Operator

from ..model.params import ParameterError
from . import assets, looks_library, osl, user_presets
from .material_values import layered_material_of, params_of, settings
from .properties import param_tooltip
from .sync import apply_to_object, desired, remove_from_object, upgrade_all
from .targets import takes_layered_material


def _object_with_materials(context):
    """The active object when it is of a type that renders the layered material (not an Empty, a
    light, a Grease Pencil object...), else None."""
    obj = context.object
    return obj if takes_layered_material(obj) else None


def _layered_material(context):
    return layered_material_of(_object_with_materials(context))


class _Reporting:
    """``execute`` runs ``run``; a ParameterError or OSError becomes an error report."""

    def execute(self, context):
        try:
            message = self.run(context)
        except (ParameterError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if message:
            self.report({"INFO"}, message)
        return {"FINISHED"}


class LAYERED_BRDF_OT_apply(_Reporting, Operator):
    """Give the active object the layered material (or rebuild its own with the current values)"""

    bl_idname = "layered_brdf.apply"
    bl_label = "Apply Layered BRDF"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return _object_with_materials(context) is not None

    def run(self, context):
        mat = apply_to_object(context.object)
        return f"Layered BRDF applied: material '{mat.name}'"


class LAYERED_BRDF_OT_remove(_Reporting, Operator):
    """Remove the layered material from the active object's slot and put back the material it replaced"""

    bl_idname = "layered_brdf.remove"
    bl_label = "Remove Layered BRDF"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return _layered_material(context) is not None

    def run(self, context):
        if not remove_from_object(context.object):
            raise ParameterError("object", context.object.name, "an object with a layered material")
        return "Layered BRDF removed"


class LAYERED_BRDF_OT_load_preset(_Reporting, Operator):
    """Load a preset into the active object's layered material (applying it when needed)"""

    bl_idname = "layered_brdf.load_preset"
    bl_label = "Load Preset"
    bl_options = {"REGISTER", "UNDO"}

    preset: StringProperty(name="Preset", description="A built-in preset name or 'user:<name>'")

    @classmethod
    def poll(cls, context):
        return _object_with_materials(context) is not None

    @classmethod
    def description(cls, context, props):
        return f"Load the preset '{props.preset}' into the layered material"

    def run(self, context):
        params = user_presets.preset_params(self.preset)
        mat = apply_to_object(context.object, params)
        settings(mat).preset = self.preset
        return f"Preset '{self.preset}' loaded into '{mat.name}'"


class LAYERED_BRDF_OT_save_preset(_Reporting, Operator):
    """Save the layered material's current values as a user preset, available in every file"""

    bl_idname = "layered_brdf.save_preset"
    bl_label = "Save Preset"
    bl_options = {"REGISTER"}

    name: StringProperty(name="Name", description="Name of the user preset (" + user_presets.NAME_RULE + ")")

    @classmethod
    def poll(cls, context):
        return _layered_material(context) is not None

    def invoke(self, context, event):
        current = settings(_layered_material(context)).preset
        if not self.name:
            self.name = current[len(user_presets.USER_PREFIX):] if current.startswith(user_presets.USER_PREFIX) \
                else "My preset"
        return context.window_manager.invoke_props_dialog(self)

    def run(self, context):
        mat = _layered_material(context)
        path = user_presets.save_user_preset(self.name, params_of(mat))
        settings(mat).preset = user_presets.USER_PREFIX + path.stem
        return f"Preset '{path.stem}' saved to {path}"


class LAYERED_BRDF_OT_delete_preset(_Reporting, Operator):
    """Delete a user preset"""

    bl_idname = "layered_brdf.delete_preset"
    bl_label = "Delete Preset"
    bl_options = {"REGISTER"}

    preset: StringProperty(name="Preset", description="Name of the user preset")

    def invoke(self, context, event):
        return context.window_manager.invoke_confirm(self, event, message=f"Delete the preset '{self.preset}'?")

    def run(self, context):
        user_presets.delete_user_preset(self.preset)
        return f"Preset '{self.preset}' deleted"


class LAYERED_BRDF_OT_mark_asset(_Reporting, Operator):
    """Mark the layered material as an asset (a look) with a rendered preview, for the Asset Browser"""

    bl_idname = "layered_brdf.mark_asset"
    bl_label = "Mark Material as Asset"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        mat = _layered_material(context)
        return mat is not None and mat.library is None

    def run(self, context):
        mat = _layered_material(context)
        desired(mat)  # a material that can be built (else ParameterError, nothing changes)
        assets.publish(mat, preview=True)
        catalog = next(c.path for c in assets.CATALOGS.values() if c.uuid == mat.asset_data.catalog_id)
        return f"Material '{mat.name}' is an asset in the catalog '{catalog}'"


class LAYERED_BRDF_OT_build_asset_library(_Reporting, Operator):
    """Write every preset as a material asset with a preview into a folder (a .blend and its catalogs), \
for the Asset Browser; optionally add the folder to Preferences > File Paths > Asset Libraries"""

    bl_idname = "layered_brdf.build_asset_library"
    bl_label = "Build Looks Library"
    bl_options = {"REGISTER"}

    directory: StringProperty(name="Folder", subtype="DIR_PATH",
                              description="The library folder: 'Layered BRDF Looks.blend' and "
                                          "'blender_assets.cats.txt' are written there")
    filter_folder: BoolProperty(default=True, options={"HIDDEN", "SKIP_SAVE"})
    include_user_presets: BoolProperty(name="Include User Presets", default=True,
                                       description="Also write your saved presets (catalog 'User presets')")
    register_library: BoolProperty(name="Add to Asset Libraries", default=True,
                                   description="Add the folder in Preferences > File Paths > Asset Libraries")
    preview_size: IntProperty(name="Preview Size", default=assets.PREVIEW_SIZE, min=0,
                              max=assets.PREVIEW_SIZE_RANGE[1],
                              description="Preview size in pixels (0: no previews)")
    samples: IntProperty(name="Preview Samples", default=assets.PREVIEW_SAMPLES,
                         min=assets.PREVIEW_SAMPLES_RANGE[0], max=assets.PREVIEW_SAMPLES_RANGE[1],
                         description="Cycles samples per preview pixel")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def run(self, context):
        if not self.directory:
            raise ParameterError("directory", self.directory, "a folder path")
        presets = looks_library.default_presets(include_user=self.include_user_presets)
        wm = context.window_manager
        wm.progress_begin(0, 1)
        try:
            result = looks_library.write_library(
                self.directory, presets, preview_size=self.preview_size, samples=self.samples,
                progress=lambda done, total: wm.progress_update(done / total))
        finally:
            wm.progress_end()
        message = f"{len(result.assets)} looks written to {result.blend}"
        if self.register_library:
            lib, added = looks_library.register_library(result.directory)
            message += f"; asset library '{lib.name}' " + ("added to the Preferences" if added else "already listed")
        return message


class LAYERED_BRDF_OT_upgrade(_Reporting, Operator):
    """Rebuild the file's layered materials whose node group or OSL shader is out of date"""

    bl_idname = "layered_brdf.upgrade"
    bl_label = "Update Layered Materials"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        done = upgrade_all()
        return f"Updated {len(done)} material(s)" + (": " + ", ".join(done) if done else "")


class LAYERED_BRDF_OT_enable_osl(_Reporting, Operator):
    """Set the scene up so Cycles runs OSL: Cycles, Open Shading Language on, CPU unless the GPU is OptiX"""

    bl_idname = "layered_brdf.enable_osl"
    bl_label = "Enable OSL"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        scene = context.scene
        scene.render.engine = "CYCLES"
        scene.cycles.shading_system = True
        ok, reason = osl.scene_supports_osl(scene)
        if not ok:
            scene.cycles.device = "CPU"
            ok, reason = osl.scene_supports_osl(scene)
        if not ok:
            raise ParameterError("scene", scene.name, f"a scene that can run OSL ({reason})")
        return "Cycles will run OSL in this scene"


class LAYERED_BRDF_OT_param_info(Operator):
    """A parameter of the layered material"""

    bl_idname = "layered_brdf.param_info"
    bl_label = "Parameter"
    bl_options = {"INTERNAL"}

    param: StringProperty(options={"HIDDEN", "SKIP_SAVE"})

    @classmethod
    def description(cls, context, props):
        return param_tooltip(props.param)

    def execute(self, context):
        self.report({"INFO"}, param_tooltip(self.param))
        return {"FINISHED"}
