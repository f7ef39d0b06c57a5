"""The render shows the material, whoever edited it: handlers that rebuild or rebake a layered material
whose sockets, links or animation no longer match what its tables were baked for, before it renders.

A material's baked tables hold the values its shader node had when they were baked; an edit the add-on
does not hear of (a script that sets a socket, inserts keyframes, adds a driver or links a node, with or
without ``register()``; a Shift+D copy of the node given other values) would otherwise render the old
look.  Three handlers close every path (:func:`install`):

* after an edit (``depsgraph_update_post``): the materials it touched (a material or its node tree),
  and the copies of the shader node in them;
* on a frame change (``frame_change_post``): the materials with keyframes or drivers, whose moving
  parameters a script can change without any update (the others cost two pointer tests each);
* before a render (``render_init``, a still or a whole animation): every local material the add-on built
  and every copy of a shader node in the file, once the stacks' tables baking beside the interface are
  done (:mod:`.bake_jobs`).

``register()`` installs them; :func:`~.material.apply_layered_material` installs them too, so a script that
only imports the add-on is covered.  They change data only on Blender's main thread (a render started
from the interface runs its handlers on its own thread, while the edit handler has already run).

A material built for a plan its caller chose (``apply_layered_material(..., plan=...)``) keeps that
plan: only its tables are rebaked for its current values, unless an animated value is one the tables
hold, where it gets the plan its values call for (per point).
"""
from __future__ import annotations

import json
import sys
import threading

import bpy
from bpy.app.handlers import persistent

from ..backends import node_group as node_group_builder
from ..model.params import LayeredParams, ParameterError
from ..model.plan import EffectPlan
from ..model.policy import render_plan
from ..model.shading.tables import unread_by_tables
from . import bake_jobs
from . import osl as osl_backend
from . import sync
from .animation import animated_parameters
from .build import group_for
from .material_values import params_of
from .own_nodes import shader_node
from .sockets import read_inputs, set_inputs
from .stored_keys import CHOSEN_PLAN_KEY
from .tables import DIGEST_KEY, baked_settings, ensure_tables


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _animated(mat) -> bool:
    """Whether ``mat`` or its node tree has keyframes, NLA strips or drivers (two pointer tests)."""
    return mat.animation_data is not None or (mat.node_tree is not None and mat.node_tree.animation_data is not None)


def chosen_plan(mat) -> EffectPlan | None:
    """The plan ``mat`` was built for by its caller's choice, or None (the plan its values call for)."""
    record = mat.get(CHOSEN_PLAN_KEY)
    if not isinstance(record, str):
        return None
    try:
        return EffectPlan(**json.loads(record))
    except (TypeError, ValueError):
        return None


def _keep_chosen(mat, plan: EffectPlan) -> bool | None:
    """Tables of a material built for a chosen plan, rebaked for its current values: whether anything was; None
    where that plan cannot show them (an animated value that the tables hold), so that it is planned afresh."""
    params = params_of(mat)
    if plan.tables and animated_parameters(mat) - unread_by_tables(params.normal_mode):
        return None
    node = shader_node(mat)
    if not plan.tables or node is None:
        return False
    if node.bl_idname == "ShaderNodeGroup":
        return ensure_tables(node, params, plan, check_pixels=False)
    return osl_backend.ensure_text(node, params, plan)


def freshen(mat) -> bool:
    """Build ``mat`` for what its sockets, links and animation say now (:func:`.sync.sync_material`, or, for
    a chosen plan, its tables); one that can't be is left as it is (the panel says why).  True when
    something was rebuilt or rebaked."""
    plan = chosen_plan(mat)
    if plan is not None:
        try:
            kept = _keep_chosen(mat, plan)
        except ParameterError:
            return False
        if kept is not None:
            return kept
        del mat[CHOSEN_PLAN_KEY]
    return sync.sync_on_its_own(mat)


# --- copies of the shader node -------------------------------------------------------------------
def _baked_source(node):
    """The node group or OSL text holding baked tables that ``node`` runs, or None."""
    if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and DIGEST_KEY in node.node_tree:
        return node.node_tree
    if node.bl_idname == "ShaderNodeScript" and node.script is not None and osl_backend.TABLES_KEY in node.script:
        return node.script
    return None


def _owners() -> dict:
    """{group or text: a layered material whose shader node runs it} for those holding baked tables."""
    owners = {}
    for mat in sync.editable_layered_materials():
        source = _baked_source(shader_node(mat))
        if source is not None:
            owners.setdefault(source.as_pointer(), mat)
    return owners


def _copy_base(source, owners) -> LayeredParams | None:
    """The settings a copy of a shader node running ``source`` takes: those its tables were baked with (or,
    for tables of older versions, the material whose shader runs them)."""
    record = baked_settings(source)
    if record is not None:
        return LayeredParams.from_dict(record)
    owner = owners.get(source.as_pointer())
    return None if owner is None else sync.desired(owner)[0]


def _freshen_copy(mat, node, base: LayeredParams) -> bool:
    """A copy ``node`` in ``mat`` of a shader node, built for its own values: the group or text its plan calls
    for (per point where its values cannot be tabulated), tables baked for them."""
    params = read_inputs(node, base=base)
    backend = "osl" if node.bl_idname == "ShaderNodeScript" else "nodes"
    plan = render_plan(params, animated_parameters(mat, node), backend)
    if backend == "osl":
        changed = osl_backend.ensure_text(node, params, plan, check_sources=False)
        if changed:
            set_inputs(node, params)
        return changed
    changed = False
    if not node_group_builder.is_current(node.node_tree, plan):
        node.node_tree = group_for(plan, params)
        set_inputs(node, params)
        changed = True
    if plan.tables:
        changed |= ensure_tables(node, params, plan)
    return changed


def freshen_copies(materials=None) -> int:
    """Give every copy of a layered material's shader node (Shift+D, or its group added by hand, in any local
    material of ``materials``, default all) that reads baked tables a group or OSL text, and tables, of its
    own values, with the settings its tables were baked with; a copy whose values are its original's keeps
    the shared tables.  Returns how many copies changed."""
    owners = _owners()
    changed = 0
    for mat in bpy.data.materials if materials is None else materials:
        if mat.library is not None or mat.node_tree is None:
            continue
        own = shader_node(mat) if sync.editable(mat) else None
        for node in list(mat.node_tree.nodes):
            source = _baked_source(node) if node != own else None
            if source is None:
                continue
            try:
                base = _copy_base(source, owners)
                if base is not None:
                    changed += _freshen_copy(mat, node, base)
            except ParameterError:
                continue
            except Exception as e:  # one broken copy must not stop the others, nor a handler
                print(f"Layered BRDF: a copy of the shader in '{mat.name}' left as it is: "
                      f"{e.__class__.__name__}: {e}", file=sys.stderr)
    return changed


def freshen_all() -> list[str]:
    """Every local layered material and every copy of a shader node, as a render needs them; the names of
    the materials rebuilt or rebaked."""
    done = [mat.name for mat in sync.editable_layered_materials() if freshen(mat)]
    freshen_copies()
    return done


bake_jobs.when_done(freshen_all)  # a stack's tables baked beside the interface are taken by every material


# --- handlers ------------------------------------------------------------------------------------
def _edited_materials(depsgraph) -> set:
    """The materials an update touched: updated materials and the materials whose node tree was."""
    mats, trees = set(), set()
    for update in depsgraph.updates:
        original = update.id.original
        if isinstance(original, bpy.types.Material):
            mats.add(original)
        elif isinstance(original, bpy.types.ShaderNodeTree):
            trees.add(original.as_pointer())
    if trees:
        mats.update(m for m in bpy.data.materials if m.node_tree is not None and m.node_tree.as_pointer() in trees)
    return mats


@persistent
def after_edit(scene, depsgraph):
    if depsgraph.mode != "VIEWPORT" or bpy.app.is_job_running("RENDER") or not _main_thread():
        return
    mats = _edited_materials(depsgraph)
    for mat in mats:
        if sync.editable(mat):
            freshen(mat)
    local = [m for m in mats if m.library is None]
    if local:
        freshen_copies(local)


@persistent
def on_frame_change(scene, *_args):
    if not _main_thread():
        return
    for mat in bpy.data.materials:
        if _animated(mat) and sync.editable(mat):
            freshen(mat)


@persistent
def before_render(scene, *_args):
    # The bakes that run beside the interface are waited for (.bake_jobs): on the main thread here, from a
    # render's own thread by holding it until the main thread's timer has given the materials their tables.
    if not bake_jobs.finish():
        print("Layered BRDF: a stack's tables were still baking when the render started", file=sys.stderr)
    if _main_thread():
        with bake_jobs.waiting():
            freshen_all()


HANDLERS = (("depsgraph_update_post", after_edit), ("frame_change_post", on_frame_change),
            ("render_init", before_render))


def _same(f, fn) -> bool:
    """``f`` is ``fn`` of any copy or import of the add-on (same qualified name, a freshness module)."""
    module = getattr(f, "__module__", None) or ""
    return getattr(f, "__qualname__", None) == fn.__qualname__ and module.endswith(".blender.freshness")


def install() -> None:
    """Add the handlers, unless this or another copy of the add-on's are there already (idempotent)."""
    for name, fn in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if not any(_same(f, fn) for f in handlers):
            handlers.append(fn)


def uninstall(everyone: bool = False) -> None:
    """Remove this copy's handlers (with ``everyone``, any copy's: ``register()`` takes over from a copy
    that a script only imported)."""
    package = __name__.rsplit(".blender.", 1)[0]
    for name, fn in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        for f in [f for f in handlers if _same(f, fn)
                  and (everyone or (getattr(f, "__module__", "") or "").startswith(package + "."))]:
            handlers.remove(f)
