"""The materials the benchmarks build beside the add-on's: a tabulated group's floor (benchmarks/scene_variants.py,
``--reads-floor``: the same thickness pattern, table reads and closures as the group, without the rest of its
arithmetic), Principled BSDF + Thin Film with the same thickness pattern, and the altered copies of a tilted
boundary's group that benchmarks/eevee_table_reads.py renders."""
from __future__ import annotations

import sys
from pathlib import Path

import bpy
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
from node_count import per_point_nodes  # noqa: E402
from eevee_table_reads import read_with, slices_by_position, without_slice_offset  # noqa: E402
from scene_variants import layered_variant, table_floor_variants  # noqa: E402

from layered_brdf_addon.model import preset  # noqa: E402
from layered_brdf_addon.model.policy import plan_effects  # noqa: E402
from layered_brdf_addon.model.table_bake import table_layout  # noqa: E402


def _reads(tree) -> list:
    """The images a tree's Image Texture nodes read, once per node, nested groups included."""
    out = []
    for n in tree.nodes:
        if n.bl_idname == "ShaderNodeTexImage":
            out.append(n.image.name)
        elif n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None:
            out += _reads(n.node_tree)
    return sorted(out)


def _variants(name: str):
    bpy.ops.mesh.primitive_uv_sphere_add()
    obj = bpy.context.active_object
    obj.data.materials.append(None)
    v = layered_variant(obj, name, "tables", preset(name).accuracy)
    return v, table_floor_variants(v)


@pytest.mark.parametrize("name, reads", [("fig6_medium", 11), ("oil_slick", 4)])
def test_floor_reads_what_the_group_reads(name, reads):
    v, (floor, *_) = _variants(name)
    # The group's image of what passes to the base feeds its Transmittance output only, unlinked here: Cycles
    # leaves it out, and so does the floor.
    p = preset(name)
    layout = table_layout(p, plan_effects(p))
    passed = f" {layout.transmittance_image}" if layout.transmittance == "own" else None
    group_reads = [r for r in _reads(v.material.node_tree) if passed is None or not r.endswith(passed)]
    assert _reads(floor.material.node_tree) == group_reads
    assert len(_reads(floor.material.node_tree)) == reads
    images = {n.image.name: n for n in floor.material.node_tree.nodes if n.bl_idname == "ShaderNodeTexImage"}
    assert {(n.interpolation, n.extension) for n in images.values()} == {("Cubic", "EXTEND")}
    glossy = [n for n in floor.material.node_tree.nodes
              if n.bl_idname in ("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic")]
    assert len(glossy) == (4 if name == "fig6_medium" else 2)
    assert all(n.inputs["Color"].is_linked and n.inputs["Roughness"].is_linked for n in glossy)
    assert floor.per_point < v.per_point


def test_thin_film_with_the_presets_noise():
    p = preset("oil_slick")
    _, (_, principled) = _variants("oil_slick")
    nt = principled.material.node_tree
    bsdf = next(n for n in nt.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    map_range = bsdf.inputs["Thin Film Thickness"].links[0].from_node
    assert (map_range.inputs["To Min"].default_value, map_range.inputs["To Max"].default_value) == \
        pytest.approx((p.d_min, p.d_max))
    noise = map_range.inputs["Value"].links[0].from_node
    assert (noise.noise_dimensions, noise.noise_type, noise.normalize) == ("4D", "FBM", True)
    assert noise.inputs["Scale"].default_value == pytest.approx(p.noise_scale)
    assert noise.inputs["Detail"].default_value == pytest.approx(p.noise_detail)
    assert per_point_nodes(nt) == 5  # coordinates, noise, map range, BSDF, output


def test_no_pattern_no_thin_film_variant():
    """The soap bubble's thickness follows the height, not a noise: only the floor."""
    _, floors = _variants("soap_bubble")
    assert [f.backend for f in floors] == ["reads-floor"]


def _group(mat):
    return next(n.node_tree for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeGroup")


def _offsets(mat) -> set:
    """The inputs feeding the X of the Combine XYZ nodes that offset the group's sliced reads."""
    out = set()
    for n in _group(mat).nodes:
        if n.bl_idname == "ShaderNodeVectorMath" and n.operation == "ADD" and n.inputs[1].is_linked:
            combine = n.inputs[1].links[0].from_node
            if combine.bl_idname == "ShaderNodeCombineXYZ" and not combine.inputs["Y"].is_linked:
                x = combine.inputs["X"]
                out.add(x.links[0].from_node.operation if x.is_linked else x.default_value)
    return out


def test_altered_groups_leave_the_original_alone():
    v, _ = _variants("fig6_medium")
    before = _offsets(v.material)
    assert before == {"MULTIPLY"}  # i0 times a slice's width
    no_offset = without_slice_offset(v.material, "no offset")
    assert _offsets(no_offset) == {0.0}
    by_position = slices_by_position(v.material, "by position", 25)
    assert any(n.outputs["Generated"].is_linked for n in _group(by_position).nodes
               if n.bl_idname == "ShaderNodeTexCoord")  # the slice from the object's height
    linear = read_with(v.material, "linear", "Linear")
    assert {n.interpolation for n in _group(linear).nodes if n.bl_idname == "ShaderNodeTexImage"} == {"Linear"}
    # the add-on's material and group are untouched
    assert _offsets(v.material) == before
    assert {n.interpolation for n in _group(v.material).nodes if n.bl_idname == "ShaderNodeTexImage"} == {"Cubic"}
    assert len({id(_group(m)) for m in (v.material, no_offset, by_position, linear)}) == 4
