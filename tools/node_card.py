"""Draw the Layered BRDF node as Blender lays it out, from the interface Blender reports for the group.

``python tools/node_card.py [PRESET] [OUT.png]`` (defaults: oil_slick, docs/images/node.png). The
group is built in Blender (the bpy module) for the preset's plan, the node given the preset's values;
its name, outputs, panels (open or closed as a new node shows them), sockets, subtypes and values are
read back from Blender and drawn in the node editor's layout and default dark theme. The bpy module
draws no user interface, so this is the node's data drawn, not a screenshot of the editor.
Written whole: a temporary file renamed into place.
"""
from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import bpy
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Circle, FancyBboxPatch  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from layered_brdf_addon.blender.material import apply_layered_material, shader_node  # noqa: E402
from layered_brdf_addon.model import preset  # noqa: E402

ROW = 0.34
WIDTH = 4.6
SOCKET_COLOURS = {"NodeSocketFloat": "#a1a1a1", "NodeSocketColor": "#c7c729", "NodeSocketVector": "#6363c7",
                  "NodeSocketShader": "#63c763"}


def _value_text(item, sock) -> str:
    if item.socket_type == "NodeSocketColor":  # the swatch, in sRGB
        rgb = [min(max(c, 0.0), 1.0) ** (1 / 2.2) for c in sock.default_value[:3]]
        return "#" + "".join(f"{round(255 * c):02x}" for c in rgb)
    if item.socket_type != "NodeSocketFloat" or item.hide_value or sock.is_linked:
        return ""
    v = sock.default_value
    if item.subtype == "ANGLE":
        return f"{math.degrees(v):.0f}\u00b0"
    if item.subtype == "WAVELENGTH":
        return f"{v:g} nm"
    if item.subtype == "FACTOR":
        return f"{v:.3f}"
    return f"{v:.3g}"


def _rows(group, node):
    """(kind, text, value, socket type) rows in the node editor's order."""
    rows = [("title", group.name, "", "")]
    for item in group.interface.items_tree:
        if item.item_type == "SOCKET" and item.in_out == "OUTPUT":
            rows.append(("output", item.name, "", item.socket_type))
    closed = set()
    for item in group.interface.items_tree:
        if item.item_type == "PANEL":
            rows.append(("panel", item.name, "\u25b8" if item.default_closed else "\u25be", ""))
            if item.default_closed:
                closed.add(item.name)
            continue
        if item.in_out != "INPUT":
            continue
        parent = item.parent.name if item.parent is not None and item.parent.name else ""
        if parent in closed:
            continue
        sock = next(s for s in node.inputs if s.identifier == item.identifier)
        rows.append(("input", item.name, _value_text(item, sock), item.socket_type))
    return rows


def draw(rows, out: Path) -> None:
    height = ROW * (len(rows) + 1)
    fig = plt.figure(figsize=(WIDTH * 0.9, height * 0.9), dpi=150)
    ax = fig.add_axes((0, 0, 1, 1))
    ax.set_xlim(-0.2, WIDTH + 0.2)
    ax.set_ylim(-height, 0.2)
    ax.axis("off")
    fig.patch.set_facecolor("#1d1d1d")
    ax.add_patch(FancyBboxPatch((0, -height + 0.1), WIDTH, height - 0.2, boxstyle="round,pad=0,rounding_size=0.12",
                                facecolor="#303030", edgecolor="#000000", linewidth=1.2))
    y = -0.05
    for kind, text, value, stype in rows:
        if kind == "title":
            ax.add_patch(FancyBboxPatch((0, y - ROW), WIDTH, ROW, boxstyle="round,pad=0,rounding_size=0.12",
                                        facecolor="#2b652b", edgecolor="none"))
            ax.text(0.15, y - ROW / 2, text, color="white", va="center", fontsize=6.5)
        elif kind == "output":
            ax.text(WIDTH - 0.2, y - ROW / 2, text, color="#e6e6e6", va="center", ha="right", fontsize=7)
            ax.add_patch(Circle((WIDTH, y - ROW / 2), 0.06, color=SOCKET_COLOURS.get(stype, "#a1a1a1")))
        elif kind == "panel":
            ax.text(0.12, y - ROW / 2, f"{value}  {text}", color="#ffffff", va="center", fontsize=7.5,
                    fontweight="bold")
        else:
            ax.add_patch(Circle((0, y - ROW / 2), 0.06, color=SOCKET_COLOURS.get(stype, "#a1a1a1")))
            if value and stype != "NodeSocketColor":
                ax.add_patch(FancyBboxPatch((0.15, y - ROW + 0.05), WIDTH - 0.3, ROW - 0.1,
                                            boxstyle="round,pad=0,rounding_size=0.06", facecolor="#545454",
                                            edgecolor="none"))
                ax.text(WIDTH - 0.25, y - ROW / 2, value, color="#e6e6e6", va="center", ha="right", fontsize=7)
            elif stype == "NodeSocketColor":
                ax.add_patch(FancyBboxPatch((WIDTH - 1.2, y - ROW + 0.06), 0.95, ROW - 0.12,
                                            boxstyle="round,pad=0,rounding_size=0.04", facecolor=value,
                                            edgecolor="none"))
            ax.text(0.25, y - ROW / 2, text, color="#e6e6e6", va="center", fontsize=7)
        y -= ROW
    tmp = out.with_name(out.name + ".tmp.png")
    fig.savefig(tmp, facecolor=fig.get_facecolor())
    plt.close(fig)
    os.replace(tmp, out)


def main(name: str = "oil_slick", out: str = "docs/images/node.png") -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("Card")
    obj = bpy.data.objects.new("Card", mesh)
    bpy.context.scene.collection.objects.link(obj)
    mat = apply_layered_material(obj, preset(name))
    node = shader_node(mat)
    draw(_rows(node.node_tree, node), Path(out))
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*sys.argv[1:])
