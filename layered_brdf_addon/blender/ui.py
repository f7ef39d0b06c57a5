"""The Layered BRDF panel in Properties > Material, its parameter sub-panels and preset menus.

Float parameters are drawn straight from the shader node's input sockets, so a keyframe
or driver added from the panel animates the socket the renderer reads.
"""
from __future__ import annotations

from bpy.types import Menu, Panel

from ..model.params import PARAM_SPECS
from ..model.policy import tables_fallback
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS, STACK_PRESETS, preset_label
from . import assets, osl, user_presets
from .animation import animated_parameters
from .material_values import is_layered, layered_material_of, settings
from .own_nodes import shader_node
from .properties import param_label
from .slots import displaced_material
from .sockets import param_socket
from .stack_ui import draw_stack
from .sync import desired_or_problem
from .targets import object_problem, takes_layered_material

MAIN_PANEL = "LAYERED_BRDF_PT_material"


def preset_title(identifier: str) -> str:
    if identifier.startswith(user_presets.USER_PREFIX):
        return identifier[len(user_presets.USER_PREFIX):]
    return preset_label(identifier)


def draw_param(layout, mat, node, spec) -> None:
    """One parameter: its socket (floats) or its setting (enums), labelled with the unit, and a tooltip."""
    row = layout.row(align=True)
    text = param_label(spec)
    if spec.used_with:  # greyed out where the material's mode does not use it
        row.active = getattr(settings(mat), spec.used_with[0]) == spec.used_with[1]
    if spec.socket:
        sock, channel = param_socket(node, spec.name)
        if sock is None:  # a socket deleted from the node group, or a node older than the parameter
            row.label(text=f"{text}: not on the node (Rebuild adds it)", icon="ERROR")
            return
        if channel is not None:  # a channel of a colour socket: the colour is drawn once, as a colour
            if channel != 0:
                return
            text = sock.name
        if sock.is_linked:
            row.label(text=f"{text}: from a link", icon="LINKED")
        else:
            row.prop(sock, "default_value", text=text)
    else:
        row.prop(settings(mat), spec.name, text=text)
    row.operator("layered_brdf.param_info", text="", icon="QUESTION", emboss=False).param = spec.name


def _alert(layout, text, icon="ERROR"):
    col = layout.column(align=True)
    col.alert = True
    col.label(text=text, icon=icon)
    return col


def draw_material(layout, context) -> None:
    obj = context.object
    mat = obj.active_material
    if obj.library is not None:
        _alert(layout, object_problem(obj), icon="LIBRARY_DATA_DIRECT")
        return
    if mat is not None and mat.library is not None:
        _alert(layout, f"'{mat.name}' is linked from {mat.library.filepath}: make it local to edit it",
               icon="LIBRARY_DATA_DIRECT")
        if is_layered(mat):
            return
    if not is_layered(mat):
        problem = object_problem(obj)  # a slot of linked data: applying would not be saved
        if problem:
            _alert(layout, problem, icon="LIBRARY_DATA_DIRECT")
        layout.operator("layered_brdf.apply", icon="SHADING_RENDERED")
        layout.menu(LAYERED_BRDF_MT_presets.__name__, text="Apply a Preset", icon="PRESET")
        draw_asset_row(layout, None)
        draw_fit_row(layout)
        return
    st = settings(mat)
    row = layout.row(align=True)
    row.menu(LAYERED_BRDF_MT_presets.__name__, text=preset_title(st.preset) if st.preset else "Presets",
             icon="PRESET")
    row.operator("layered_brdf.save_preset", text="", icon="ADD")
    row.menu(LAYERED_BRDF_MT_delete_presets.__name__, text="", icon="REMOVE")
    layout.prop(st, "backend", expand=True)
    if st.backend == "osl":
        ok, reason = osl.scene_supports_osl(context.scene)
        if not ok:
            col = _alert(layout, f"OSL will not run: {reason}")
            col.operator("layered_brdf.enable_osl", icon="SETTINGS")
    wanted, problem = desired_or_problem(mat)
    if problem:
        _alert(layout, problem)
    row = layout.row(align=True)
    row.operator("layered_brdf.apply", text="Rebuild", icon="FILE_REFRESH")
    row.operator("layered_brdf.remove", text="", icon="X")
    draw_asset_row(layout, mat)
    draw_fit_row(layout)
    displaced = displaced_material(mat)
    if displaced is not None:
        layout.label(text=f"Remove puts '{displaced.name}' back in the slot", icon="INFO")
    if shader_node(mat) is None:
        layout.label(text="The material has no Layered BRDF node: Rebuild restores it", icon="INFO")
    elif wanted is not None:
        params, backend, plan = wanted
        col = layout.column(align=True)
        col.label(text=f"Effects ({plan.key}):")
        for line in plan.describe():
            col.label(text=line, icon="DOT")
        if params.evaluation == "tables" and not plan.tables:
            why = tables_fallback(params, animated_parameters(mat), backend)
            if why:  # the tables would not hold the program here: it computes per point
                col.label(text=why[0].upper() + why[1:], icon="INFO")


def draw_asset_row(layout, mat) -> None:
    """The Asset Browser: mark the layered material as an asset (a look), build the looks library."""
    row = layout.row(align=True)
    if mat is not None:
        text = "Update Asset" if assets.is_look(mat) else "Mark Material as Asset"
        row.operator("layered_brdf.mark_asset", text=text, icon="ASSET_MANAGER")
    row.operator("layered_brdf.build_asset_library", text="Build Looks Library..." if mat is None else "",
                 icon="ASSET_MANAGER" if mat is None else "FILE_FOLDER")


def draw_fit_row(layout) -> None:
    """Fit the layered material to a render or a Principled material (greyed out, saying why,
    where Blender's Python lacks SciPy or colour-science)."""
    layout.operator("layered_brdf.fit_to_render", icon="EYEDROPPER")


class LAYERED_BRDF_PT_material(Panel):
    """Layered BRDF: iridescent layered material of the active object"""

    bl_label = "Layered BRDF"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return takes_layered_material(context.object)

    def draw(self, context):
        draw_material(self.layout, context)


class _ParamsPanel(Panel):
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"
    bl_parent_id = MAIN_PANEL
    group = ""

    @classmethod
    def poll(cls, context):
        obj = context.object
        mat = layered_material_of(obj) if takes_layered_material(obj) else None
        return mat is not None and mat.library is None and shader_node(mat) is not None

    def draw(self, context):
        mat = context.object.active_material
        node = shader_node(mat)
        self.layout.use_property_split = False
        for spec in PARAM_SPECS:
            if spec.group == self.group:
                if spec.kind == "stack":
                    draw_stack(self.layout, mat)
                else:
                    draw_param(self.layout, mat, node, spec)


def _params_panels():
    groups = list(dict.fromkeys(s.group for s in PARAM_SPECS))
    panels = []
    for k, group in enumerate(groups):
        ident = "".join(c if c.isalnum() else "_" for c in group.lower())
        panels.append(type(f"LAYERED_BRDF_PT_params_{ident}", (_ParamsPanel,), {
            "bl_label": group, "group": group, "bl_order": k,
            "bl_options": set() if k == 0 else {"DEFAULT_CLOSED"},
            "__doc__": f"Layered BRDF parameters: {group}",
        }))
    return tuple(panels)


PARAM_PANELS = _params_panels()


class LAYERED_BRDF_MT_presets(Menu):
    """Paper figures, artist presets and your saved presets"""

    bl_label = "Layered BRDF Presets"

    def draw(self, context):
        layout = self.layout
        sections = (("Paper figures", list(PAPER_PRESETS)), ("Artist presets", list(ARTIST_PRESETS)),
                    ("Structural colours", list(STACK_PRESETS)),
                    ("User presets", [user_presets.USER_PREFIX + n for n in user_presets.user_preset_names()]))
        for k, (title, identifiers) in enumerate(sections):
            if k:
                layout.separator()
            layout.label(text=title)
            for ident in identifiers:
                layout.operator("layered_brdf.load_preset", text=preset_title(ident)).preset = ident
            if not identifiers:
                layout.label(text="None saved yet (+ saves one)", icon="INFO")


class LAYERED_BRDF_MT_delete_presets(Menu):
    """Delete one of your saved presets"""

    bl_label = "Delete User Preset"

    def draw(self, context):
        layout = self.layout
        names = user_presets.user_preset_names()
        for name in names:
            layout.operator("layered_brdf.delete_preset", text=name, icon="X").preset = name
        if not names:
            layout.label(text="No user presets", icon="INFO")
