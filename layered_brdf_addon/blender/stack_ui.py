"""The panel's stack editor: the list of films, their add, remove and move buttons, and the stack's
summary (films, total thickness, and whether the layer's thickness range holds it)."""
from __future__ import annotations

from bpy.props import EnumProperty
from bpy.types import Operator, UIList

from ..model.errors import ParameterError
from ..model.stack import MAX_FILMS
from .material_values import layered_material_of, params_of, settings
from .own_nodes import shader_node
from .sockets import input_value, set_inputs
from .stack_settings import INDEX_ITEM, stack_from_settings
from . import bake_jobs
from .sync import desired, material_problem, sync_material, updates_suspended

THICKNESS_SPREAD = 0.05  # "Thickness from Stack": the layer's range, the stack's total +- 5%


class LAYERED_BRDF_UL_stack_films(UIList):
    """The films of a stack, from the top"""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        row = layout.row(align=True)
        row.label(text=f"{index + 1}")
        row.prop(item, "medium", text="")
        if item.medium == INDEX_ITEM:
            row.prop(item, "ior", text="")
            row.prop(item, "k", text="k")
        row.prop(item, "thickness_nm", text="nm")


def _material(context):
    return layered_material_of(context.object)


def _changed(mat) -> None:
    if not updates_suspended():
        try:
            sync_material(mat)
        except ParameterError:
            pass  # the panel shows why (sync.material_problem); nothing else was changed


class _StackOperator(Operator):
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        mat = _material(context)
        return mat is not None and mat.library is None


class LAYERED_BRDF_OT_stack_film(_StackOperator):
    """Add a film under the active one, remove the active film, or move it up or down"""

    bl_idname = "layered_brdf.stack_film"
    bl_label = "Edit Stack Films"
    action: EnumProperty(items=(("ADD", "Add", "Add a film under the active one"),
                                ("REMOVE", "Remove", "Remove the active film"),
                                ("UP", "Up", "Move the active film up"),
                                ("DOWN", "Down", "Move the active film down")))

    def execute(self, context):
        mat = _material(context)
        st = settings(mat)
        films, i = st.stack_films, st.stack_index
        if self.action == "ADD":
            if len(films) >= MAX_FILMS:
                self.report({"ERROR"}, f"A stack has at most {MAX_FILMS} films")
                return {"CANCELLED"}
            item = films.add()
            if 0 <= i < len(films) - 1:
                source = films[i]
                item.medium, item.thickness_nm = source.medium, source.thickness_nm
                item.ior, item.dispersion, item.k = source.ior, source.dispersion, source.k
                films.move(len(films) - 1, i + 1)
                st.stack_index = i + 1
            else:
                st.stack_index = len(films) - 1
        elif not 0 <= i < len(films):
            return {"CANCELLED"}
        elif self.action == "REMOVE":
            films.remove(i)
            st.stack_index = max(min(i, len(films) - 1), 0)
        else:
            j = i - 1 if self.action == "UP" else i + 1
            if not 0 <= j < len(films):
                return {"CANCELLED"}
            films.move(i, j)
            st.stack_index = j
        _changed(mat)
        return {"FINISHED"}


class LAYERED_BRDF_OT_stack_thickness(_StackOperator):
    """Set Thickness Min and Max to the stack's total thickness, 5% either side: the pattern then scales
    every film between 0.95 and 1.05 of its own thickness"""

    bl_idname = "layered_brdf.stack_thickness"
    bl_label = "Thickness from Stack"

    def execute(self, context):
        mat = _material(context)
        node = shader_node(mat)
        try:
            stack = stack_from_settings(settings(mat))
        except ParameterError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        if stack is None or node is None:
            return {"CANCELLED"}
        total = stack.total_nm
        values = {k: input_value(node, k) for k in ("d_min", "d_max")}
        wanted = {"d_min": total * (1.0 - THICKNESS_SPREAD), "d_max": total * (1.0 + THICKNESS_SPREAD)}
        if values != wanted:
            set_inputs(node, params_of(mat).replace(**wanted))
        _changed(mat)
        return {"FINISHED"}


def draw_stack(layout, mat) -> None:
    """The stack editor of the Stack sub-panel."""
    st = settings(mat)
    row = layout.row(align=True)
    row.prop(st, "use_stack")
    row.operator("layered_brdf.param_info", text="", icon="QUESTION", emboss=False).param = "stack"
    col = layout.column()
    col.active = st.use_stack
    row = col.row(align=True)
    row.prop(st, "stack_kind", expand=True)
    if st.stack_kind == "periodic":
        col.prop(st, "stack_periods")
    col.prop(st, "stack_disorder")
    col.prop(st, "stack_domains")
    row = col.row()
    row.template_list(LAYERED_BRDF_UL_stack_films.__name__, "", st, "stack_films", st, "stack_index", rows=4)
    buttons = row.column(align=True)
    for action, icon in (("ADD", "ADD"), ("REMOVE", "REMOVE"), ("UP", "TRIA_UP"), ("DOWN", "TRIA_DOWN")):
        buttons.operator(LAYERED_BRDF_OT_stack_film.bl_idname, text="", icon=icon).action = action
    if 0 <= st.stack_index < len(st.stack_films) and st.stack_films[st.stack_index].medium == INDEX_ITEM:
        film = st.stack_films[st.stack_index]
        sub = col.row(align=True)
        sub.prop(film, "dispersion")
    if not st.use_stack:
        return
    try:
        stack = stack_from_settings(st)
    except ParameterError as e:
        col.alert = True
        col.label(text=str(e), icon="ERROR")
        return
    col.label(text=stack.describe(), icon="INFO")
    node = shader_node(mat)
    if node is not None:
        low, high = input_value(node, "d_min"), input_value(node, "d_max")
        col.label(text=f"Thickness Min / Max scale the stack by {low / stack.total_nm:.2f} - "
                       f"{high / stack.total_nm:.2f}", icon="DOT")
    col.operator(LAYERED_BRDF_OT_stack_thickness.bl_idname, icon="MOD_THICKNESS")
    if material_problem(mat) is not None:
        return
    params, _, plan = desired(mat)
    if params.normal_mode == "tilted":
        col.label(text=f"Lamellae along the lower normal (Tilt {params.tilt:g}\u00b0) in a crystal of IOR "
                       f"{params.r1[1]:.3f}: its gloss, their schiller", icon="DOT")
    if bake_jobs.baking_any():
        if bake_jobs.baking(params, plan):
            col.label(text="Baking the stack's tables: the look follows when they are done", icon="TIME")


CLASSES = (LAYERED_BRDF_UL_stack_films, LAYERED_BRDF_OT_stack_film, LAYERED_BRDF_OT_stack_thickness)