"""Building the layered material: :func:`apply_layered_material`, the one function the UI, the
command line and the tests call, and :func:`tree_current`, the one test of whether a material's
tree is what a build would make.

A material's tree is built for a backend ("nodes": the node group; "osl": the OSL script) and
an effect plan.  Applying again rebuilds only when that changed (or the tree was damaged);
otherwise only the parameter values are written into the shader node's sockets.
"""
from __future__ import annotations

import json

from ..backends import node_group as node_group_builder
from ..model import policy
from ..model.base_layers import base_node
from ..model.params import THICKNESS_SOCKET, LayeredParams, ParameterError, group_socket_name, iter_sockets
from ..model.plan import EffectPlan
from ..model.policy import render_plan
from ..model.table_bake import table_layout
from . import osl as osl_backend
from .animation import animated_parameters, restore_animation, stash_animation
from .migration import claim, legacy_base_links, link_legacy_base, repair
from .own_nodes import CLEAR_BASE_ADD, active_output, stamp
from .slots import material_for
from .sockets import find_socket, held_units, legacy_tint, node_damage, set_inputs, socket_parameter
from .stored_keys import (AOV_LOWER_NORMAL, AOV_THICKNESS, AOV_UPPER_NORMAL, BACKEND_KEY, BASE_CHANNELS, BUILD_KEY,
                          CHOSEN_PLAN_KEY, ENUMS_KEY, OWN_PREFIX, ROLE_KEY, SHADER_NODE, settings_record)
from .tables import ensure_tables, tables_current
from .targets import params_argument, shown
from .unit_conversion import link_converted
from .unused_data import remove_unused_own_data


def apply_layered_material(target, params: LayeredParams | None = None, backend: str = "nodes",
                           plan: EffectPlan | None = None, name: str = "Layered BRDF"):
    """Give ``target`` (an object, its name, or a material) the layered material.

    ``params``: a LayeredParams, a dict of parameter values (validated like a preset file) or
    None (the defaults).  A wrong type, an object of a type that renders no surface shader (an
    Empty, a Grease Pencil object...) or linked data raises ParameterError, with nothing changed.
    Idempotent: applying again reuses the material and the node group, rebuilds the
    material's tree only when the backend or the plan of active effects changed, and
    otherwise only writes the parameter values into the shader's input sockets.
    ``plan`` defaults to :func:`~..model.policy.render_plan` of ``params`` (``EffectPlan.full()`` gives
    the always-full shader); a plan given is kept when the material's values change later (only its
    tables follow them, :mod:`.freshness`).  Returns the material.
    """
    params = params_argument(params)
    if plan is not None and not isinstance(plan, EffectPlan):
        raise ParameterError("plan", shown(plan), "an EffectPlan or None (the plan of the parameters)")
    if not isinstance(name, str) or not name:
        raise ParameterError("name", name if isinstance(name, str) else shown(name), "a material name (text)")
    policy.check_backend(backend, params.lobe)
    mat = material_for(target, name)
    chosen = plan is not None
    plan = plan or render_plan(params, animated_parameters(mat), backend)
    if plan.lobe != params.lobe:
        plan = EffectPlan(**{**plan.to_dict(), "lobe": params.lobe})
    node, own = claim(mat)
    if chosen:
        mat[CHOSEN_PLAN_KEY] = json.dumps(plan.to_dict(), sort_keys=True)
    else:
        mat.pop(CHOSEN_PLAN_KEY, None)
    if not tree_current(mat, node, backend, plan, params):
        if not tree_current(mat, node, backend, plan, params, tables=False):
            node = _build_tree(mat, params, backend, plan, node, own)
            mat[BUILD_KEY] = build_key(backend, plan, params)
        if backend == "nodes" and plan.tables:
            ensure_tables(node, params, plan, check_pixels=True)
        elif backend == "osl" and plan.tables:
            osl_backend.ensure_text(node, params, plan)
        remove_unused_own_data()
    repair(mat, node)
    set_inputs(node, params)
    _set_base_inputs(node, params)
    mat[BACKEND_KEY] = backend
    mat[ENUMS_KEY] = settings_record(params)
    return mat


def build_key(backend: str, plan: EffectPlan, params: LayeredParams) -> str:
    """What a build records under :data:`~.stored_keys.BUILD_KEY`: backend, plan and base layer."""
    return f"{backend}:{plan.key}:{params.base_layer}"


def tree_current(mat, node, backend: str, plan: EffectPlan, params: LayeredParams, check_sources: bool = True,
                 tables: bool = True) -> bool:
    """Whether ``mat``'s tree, with ``node`` its shader node (or None), is what a build for
    ``backend``, ``plan`` and ``params`` makes: its build record says so, the node has every
    socket, and it runs this version's node group for ``plan`` (for a plan with tables, baked for
    ``params``; with ``check_sources``, their texels read back too; without ``tables``, whatever
    its tables hold) or the OSL script (for a plan with tables, its text written for ``params``; its
    source read back only with ``check_sources``; without ``tables``, any text of the plan's)."""
    if node is None or mat.get(BUILD_KEY) != build_key(backend, plan, params) or node_damage(node) is not None:
        return False
    if backend == "nodes":
        return node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and \
            node_group_builder.is_current(node.node_tree, plan) and \
            (not (tables and plan.tables) or tables_current(node.node_tree, params, plan, check_sources))
    if node.bl_idname != "ShaderNodeScript" or node.script is None:
        return False
    if plan.tables and not tables:
        return osl_backend.TABLES_KEY in node.script
    return osl_backend.text_current(node.script, params, plan, check_sources)


def _set_base_inputs(node, params: LayeredParams) -> None:
    """Write the values of the add-on's base node (a metal's colour and roughness follow the
    parameters) when the add-on's own base node feeds ``node``'s Base Shader input."""
    spec = base_node(params)
    base_in = find_socket(node.inputs, "Base Shader")
    if spec is None or base_in is None:
        return
    for link in base_in.links:
        base = link.from_node
        if base.get(ROLE_KEY) == "base" and base.bl_idname == spec.node_type:
            for name, value in spec.inputs.items():
                base.inputs[name].default_value = value


def _add_clear_base(tree, node, base, transmittance, parent) -> None:
    """A clear base (a soap film's): the Transparent BSDF ``base`` tinted by ``node``'s Transmittance (what
    the film passes, channel by channel), added to ``node``'s BSDF by an Add Shader that now feeds whatever
    the BSDF fed.  Not through the Base Shader input: a Mix Shader takes one factor for all channels."""
    tree.links.new(transmittance, base.inputs["Color"])
    add = tree.nodes.new("ShaderNodeAddShader")
    add.name = add.label = f"{OWN_PREFIX} clear base"
    add.location = (node.location[0] + 260, node.location[1] - 120)
    if parent is not None:
        add.parent = parent
    stamp(add, CLEAR_BASE_ADD)
    bsdf = find_socket(node.outputs, "BSDF")
    targets = [link.to_socket for link in bsdf.links]
    tree.links.new(bsdf, add.inputs[0])
    tree.links.new(base.outputs[0], add.inputs[1])
    for target in targets:
        tree.links.new(add.outputs[0], target)


def _group_lacks_sockets(group) -> bool:
    """Whether the add-on's node group lacks a socket it builds for a parameter, its Thickness input or
    its BSDF output."""
    items = [i for i in group.interface.items_tree if i.item_type == "SOCKET"]
    inputs = {i.name for i in items if i.in_out == "INPUT"}
    outputs = {i.name for i in items if i.in_out == "OUTPUT"}
    return "BSDF" not in outputs or THICKNESS_SOCKET not in inputs or \
        any(group_socket_name(s) not in inputs for s in iter_sockets())


def group_for(plan: EffectPlan, params: LayeredParams):
    """The node group for ``plan`` (:func:`node_group_builder.ensure_group`). A group stamped as
    current that lacks a socket (the artist deleted one) is marked stale first, so it is rebuilt,
    or set aside while other materials still use it (each is repaired when applied again)."""
    layout = table_layout(params, plan) if plan.tables else None
    group = node_group_builder.ensure_group(plan, layout)
    if _group_lacks_sockets(group):
        del group[node_group_builder.PLAN_KEY]
        group = node_group_builder.ensure_group(plan, layout)
    return group


def _build_tree(mat, params: LayeredParams, backend: str, plan: EffectPlan, old, own):
    """(Re)build the add-on's nodes (``old`` the shader node, ``own`` every node of the add-on)
    in ``mat``.  The artist's nodes are kept, and so are their links to and from the shader
    node: the new node feeds whatever the old one fed (a Mix Shader, the Material Output)."""
    tree = mat.node_tree
    keep_in, keep_out = [], []
    name, label, width, parent, location = SHADER_NODE, SHADER_NODE, 220, None, None
    legacy_base = None
    if old is not None:
        for sock in old.inputs:
            for link in sock.links:
                if link.from_node not in own:
                    keep_in.append((link.from_socket, sock.name, socket_parameter(old, sock)))
        for sock in old.outputs:
            for link in sock.links:
                if link.to_node not in own:
                    keep_out.append((sock.name, link.to_socket))
                elif link.to_node.get(ROLE_KEY) == CLEAR_BASE_ADD:  # what the clear base's Add fed, the BSDF feeds
                    keep_out += [(sock.name, out_link.to_socket) for out_link in link.to_node.outputs[0].links
                                 if out_link.to_node not in own]
        name, label, width, parent = old.name, old.label, old.width, old.parent
        location = tuple(old.location)
        old_inputs = [(sock.name, socket_parameter(old, sock)[1]) for sock in old.inputs]
        stashed = stash_animation(mat, old.name)
        legacy_base = legacy_base_links(old, params)
        if legacy_base is not None:
            handled = {*BASE_CHANNELS, legacy_tint(old).name}
            keep_in = [kept for kept in keep_in if kept[1] not in handled]
    for n in own:
        tree.nodes.remove(n)
    out = active_output(tree)
    if out is None:
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        out.location = (400, 0)
    if backend == "nodes":
        group = group_for(plan, params)
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
    else:
        node = tree.nodes.new("ShaderNodeScript")
        node.mode = "INTERNAL"
        osl_backend.compile_script_node(node, script=osl_backend.text_for(plan, params))
    node.name = name
    node.label = label
    node.width = width
    if parent is not None:
        node.parent = parent
    node.location = location if location is not None else (out.location[0] - 300, out.location[1])
    stamp(node, "shader")
    if old is None:  # a first build: the material shows the layered shader
        tree.links.new(find_socket(node.outputs, "BSDF"), out.inputs["Surface"])
    for k, (from_socket, sock_name, (spec, units)) in enumerate(keep_in):
        target = find_socket(node.inputs, sock_name)
        if target is None:
            continue
        new_units = held_units(node, spec, target) if spec is not None else units
        if new_units == units:
            tree.links.new(from_socket, target)
        else:  # a link into a socket of other units (an exponent into a Roughness): converted on the way
            link_converted(tree, from_socket, target, units, new_units, parent=parent,
                           location=(node.location[0] - 380, node.location[1] - 40 * k))
    for sock_name, to_socket in keep_out:
        source = find_socket(node.outputs, sock_name)
        if source is not None:
            tree.links.new(source, to_socket)
    if old is not None:
        restore_animation(mat, stashed, node, old_inputs)
    if legacy_base is not None:
        link_legacy_base(tree, node, *legacy_base)
    base_in = find_socket(node.inputs, "Base Shader")
    spec = base_node(params)
    if spec is not None and base_in is not None and not base_in.is_linked:
        base = tree.nodes.new(spec.node_type)
        base.name = base.label = f"{OWN_PREFIX} {spec.label}"
        base.location = (node.location[0] - 250, node.location[1] - 300)
        if parent is not None:
            base.parent = parent
        stamp(base, "base")
        transmittance = find_socket(node.outputs, "Transmittance")
        if spec.node_type == "ShaderNodeBsdfTransparent" and transmittance is not None:
            _add_clear_base(tree, node, base, transmittance, parent)
        else:
            tree.links.new(base.outputs[0], base_in)
    for k, (aov_name, socket_name, kind) in enumerate(((AOV_THICKNESS, "Thickness", "Value"),
                                                       (AOV_LOWER_NORMAL, "Lower Normal", "Color"),
                                                       (AOV_UPPER_NORMAL, "Upper Normal", "Color"))):
        src = find_socket(node.outputs, socket_name)
        if src is None:
            continue
        aov = tree.nodes.new("ShaderNodeOutputAOV")
        aov.name = aov.label = f"{OWN_PREFIX} AOV {aov_name}"
        aov.aov_name = aov_name
        aov.location = (out.location[0], out.location[1] - 200 - 150 * k)
        stamp(aov, "aov")
        tree.links.new(src, aov.inputs[kind])
    return node

