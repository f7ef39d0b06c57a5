"""Operators: thin wrappers over the functions of ``properties``, ``user_presets`` and ``assets``.

A ParameterError (an invalid value, a linked material, a bad preset file) is reported
as an error and the operator is cancelled with nothing changed.
"""
from __future__ import annotations

from bpy.props import StringProperty
from bpy.types import Operator

from ..model.params import ParameterError
from . import assets, osl, properties, user_presets


def _object_with_materials(context):
    obj = context.object
    return obj if obj is not None and hasattr(obj.data, "materials") else None


def _layered_material(context):
    return properties.layered_material_of(_object_with_materials(context))


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
        mat = properties.apply_to_object(context.object)
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
        if not properties.remove_from_object(context.object):
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
        mat = properties.apply_to_object(context.object, params)
        properties.settings(mat).preset = self.preset
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
        current = properties.settings(_layered_material(context)).preset
        if not self.name:
            self.name = current[len(user_presets.USER_PREFIX):] if current.startswith(user_presets.USER_PREFIX) \
                else "My preset"
        return context.window_manager.invoke_props_dialog(self)

    def run(self, context):
        mat = _layered_material(context)
        path = user_presets.save_user_preset(self.name, properties.params_of(mat))
        properties.settings(mat).preset = user_presets.USER_PREFIX + path.stem
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
    """Mark the material's node group as an asset with a rendered preview, for the Asset Browser"""

    bl_idname = "layered_brdf.mark_asset"
    bl_label = "Mark Node Group as Asset"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        mat = _layered_material(context)
        return mat is not None and assets.group_of(mat) is not None

    def run(self, context):
        mat = _layered_material(context)
        _, _, plan = properties.desired(mat)
        group = assets.publish(mat, plan, preview=True)
        return f"Node group '{group.name}' is an asset"


class LAYERED_BRDF_OT_upgrade(_Reporting, Operator):
    """Rebuild the file's layered materials whose node group or OSL shader is out of date"""

    bl_idname = "layered_brdf.upgrade"
    bl_label = "Update Layered Materials"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        done = properties.upgrade_all()
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
        return properties.param_tooltip(props.param)

    def execute(self, context):
        self.report({"INFO"}, properties.param_tooltip(self.param))
        return {"FINISHED"}
