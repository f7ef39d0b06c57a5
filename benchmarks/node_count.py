"""How many nodes a material makes Cycles (and EEVEE) interpret: those an output depends on, nested groups
expanded (:func:`interpreted_nodes`), and of those the nodes that depend on the shading point, which Cycles
cannot fold into constants before rendering (:func:`per_point_nodes`).  The cost of a sample follows the
nodes interpreted per point.
"""
from __future__ import annotations

SKIPPED_NODES = {"NodeGroupInput", "NodeGroupOutput", "NodeReroute", "NodeFrame"}


OUTPUT_NODES = {"ShaderNodeOutputMaterial", "ShaderNodeOutputAOV", "NodeGroupOutput"}


def compiled_nodes(tree) -> list:
    """The nodes of ``tree`` that an output depends on (a node nothing reads is never compiled), group
    input/output, reroute and frame nodes left out; a group node stands for its group."""
    outputs = [n for n in tree.nodes if n.bl_idname in OUTPUT_NODES]
    seen, stack = set(), list(outputs)
    while stack:
        node = stack.pop()
        if node.as_pointer() in seen:
            continue
        seen.add(node.as_pointer())
        stack += [link.from_node for sock in node.inputs for link in sock.links if not link.is_muted]
    return [node for node in tree.nodes if node.as_pointer() in seen and node.bl_idname not in SKIPPED_NODES]


def interpreted_nodes(tree) -> int:
    """Nodes Cycles/EEVEE evaluate in ``tree``: those an output depends on (a node nothing reads is
    never compiled), nested groups expanded (each use counts, the part of the group its used outputs
    need), group input/output, reroute and frame nodes left out.  The material's own output and
    AOV nodes count, as in any material."""
    n = 0
    for node in compiled_nodes(tree):
        if node.bl_idname == "ShaderNodeGroup":
            n += interpreted_nodes(node.node_tree) if node.node_tree is not None else 0
        else:
            n += 1
    return n


#: Nodes whose outputs Cycles never folds into constants: the shading point's geometry and the object's,
#: textures, closures and outputs.
UNFOLDED_NODES = {"ShaderNodeNewGeometry", "ShaderNodeTexCoord", "ShaderNodeTangent", "ShaderNodeAttribute",
                  "ShaderNodeUVMap", "ShaderNodeObjectInfo", "ShaderNodeVectorTransform", "ShaderNodeLayerWeight",
                  "ShaderNodeFresnel", "ShaderNodeLightPath", "ShaderNodeCameraData", "ShaderNodeWireframe",
                  "ShaderNodeBump", "ShaderNodeNormalMap", "ShaderNodeAmbientOcclusion", "ShaderNodeBevel",
                  "ShaderNodeAddShader", "ShaderNodeMixShader", *OUTPUT_NODES}


def _unfolded(node) -> bool:
    name = node.bl_idname
    return name in UNFOLDED_NODES or name.startswith(("ShaderNodeTex", "ShaderNodeBsdf"))


def per_point_nodes(tree) -> int:
    """Of :func:`interpreted_nodes`, those Cycles cannot fold into constants: nodes that read the shading
    point, the object, a texture or a closure, and nodes with an input that depends on one of those.  A node
    whose inputs are all constants (the material's values through the group's sockets) is folded before
    rendering and costs nothing per sample."""
    return _PerPoint().count(tree, frozenset())


class _PerPoint:
    """:func:`per_point_nodes`'s walk: a group's nodes are counted with the set of its inputs fed per point.
    Every answer is kept (by node or group node, and the inputs fed), so each is worked out once."""

    def __init__(self):
        self.memo = {}

    def varies(self, socket, tree, fed: frozenset) -> bool:
        """Whether the output ``socket`` of a node of ``tree`` depends on the shading point."""
        node = socket.node
        if node.bl_idname == "NodeGroupInput":
            return socket.identifier in fed
        if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
            key = ("output", node.as_pointer(), socket.identifier, fed)
            if key not in self.memo:
                self.memo[key] = False
                inner = self.fed_inputs(node, tree, fed)
                out = next((n for n in node.node_tree.nodes
                            if n.bl_idname == "NodeGroupOutput" and n.is_active_output), None)
                self.memo[key] = out is not None and any(
                    self.varies(link.from_socket, node.node_tree, inner)
                    for s in out.inputs if s.identifier == socket.identifier
                    for link in s.links if not link.is_muted)
            return self.memo[key]
        return self.node_varies(node, tree, fed)

    def node_varies(self, node, tree, fed: frozenset) -> bool:
        key = ("node", node.as_pointer(), fed)
        if key not in self.memo:
            self.memo[key] = False  # a cycle (none in a valid tree) counts as constant
            self.memo[key] = _unfolded(node) or any(self.varies(link.from_socket, tree, fed) for s in node.inputs
                                                    for link in s.links if not link.is_muted)
        return self.memo[key]

    def fed_inputs(self, group_node, tree, fed: frozenset) -> frozenset:
        key = ("fed", group_node.as_pointer(), fed)
        if key not in self.memo:
            self.memo[key] = frozenset(
                s.identifier for s in group_node.inputs
                if any(self.varies(link.from_socket, tree, fed) for link in s.links if not link.is_muted))
        return self.memo[key]

    def count(self, tree, fed: frozenset) -> int:
        n = 0
        for node in compiled_nodes(tree):
            if node.bl_idname == "ShaderNodeGroup":
                if node.node_tree is not None:
                    n += self.count(node.node_tree, self.fed_inputs(node, tree, fed))
            elif self.node_varies(node, tree, fed):
                n += 1
        return n
