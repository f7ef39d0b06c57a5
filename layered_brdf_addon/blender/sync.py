"""Keeping materials in step with what they should be: the one place that decides what a layered
material should be built as (:func:`desired`) and builds it (:func:`apply`).

The panel's settings (their update callbacks), the operators, the looks and the looks library
call these; so do the handlers, after an edit (depsgraph updates) and when a file is opened.
A material's tree is built for an effect plan; when edits change the plan, :func:`sync_material`
rebuilds it (:mod:`.freshness` holds the handlers that call it after an edit, on a frame change and
before a render).  Animated, driven or linked sockets count as taking any value, so the plan never
has to change during a render.
"""
from __future__ import annotations

import json
import sys
from contextlib import contextmanager

import bpy
from bpy.app.handlers import persistent

from ..model import policy
from ..model.params import LayeredParams, ParameterError
from ..model.plan import EffectPlan
from ..model.policy import render_plan
from . import assets, bake_jobs
from .animation import animated_parameters
from .build import apply_layered_material, tree_current
from .material_values import check_local, is_layered, layered_material_of, legacy_values, params_of, settings
from .own_nodes import shader_node
from .slots import remove_layered_material
from .sockets import check_node
from .stored_keys import (BACKEND_KEY, BUILD_KEY, CHOSEN_PLAN_KEY, SETTINGS, SYNC_KEY, recorded_settings,
                          setting_specs, settings_record)

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


def updates_suspended() -> bool:
    """Whether settings are being written by :func:`suspended_updates` (their callbacks do nothing)."""
    return _suspended > 0


# --- what a material should be -------------------------------------------------------------------
def desired(mat) -> tuple[LayeredParams, str, EffectPlan]:
    """What the material should be built as: (parameters, backend, plan); ParameterError if it can't be
    (also when its shader node lacks a socket: only applying it again repairs that)."""
    check_local(mat)
    node = shader_node(mat)
    if node is not None:
        check_node(mat, node)
    params = params_of(mat)
    backend = settings(mat).backend
    policy.check_backend(backend, params.lobe)
    return params, backend, render_plan(params, animated_parameters(mat), backend)


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


def signature(mat, params: LayeredParams, backend: str, plan: EffectPlan) -> str:
    """What the material was last synchronised to: backend, plan, settings and the build it got."""
    return json.dumps({"backend": backend, "plan": plan.to_dict(),
                       "settings": settings_record(params),
                       "build": mat.get(BUILD_KEY)}, sort_keys=True)


def in_sync(mat, params: LayeredParams, backend: str, plan: EffectPlan, check_sources: bool) -> bool:
    """Whether ``mat`` was last synchronised to this and its tree is still what a build makes
    (:func:`~.build.tree_current`; OSL sources compared only with ``check_sources``)."""
    return mat.get(SYNC_KEY) == signature(mat, params, backend, plan) and \
        tree_current(mat, shader_node(mat), backend, plan, params, check_sources=check_sources)


# --- changing a material -------------------------------------------------------------------------
def write_settings(mat, params: LayeredParams, backend: str) -> None:
    st = settings(mat)
    with suspended_updates():
        for s in setting_specs():
            # Written even when equal to the default, so that a later default cannot change it.
            if s.kind == "stack" or getattr(st, s.name) != getattr(params, s.name) or \
                    not st.is_property_set(s.name):
                setattr(st, s.name, getattr(params, s.name))
        if st.backend != backend:
            st.backend = backend
        st.adopted = True


def adopt(mat, keep: str | None = None) -> None:
    """Copy a material's built settings and backend into its settings, once (e.g. made by a script).

    ``keep`` names a setting the user has just changed: it is not overwritten.  A setting whose
    default has changed since the material was built is pinned to what it was built with
    (:data:`~.material_values.LEGACY_DEFAULTS`).
    """
    st = settings(mat)
    legacy = {k: v for k, v in legacy_values(mat).items() if k != keep}
    if legacy:
        with suspended_updates():
            for name, value in legacy.items():
                setattr(st, name, value)
    if st.adopted:
        return
    values = recorded_settings(mat)
    backend = mat.get(BACKEND_KEY)
    if backend in policy.BACKENDS:
        values["backend"] = backend
    with suspended_updates():
        for s in setting_specs():
            if s.name in values and s.name != keep:
                setattr(st, s.name, s.check(values[s.name]))
        if "backend" in values and keep != "backend":
            policy.check_backend(values["backend"])
            st.backend = values["backend"]
        st.adopted = True


def follow_build(mat) -> None:
    """The material's settings (the panel's, where the add-on is registered) set to what its last build
    recorded, so that a script's :func:`~.build.apply_layered_material` with another backend or other
    options is what the handlers keep, not what the panel said before."""
    st = getattr(mat, SETTINGS, None)
    if st is None:
        return
    values = recorded_settings(mat)
    backend = mat.get(BACKEND_KEY)
    with suspended_updates():
        for name, value in values.items():
            # The stack is no property of its own (the stack editor's are): Blender does not record it as set.
            if getattr(st, name) != value or (name in st.bl_rna.properties and not st.is_property_set(name)):
                setattr(st, name, value)
        if backend in policy.BACKENDS and st.backend != backend:
            st.backend = backend
        st.adopted = True


def apply(target, params: LayeredParams, backend: str, plan: EffectPlan, preview: bool):
    """Build ``target`` (an object or a material) as ``params``, ``backend`` and ``plan`` say,
    record it in the material's settings, and refresh a look's preview (now with ``preview``,
    else when idle); returns the material."""
    mat = apply_layered_material(target, params, backend, plan=plan)
    mat.pop(CHOSEN_PLAN_KEY, None)  # the plan its values call for, not a caller's choice
    write_settings(mat, params, backend)
    mat[SYNC_KEY] = signature(mat, params, backend, plan)
    assets.refresh(mat, preview=preview)  # a look's preview follows it; node groups are never assets
    return mat


def sync_material(mat, check_sources: bool = False) -> bool:
    """Rebuild ``mat`` when its settings, its sockets' effects or its shader's version call for it.

    Returns True when the material was rebuilt or rewritten.  Raises ParameterError when it can't be.
    """
    adopt(mat)
    params, backend, plan = desired(mat)
    if in_sync(mat, params, backend, plan, check_sources):
        return False
    if bake_jobs.baking(params, plan) and mat.get(SYNC_KEY) == signature(mat, params, backend, plan) and \
            tree_current(mat, shader_node(mat), backend, plan, params, tables=False):
        return False  # built for these values; its tables are baking beside the interface (.bake_jobs)
    apply(mat, params, backend, plan, preview=False)
    return True


def apply_to_object(obj, params: LayeredParams | None = None, backend: str | None = None, preview: bool = True):
    """Give ``obj`` the layered material (reusing its own), with ``params`` or the current values.

    A material that is a look (an asset) gets a fresh preview; with ``preview`` now, else when idle.
    """
    mat = layered_material_of(obj)
    if mat is not None:
        check_local(mat)
        adopt(mat)
    if params is None:
        params = params_of(mat) if mat is not None and shader_node(mat) is not None else LayeredParams()
    params = params.validate()
    if backend is None:
        backend = settings(mat).backend if mat is not None else "nodes"
    policy.check_backend(backend, params.lobe)
    animated = animated_parameters(mat) if mat is not None else set()
    return apply(obj, params, backend, render_plan(params, animated, backend), preview)


def remove_from_object(obj) -> bool:
    mat = layered_material_of(obj)
    if mat is None:
        return False
    return remove_layered_material(obj)


# --- every material of the file ------------------------------------------------------------------
def editable(mat) -> bool:
    """A local material the add-on made, or built its shader into (an artist's material given to
    :func:`~.build.apply_layered_material`), that still holds the shader node."""
    return mat.library is None and (is_layered(mat) or mat.get(BUILD_KEY) is not None) and \
        shader_node(mat) is not None


def editable_layered_materials():
    return [m for m in bpy.data.materials if editable(m)]


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
    """Rebuild the local layered materials whose node group, baked tables (read back) or OSL text is out
    of date, each on
    its own (one that can't be leaves the others to be done); the names of those rebuilt."""
    return [mat.name for mat in editable_layered_materials() if sync_on_its_own(mat, check_sources=True)]


# --- handlers ------------------------------------------------------------------------------------
@persistent
def on_load_post(*_args):
    upgrade_all()


@persistent
def on_undo_redo(*_args):
    """After an undo or redo: the materials' values are the restored ones, but a baked table's texels
    are whatever was baked last; every table is read back and rebaked where it differs."""
    upgrade_all()
