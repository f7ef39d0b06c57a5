"""The add-on's own data blocks that nothing uses any more: node groups, baked tables and OSL texts it made
(recognised by their stamps), removed after a rebuild; unstamped, linked or used ones are kept.
"""
from __future__ import annotations

import bpy

from ..backends import node_group as node_group_builder
from .stored_keys import SUBGROUP_KEY, TEXT_KEY
from .tables import unused_tables


def _script_texts_in_use() -> set:
    trees = [m.node_tree for m in bpy.data.materials if m.node_tree is not None]
    trees += list(bpy.data.node_groups)
    used = set()
    for tree in trees:
        for n in tree.nodes:
            if n.bl_idname == "ShaderNodeScript" and n.script is not None:
                used.add(n.script.name)
    for screen in bpy.data.screens:
        for area in screen.areas:
            for space in area.spaces:
                if space.type == "TEXT_EDITOR" and space.text is not None:
                    used.add(space.text.name)
    return used


def remove_unused_own_data() -> list[str]:
    """Remove the add-on's node groups and OSL texts (stamped) that nothing uses any more.

    A group counts as unused when its only user is its fake user (asset marking sets one);
    a text when no Script node runs it and no Text Editor shows it.  Unstamped, linked or
    used data blocks are never touched.  Returns the names removed."""
    removed = []
    while True:
        stale = [g for g in bpy.data.node_groups
                 if g.library is None and (g.get(node_group_builder.STAMP_KEY) is not None
                                           or g.get(SUBGROUP_KEY) is not None)
                 and g.users - int(g.use_fake_user) <= 0]
        if not stale:
            break
        for g in stale:
            removed.append(g.name)
            bpy.data.node_groups.remove(g)
    for image in unused_tables():
        removed.append(image.name)
        bpy.data.images.remove(image)
    used = _script_texts_in_use()
    for t in [t for t in bpy.data.texts if t.library is None and t.get(TEXT_KEY) is not None
              and t.name not in used]:
        removed.append(t.name)
        bpy.data.texts.remove(t)
    return removed
