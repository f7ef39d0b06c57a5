"""The benchmarks' node counts (benchmarks/node_count.py): nodes interpreted, and of those the nodes that
depend on the shading point (what Cycles cannot fold), through nested groups."""
from __future__ import annotations

import sys
from pathlib import Path

import bpy
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from node_count import interpreted_nodes, per_point_nodes  # noqa: E402


def _math(tree, op, a, b=None):
    """A Math node ``op`` of ``a`` (a socket or a number) and ``b``."""
    node = tree.nodes.new("ShaderNodeMath")
    node.operation = op
    for i, x in enumerate((a, b)):
        if x is None:
            continue
        if isinstance(x, float):
            node.inputs[i].default_value = x
        else:
            tree.links.new(x, node.inputs[i])
    return node.outputs[0]


def _group(per_point_input: bool):
    """A material whose Diffuse BSDF takes its Roughness from a group of three Math nodes: two on the group's
    input, one on a constant; the group's input fed by the Geometry node's Backfacing, or by a Value node."""
    group = bpy.data.node_groups.new("Counted", "ShaderNodeTree")
    group.interface.new_socket("In", in_out="INPUT", socket_type="NodeSocketFloat")
    group.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketFloat")
    gin, gout = group.nodes.new("NodeGroupInput"), group.nodes.new("NodeGroupOutput")
    folded = _math(group, "MULTIPLY", 2.0, 3.0)
    on_input = _math(group, "ADD", _math(group, "SQRT", gin.outputs[0]), folded)
    group.links.new(on_input, gout.inputs[0])

    mat = bpy.data.materials.new("Counted")
    nt = mat.node_tree
    nt.nodes.clear()
    source = nt.nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"] if per_point_input else \
        nt.nodes.new("ShaderNodeValue").outputs[0]
    node = nt.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    nt.links.new(source, node.inputs[0])
    bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
    nt.links.new(node.outputs[0], bsdf.inputs["Roughness"])
    nt.nodes.new("ShaderNodeMath")  # nothing reads it: never compiled
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return mat.node_tree


@pytest.mark.parametrize("per_point_input, per_point", [(True, 5), (False, 2)])
def test_nodes_on_constants_are_not_counted_per_point(per_point_input, per_point):
    tree = _group(per_point_input)
    # Source, three Math nodes in the group, the BSDF and the output; the unread Math node is not counted.
    assert interpreted_nodes(tree) == 6
    # Per point: the Geometry node, the two Math nodes on the group's input, the BSDF and the output; with a
    # Value node feeding the group, only the BSDF and the output.
    assert per_point_nodes(tree) == per_point
