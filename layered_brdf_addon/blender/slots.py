"""The object's material slot and the layered material: Apply fills the slot the object renders
(or adds one) and records what it displaced; Remove puts that back, and takes away only a slot
the add-on added.
"""
from __future__ import annotations

import bpy

from .stored_keys import DISPLACED_KEY, MATERIAL_KEY, SLOT_KEY
from .targets import DataBlockError, check_local_material, check_object, linked_problem, object_argument


def material_for(target, name: str):
    """The material ``target`` (a material, an object or its name) gets: the material itself, the
    object's own layered material, else a new one in the slot the object renders (recorded so that
    Remove can undo it)."""
    if isinstance(target, bpy.types.Material):
        check_local_material(target)
        return target
    obj = object_argument(target, "target")
    check_object(obj)
    mat = None
    if obj.active_material is not None and obj.active_material.get(MATERIAL_KEY):
        mat = obj.active_material
    if mat is not None and mat.library is not None:
        raise DataBlockError("object", obj, "an object whose material is local",
                             f"object '{obj.name}': its material '{mat.name}' is linked from "
                             f"{mat.library.filepath}: make it local first (edits to linked data are not saved)")
    if mat is not None:
        return mat
    problem = linked_problem(obj)
    if problem is not None:
        raise DataBlockError("object", obj, "an object whose slot can be saved", problem)
    mat = bpy.data.materials.new(name)
    mat[MATERIAL_KEY] = True
    mat.node_tree.nodes.clear()  # a new material's default Principled BSDF is not ours to keep
    if obj.material_slots:
        # The slot the object renders: the object's own when the slot is linked to the Object.
        slot = obj.material_slots[obj.active_material_index]
        displaced = slot.material
        slot.material = mat
        if displaced is not None:
            mat[DISPLACED_KEY] = displaced  # an ID pointer: a user, so it is saved; Remove puts it back
        mat[SLOT_KEY] = "replaced" if displaced is not None else "filled"
    else:
        obj.data.materials.append(mat)
        mat[SLOT_KEY] = "added"
    return mat


def displaced_material(mat):
    """The artist's material that ``mat`` replaced in an object's slot (Remove puts it back), or None."""
    other = mat.get(DISPLACED_KEY)
    return other if isinstance(other, bpy.types.Material) else None


def remove_layered_material(obj) -> bool:
    """Remove the add-on's material from ``obj`` (an object or its name): from its active slot,
    else its first layered slot, and put back the material it replaced there; True when one was
    removed.  A linked object is refused (the edit would not be saved)."""
    obj = object_argument(obj, "obj")
    if obj.library is not None:
        raise DataBlockError("object", obj, "a local object", linked_problem(obj))
    slots = list(obj.material_slots)
    order = [obj.active_material_index] + list(range(len(slots))) if slots else []
    i = next((i for i in order if i < len(slots) and slots[i].material is not None
              and slots[i].material.get(MATERIAL_KEY)), None)
    if i is None:
        return False
    problem = linked_problem(obj, i)
    if problem is not None:
        raise DataBlockError("object", obj, "an object whose slot can be saved", problem)
    slot = slots[i]
    mat = slot.material
    displaced = displaced_material(mat)
    how = mat.get(SLOT_KEY)
    if displaced is not None:
        slot.material = displaced
    elif how in ("replaced", "filled") or slot.link == "OBJECT":
        slot.material = None
    else:  # the slot was added for it (or the material predates this record)
        _remove_slot(obj, i)
    for key in (DISPLACED_KEY, SLOT_KEY):
        if key in mat:
            del mat[key]
    return True


def _remove_slot(obj, index: int) -> None:
    """Remove material slot ``index`` of ``obj`` (popping the mesh's material leaves the object a slot)."""
    active = obj.active_material_index
    obj.active_material_index = index
    try:
        with bpy.context.temp_override(object=obj):
            done = bpy.ops.object.material_slot_remove() == {"FINISHED"}
    except RuntimeError:
        done = False
    if not done:
        obj.data.materials.pop(index=index)
    obj.active_material_index = min(active if active < index else max(active - 1, 0),
                                    max(len(obj.material_slots) - 1, 0))
