"""The add-on's settings on materials: the :class:`LayeredBRDFSettings` property group, generated
from :data:`PARAM_SPECS`, and the labels and tooltips of the parameters.

Float parameters live in the shader node's input sockets (keyframes and drivers on them
animate final renders); the other parameters (enums), the backend and the last preset are
this property group on every material.  Changing a setting rebuilds the material when its
effects call for it (:func:`.sync.sync_material`).
"""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, StringProperty

from ..model.dispersion import ior_and_dispersion
from ..model.params import (LayeredParams, ParameterError, ParamSpec, group_socket_name, option_label,
                            socket_tooltip)
from .material_values import is_layered, params_of
from . import stack_settings
from .own_nodes import shader_node
from .sockets import input_value, set_inputs
from .stored_keys import setting_specs
from .sync import adopt, sync_material, updates_suspended

BACKEND_ITEMS = (
    ("nodes", "Node group", "Stock shader nodes: Cycles and EEVEE, CPU and GPU"),
    ("osl", "OSL", "Open Shading Language script: Cycles on the CPU, or on the GPU with OptiX"),
)

UNIT_LABELS = {"deg": "\u00b0"}


def param_label(spec: ParamSpec) -> str:
    """The label with its unit, e.g. ``Thickness min (nm)``; a socket that holds something else than
    the parameter (a Roughness for an exponent) is labelled as the node labels it."""
    if spec.socket_units:
        return group_socket_name(spec).capitalize()
    return f"{spec.label} ({UNIT_LABELS.get(spec.unit, spec.unit)})" if spec.unit else spec.label


def param_tooltip(name: str) -> str:
    """Description, allowed range and typical range of a parameter (of its socket, where the socket
    holds something else: a Roughness)."""
    spec = LayeredParams.spec(name)
    if spec.socket_units:
        return socket_tooltip(spec)
    text = f"{spec.description}. Allowed: {spec.allowed}"
    if spec.soft_min is not None and spec.soft_max is not None:
        unit = f" {spec.unit}" if spec.unit else ""
        text += f"; typical: {spec.soft_min:g} to {spec.soft_max:g}{unit}"
    return text


def _updater(name: str):
    def update(self, context):
        if updates_suspended():
            return
        mat = self.id_data
        if mat is None or mat.library is not None or not is_layered(mat):
            return
        adopt(mat, keep=name)
        try:
            if name == "layer_index" and self.layer_index == "ior" and shader_node(mat) is not None:
                # The IOR and Dispersion start where the three indices were (their nearest Cauchy law).
                node = shader_node(mat)
                ior, dispersion = ior_and_dispersion([input_value(node, c) for c in ("r1_r", "r1_g", "r1_b")])
                set_inputs(node, params_of(mat).replace(layer_ior=min(max(ior, 1.0), 5.0),
                                                        layer_dispersion=min(max(dispersion, 0.0), 10.0)))
            if name == "lower_medium" and self.lower_medium != "custom" and shader_node(mat) is not None:
                # A named medium fills the lower medium's n and k sockets.
                set_inputs(shader_node(mat), params_of(mat).replace(lower_medium=self.lower_medium))
            sync_material(mat)
        except ParameterError:
            return  # the material is left as it was; the panel shows the reason (sync.material_problem)

    return update


def _spec_property(spec: ParamSpec):
    if spec.kind == "enum":
        items = [(o, option_label(o), f"{spec.label}: {option_label(o)} ('{o}')") for o in spec.options]
        return EnumProperty(name=spec.label, description=spec.description, items=items, default=spec.default,
                            update=_updater(spec.name))
    if spec.kind == "bool":
        return BoolProperty(name=spec.label, description=spec.description, default=spec.default,
                            update=_updater(spec.name))
    kw = dict(name=spec.label, description=spec.description, default=spec.default, update=_updater(spec.name))
    if spec.min > -3.0e38:
        kw["min"] = spec.min
    if spec.max < 3.0e38:
        kw["max"] = spec.max
    if spec.soft_min is not None:
        kw["soft_min"] = spec.soft_min
    if spec.soft_max is not None:
        kw["soft_max"] = spec.soft_max
    return FloatProperty(**kw)


LayeredBRDFStackFilm = stack_settings.film_item_class(_updater("stack"))


def _settings_class():
    ann = {s.name: _spec_property(s) for s in setting_specs() if s.kind != "stack"}
    ann.update(stack_settings.stack_annotations(_updater("stack"), LayeredBRDFStackFilm))
    ann["backend"] = EnumProperty(name="Backend", description="How the material is built", items=BACKEND_ITEMS,
                                  default="nodes", update=_updater("backend"))
    ann["preset"] = StringProperty(name="Preset", description="The preset last loaded into the material")
    ann["adopted"] = BoolProperty(name="Adopted", options={"HIDDEN"},
                                  description="The settings describe the material (copied from it once)")
    return type("LayeredBRDFSettings", (bpy.types.PropertyGroup,),
                {"__annotations__": ann, "__doc__": "Layered BRDF settings of a material",
                 "stack": stack_settings.stack_property()})


LayeredBRDFSettings = _settings_class()
