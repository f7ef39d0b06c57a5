"""A clear base (*Base shader: Transparent*, a soap film): a Transparent BSDF tinted by the shader's
Transmittance, added after the shader by an Add Shader the add-on stamps.  Applying again, switching the
base away and back, and an artist's node between the shader and the output leave one of each of the add-on's
nodes, and every node and link of the artist's where it was."""
from __future__ import annotations

import bpy
import pytest

from layered_brdf_addon.blender.material import ROLE_KEY, apply_layered_material, shader_node
from layered_brdf_addon.blender.own_nodes import CLEAR_BASE_ADD
from layered_brdf_addon.blender.scene import reset_blender
from layered_brdf_addon.blender.sockets import find_socket
from layered_brdf_addon.model import preset

from blender_helpers import add_sphere

SOAP = preset("soap_bubble")


def _own(mat, role):
    return [n for n in mat.node_tree.nodes if n.get(ROLE_KEY) == role]


def _output(mat):
    return next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")


@pytest.fixture
def sphere():
    reset_blender()
    return add_sphere()


@pytest.mark.parametrize("backend", ["nodes", "osl"])
def test_a_clear_base_is_tinted_by_the_transmittance_and_added_after_the_shader(sphere, backend):
    mat = apply_layered_material(sphere, SOAP, backend)
    for _ in range(2):  # applying again changes nothing
        (add,) = _own(mat, CLEAR_BASE_ADD)
        (base,) = _own(mat, "base")
        node = shader_node(mat)
        assert base.bl_idname == "ShaderNodeBsdfTransparent"
        assert base.inputs["Color"].links[0].from_socket.name == "Transmittance"
        assert base.inputs["Color"].links[0].from_node == node
        assert {link.from_node for s in add.inputs for link in s.links} == {node, base}
        assert _output(mat).inputs["Surface"].links[0].from_node == add
        assert not find_socket(node.inputs, "Base Shader").is_linked  # the group's name or OSL's
        mat = apply_layered_material(sphere, SOAP.replace(d_max=800.0), backend)


def test_switching_the_base_away_and_back_keeps_the_artists_nodes(sphere):
    mat = apply_layered_material(sphere, SOAP, "nodes")
    tree = mat.node_tree
    # The artist puts a Mix Shader between the layered material and the output.
    mix = tree.nodes.new("ShaderNodeMixShader")
    (add,) = _own(mat, CLEAR_BASE_ADD)
    tree.links.new(add.outputs[0], mix.inputs[1])
    tree.links.new(mix.outputs[0], _output(mat).inputs["Surface"])
    names = {n.name for n in tree.nodes if n.get(ROLE_KEY) is None}

    mat = apply_layered_material(sphere, SOAP.replace(base_layer="none"), "nodes")
    assert not _own(mat, CLEAR_BASE_ADD) and not _own(mat, "base")
    assert mix.inputs[1].links[0].from_node == shader_node(mat)  # what the Add fed, the shader feeds
    assert _output(mat).inputs["Surface"].links[0].from_node == mix

    mat = apply_layered_material(sphere, SOAP, "nodes")
    (add,) = _own(mat, CLEAR_BASE_ADD)
    assert mix.inputs[1].links[0].from_node == add and _output(mat).inputs["Surface"].links[0].from_node == mix
    assert {n.name for n in tree.nodes if n.get(ROLE_KEY) is None} == names
    assert len(bpy.data.materials) == 1
