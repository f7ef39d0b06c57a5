"""What the add-on puts under the layer, in its Base Shader input (``base_layer``).

The paper's model says nothing of medium 2 beyond the lower boundary's reflection and the
diffuse term: a base is the artist's choice.  Besides their own shader ('none'), the add-on
offers a clear film ('transparent': a soap bubble) and a metal ('metal': anodised or
tarnished metals), a conductor of the base colour receiving what the top boundary
transmits (``1 - F``), as rough as the upper boundary.

With thin-film optics (``optics="physical"``) the metal *is* the layer's lower boundary: its
reflection is the transmitted lobe, from the lower medium's complex index (``r2``, ``k2``), so
no second metal is added; a transparent base receives what the film neither reflects nor
absorbs (docs/physical-optics.md has the rule for each base).

bpy-free: the Blender layer builds the node from :func:`base_node`.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .params import LayeredParams
from .socket_units import ROUGHNESS, to_socket


@dataclass(frozen=True)
class BaseNode:
    """A shader node under the layer: its Blender type, label and input values."""

    node_type: str
    label: str
    inputs: dict[str, Any] = field(default_factory=dict)


def phong_to_roughness(e: float) -> float:
    """The Roughness of a Cycles microfacet node (``sqrt(alpha)``) whose lobe about the mirror
    direction is as wide as a Phong lobe of exponent ``e``: the Upper Roughness socket's value
    (:mod:`.socket_units`, Beckmann ``alpha = sqrt(2 / (4 e + 2))``)."""
    return float(to_socket(ROUGHNESS, max(e, 0.0)))


def base_node(params: LayeredParams) -> BaseNode | None:
    """The node the add-on puts in the Base Shader input for ``params.base_layer`` (None: none)."""
    if params.base_layer == "transparent":
        return BaseNode("ShaderNodeBsdfTransparent", "base")
    if params.base_layer == "metal" and params.optics == "physical":
        return None  # the lower medium is the metal
    if params.base_layer == "metal":
        return BaseNode("ShaderNodeBsdfMetallic", "metal base",
                        {"Base Color": (*params.base_color, 1.0), "Roughness": phong_to_roughness(params.e0)})
    return None
