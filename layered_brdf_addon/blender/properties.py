"""The add-on's settings on materials and the functions that keep materials in step with them.

Float parameters live in the shader node's input sockets (keyframes and drivers on
them animate final renders); the other parameters (enums), the backend and the last
preset are a :class:`LayeredBRDFSettings` property group on every material, generated
from :data:`PARAM_SPECS`.  A material's tree is built for an effect plan; when edits
change the plan, :func:`sync_material` rebuilds it.  Animated, driven or linked
sockets count as taking any value, so the plan never has to change during a render.
"""
from __future__ import annotations

import json
import re
import sys
from contextlib import contextmanager

import bpy
from bpy.app.handlers import persistent
from bpy.props import BoolProperty, EnumProperty, FloatProperty, StringProperty

from ..model.params import PARAM_SPECS, LayeredParams, ParameterError, ParamSpec, iter_sockets, option_label
from ..model.plan import EffectPlan
from ..model import policy
from ..model.policy import plan_effects
from . import assets
from . import material as M
from . import osl as osl_backend
from ..backends import node_group as node_group_builder

SETTINGS = "layered_brdf_settings"  # the PointerProperty on bpy.types.Material
BUILD_KEY = "layered_brdf_build"  # written by apply_layered_material
ENUMS_KEY = "layered_brdf_enums"
BACKEND_KEY = "layered_brdf_backend"
SYNC_KEY = "layered_brdf_synced"  # the _signature of the last synchronisation

BACKEND_ITEMS = (
    ("nodes", "Node group", "Stock shader nodes: Cycles and EEVEE, CPU and GPU"),
    ("osl", "OSL", "Open Shading Language script: Cycles on the CPU, or on the GPU with OptiX"),
)

# The effect each animatable parameter switches on or off (see model/plan.py).
_suspended = 0


@contextmanager
def suspended_updates():
    """Write settings without their update callbacks rebuilding the material."""
    global _suspended
    _suspended += 1
    try:
        yield
    finally:
        _suspended -= 1


UNIT_LABELS = {"deg": "\u00b0"}


def param_label(spec: ParamSpec) -> str:
    """The label with its unit, e.g. ``Thickness min (nm)``."""
    return f"{spec.label} ({UNIT_LABELS.get(spec.unit, spec.unit)})" if spec.unit else spec.label


def param_tooltip(name: str) -> str:
    """Description, allowed range and typical range of a parameter."""
    spec = LayeredParams.spec(name)
    text = f"{spec.description}. Allowed: {spec.allowed}"
    if spec.soft_min is not None and spec.soft_max is not None:
        unit = f" {spec.unit}" if spec.unit else ""
        text += f"; typical: {spec.soft_min:g} to {spec.soft_max:g}{unit}"
    return text


def setting_specs() -> list[ParamSpec]:
    """The parameters that are not shader inputs: properties of the settings group."""
    return [s for s in PARAM_SPECS if not s.socket]


def _updater(name: str):
    def update(self, context):
        if _suspended:
            return
        mat = self.id_data
        if mat is None or mat.library is not None or not is_layered(mat):
            return
        adopt(mat, keep=name)
        try:
            if name == "lower_medium" and self.lower_medium != "custom" and M.shader_node(mat) is not None:
                # A named medium fills the lower medium's n and k sockets.
                M.set_inputs(M.shader_node(mat), params_of(mat).replace(lower_medium=self.lower_medium))
            sync_material(mat)
        except ParameterError:
            return  # the material is left as it was; the panel shows the reason (material_problem)

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


def _settings_class():
    ann = {s.name: _spec_property(s) for s in setting_specs()}
    ann["backend"] = EnumProperty(name="Backend", description="How the material is built", items=BACKEND_ITEMS,
                                  default="nodes", update=_updater("backend"))
    ann["preset"] = StringProperty(name="Preset", description="The preset last loaded into the material")
    ann["adopted"] = BoolProperty(name="Adopted", options={"HIDDEN"},
                                  description="The settings describe the material (copied from it once)")
    return type("LayeredBRDFSettings", (bpy.types.PropertyGroup,),
                {"__annotations__": ann, "__doc__": "Layered BRDF settings of a material"})


LayeredBRDFSettings = _settings_class()


# --- reading a material ----------------------------------------------------------------
def is_layered(mat) -> bool:
    return mat is not None and bool(mat.get(M.MATERIAL_KEY))


def settings(mat):
    return getattr(mat, SETTINGS)


# Settings whose default has changed, with the default a material built before the change
# had: Blender stores a setting only once it is written, so a material that kept the old
# default would otherwise read the new one and change its look on the next rebuild.
LEGACY_DEFAULTS = {"accuracy": "rgb"}


def stored_enums(mat) -> dict:
    """The settings ``mat`` was last built with (the record apply_layered_material writes), the
    valid entries only: a record that is not a mapping, or an entry that is not one of its
    setting's options, is read as absent (the setting keeps its own value)."""
    stored = mat.get(ENUMS_KEY)
    record = stored.to_dict() if hasattr(stored, "to_dict") else stored
    if not isinstance(record, dict):
        return {}
    specs = {s.name: s for s in setting_specs()}
    valid = {}
    for name, value in record.items():
        if name in specs:
            try:
                valid[name] = specs[name].check(value)
            except (ParameterError, TypeError):
                continue
    return valid


def _legacy_values(mat) -> dict:
    """The values of :data:`LEGACY_DEFAULTS` settings that ``mat`` (built by the add-on) never
    wrote: what it was built with (its stamped enums), else the old default."""
    st = settings(mat)
    if mat.get(BUILD_KEY) is None:
        return {}
    enums = stored_enums(mat)
    return {name: enums.get(name, old) for name, old in LEGACY_DEFAULTS.items() if not st.is_property_set(name)}


def _setting_values(mat) -> dict:
    st = settings(mat)
    return {**{s.name: getattr(st, s.name) for s in setting_specs()}, **_legacy_values(mat)}


def _check_local(mat) -> None:
    if mat.library is not None:
        raise ParameterError("material", mat.name, f"a local material: it is linked from "
                             f"{mat.library.filepath}; make it local to edit it")


def params_of(mat) -> LayeredParams:
    """The material's parameters: floats from the shader's sockets, the rest from its settings."""
    node = M.shader_node(mat)
    if node is None:
        raise ParameterError("material", mat.name, "a material holding the 'Layered BRDF' shader node "
                             "(apply the layered material first)")
    return M.read_inputs(node, base=LayeredParams.from_dict(_setting_values(mat)))


def check_backend(params: LayeredParams, backend: str) -> None:
    policy.check_backend(backend, params.lobe)


def desired(mat) -> tuple[LayeredParams, str, EffectPlan]:
    """What the material should be built as: (parameters, backend, plan); ParameterError if it can't be
    (also when its shader node lacks a socket: only applying it again repairs that)."""
    _check_local(mat)
    node = M.shader_node(mat)
    if node is not None:
        M.check_node(mat, node)
    params = params_of(mat)
    backend = settings(mat).backend
    check_backend(params, backend)
    return params, backend, plan_effects(params, M.animated_parameters(mat))


def desired_or_problem(mat) -> tuple[tuple[LayeredParams, str, EffectPlan] | None, str | None]:
    """``(desired(mat), None)``, or ``(None, why the material cannot be edited or rebuilt now)``:
    one walk over the material's animation for a panel that shows both."""
    try:
        return desired(mat), None
    except ParameterError as e:
        return None, str(e)


def material_problem(mat) -> str | None:
    """Why the material cannot be edited or rebuilt now, or None."""
    return desired_or_problem(mat)[1]


def _signature(mat, params: LayeredParams, backend: str, plan: EffectPlan) -> str:
    """What the material was last synchronised to: backend, plan, settings and the build it got."""
    return json.dumps({"backend": backend, "plan": plan.to_dict(),
                       "settings": {s.name: getattr(params, s.name) for s in setting_specs()},
                       "build": mat.get(BUILD_KEY)}, sort_keys=True)


def _in_sync(mat, params: LayeredParams, backend: str, plan: EffectPlan, check_sources: bool) -> bool:
    """Whether ``mat`` is built as wanted (OSL sources compared only with ``check_sources``)."""
    if mat.get(SYNC_KEY) != _signature(mat, params, backend, plan):
        return False
    node = M.shader_node(mat)
    if node is None:
        return False
    if backend == "nodes":
        return node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and \
            node_group_builder.is_current(node.node_tree, plan)
    if node.bl_idname != "ShaderNodeScript" or node.script is None:
        return False
    return not check_sources or node.script.as_string() == osl_backend.source(plan)


# --- changing a material -----------------------------------------------------------------
def write_settings(mat, params: LayeredParams, backend: str) -> None:
    st = settings(mat)
    with suspended_updates():
        for s in setting_specs():
            # Written even when equal to the default, so that a later default cannot change it.
            if getattr(st, s.name) != getattr(params, s.name) or not st.is_property_set(s.name):
                setattr(st, s.name, getattr(params, s.name))
        if st.backend != backend:
            st.backend = backend
        st.adopted = True


def adopt(mat, keep: str | None = None) -> None:
    """Copy a material's built enums and backend into its settings, once (e.g. made by a script).

    ``keep`` names a setting the user has just changed: it is not overwritten.  A setting whose
    default has changed since the material was built is pinned to what it was built with
    (:data:`LEGACY_DEFAULTS`).
    """
    st = settings(mat)
    legacy = {k: v for k, v in _legacy_values(mat).items() if k != keep}
    if legacy:
        with suspended_updates():
            for name, value in legacy.items():
                setattr(st, name, value)
    if st.adopted:
        return
    values = stored_enums(mat)
    backend = mat.get(BACKEND_KEY)
    if backend in tuple(b for b, _, _ in BACKEND_ITEMS):
        values["backend"] = backend
    with suspended_updates():
        for s in setting_specs():
            if s.name in values and s.name != keep:
                setattr(st, s.name, s.check(values[s.name]))
        if "backend" in values and keep != "backend":
            policy.check_backend(values["backend"])
            st.backend = values["backend"]
        st.adopted = True


def _apply(target, params: LayeredParams, backend: str, plan: EffectPlan, preview: bool):
    mat = M.apply_layered_material(target, params, backend, plan=plan)
    write_settings(mat, params, backend)
    mat[SYNC_KEY] = _signature(mat, params, backend, plan)
    assets.refresh(mat, preview=preview)  # a look's preview follows it; node groups are never assets
    return mat


def sync_material(mat, check_sources: bool = False) -> bool:
    """Rebuild ``mat`` when its settings, its sockets' effects or its shader's version call for it.

    Returns True when the material was rebuilt or rewritten.  Raises ParameterError when it can't be.
    """
    adopt(mat)
    params, backend, plan = desired(mat)
    if _in_sync(mat, params, backend, plan, check_sources):
        return False
    _apply(mat, params, backend, plan, preview=False)
    return True


def layered_material_of(obj):
    mat = obj.active_material if obj is not None else None
    return mat if is_layered(mat) else None


def apply_to_object(obj, params: LayeredParams | None = None, backend: str | None = None, preview: bool = True):
    """Give ``obj`` the layered material (reusing its own), with ``params`` or the current values.

    A material that is a look (an asset) gets a fresh preview; with ``preview`` now, else when idle.
    """
    mat = layered_material_of(obj)
    if mat is not None:
        _check_local(mat)
        adopt(mat)
    if params is None:
        params = params_of(mat) if mat is not None and M.shader_node(mat) is not None else LayeredParams()
    params = params.validate()
    if backend is None:
        backend = settings(mat).backend if mat is not None else "nodes"
    policy.check_backend(backend)
    check_backend(params, backend)
    animated = M.animated_parameters(mat) if mat is not None else set()
    return _apply(obj, params, backend, plan_effects(params, animated), preview)


def remove_from_object(obj) -> bool:
    mat = layered_material_of(obj)
    if mat is None:
        return False
    return M.remove_layered_material(obj)


def _editable(mat) -> bool:
    return is_layered(mat) and mat.library is None and M.shader_node(mat) is not None


def _editable_layered_materials():
    return [m for m in bpy.data.materials if _editable(m)]


def sync_on_its_own(mat, check_sources: bool = False) -> bool:
    """:func:`sync_material` for a handler or a pass over many materials: a material that can't be
    built (ParameterError) is left as it is, and the panel says why; one whose rebuild fails is
    left too, with one line on stderr.  Either way the next material is still done."""
    try:
        return sync_material(mat, check_sources=check_sources)
    except ParameterError:
        return False
    except Exception as e:  # a broken material must not stop the others, nor a handler
        print(f"Layered BRDF: material '{mat.name}' left as it is: {e.__class__.__name__}: {e}", file=sys.stderr)
        return False


def upgrade_all() -> list[str]:
    """Rebuild the local layered materials whose node group or OSL text is out of date, each on
    its own (one that can't be leaves the others to be done); the names of those rebuilt."""
    return [mat.name for mat in _editable_layered_materials() if sync_on_its_own(mat, check_sources=True)]


# --- handlers ----------------------------------------------------------------------------
@persistent
def on_depsgraph_update(scene, depsgraph):
    if depsgraph.mode != "VIEWPORT" or bpy.app.is_job_running("RENDER"):
        return
    updated = [u.id.original for u in depsgraph.updates if isinstance(u.id, bpy.types.Material)]
    for mat in updated:
        if _editable(mat):
            sync_on_its_own(mat)


@persistent
def on_load_post(*_args):
    upgrade_all()
