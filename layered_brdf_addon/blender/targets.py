"""What may take the layered material: the objects that render a surface shader, local data
(edits to linked data are not saved), and the arguments of :func:`~.build.apply_layered_material`
checked, each refusal a ParameterError that says why in the data block's own words.
"""
from __future__ import annotations

from collections.abc import Mapping

import bpy

from ..model.params import LayeredParams, ParameterError


class DataBlockError(ParameterError):
    """An object or material that cannot take the layered material, said in its own words
    ("object 'Empty' (EMPTY) has no material slots: ..."): a ParameterError, so the panel, the
    operators and the command line treat it as invalid input; ``name`` is ``"object"`` or
    ``"material"``, ``value`` the data block's name."""

    def __init__(self, kind: str, data_block, allowed: str, message: str):
        super().__init__(kind, data_block.name, allowed)
        self.args = (message,)


class _Shown:
    """A value of the wrong type as a message shows it: its type, never a long repr."""

    def __init__(self, value):
        self.text = f"<{type(value).__name__}>"

    def __repr__(self) -> str:
        return self.text


def shown(value):
    """``value`` itself when its repr is short (None, a number), else :class:`_Shown`."""
    return value if value is None or isinstance(value, (bool, int, float)) else _Shown(value)


# The object types that render a material's surface shader. Grease Pencil objects take Grease
# Pencil materials, not shader node materials; a volume renders only a material's Volume output.
SURFACE_OBJECTS = frozenset({"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD"})
SURFACE_KINDS = "a mesh, curve, surface, metaball, text, hair curves or point cloud object"
_GREASE_PENCIL = ("GREASEPENCIL", "GPENCIL")


def takes_layered_material(obj) -> bool:
    """Whether ``obj`` is of a type that renders the layered material (a mesh, curve, text...)."""
    return obj is not None and obj.type in SURFACE_OBJECTS and hasattr(obj.data, "materials")


def _kind_problem(obj) -> str | None:
    """Why an object of ``obj``'s type cannot carry the layered material, or None."""
    if takes_layered_material(obj):
        return None
    head = f"object '{obj.name}' ({obj.type})"
    if obj.type in _GREASE_PENCIL:
        return f"{head} is a Grease Pencil object: its materials are Grease Pencil materials, " \
               f"not shader node materials; choose {SURFACE_KINDS}"
    if obj.type == "VOLUME":
        return f"{head} renders only a material's Volume output, not a surface shader; choose {SURFACE_KINDS}"
    return f"{head} has no material slots: choose {SURFACE_KINDS}"


def linked_problem(obj, index: int | None = None) -> str | None:
    """Why a material cannot be written into ``obj``'s slot ``index`` (None: the active slot, or a
    new one when it has none), or None: edits to linked data are not saved (reopening the file
    reads the library again), so a linked object, and a slot (or a new slot) of linked object data,
    are refused; a library override's own slot (a slot linked to the Object) and an overridden
    mesh's existing slot keep the edit."""
    if obj.library is not None:
        return f"object '{obj.name}' is linked from {obj.library.filepath}: make it local first " \
               "(edits to linked data are not saved)"
    data = obj.data
    slots = obj.material_slots
    if slots and slots[obj.active_material_index if index is None else index].link == "OBJECT":
        return None
    if data.library is not None:
        where = "the slot is linked to the data" if slots else "a new slot would go in the data"
        return f"object '{obj.name}': its data '{data.name}' is linked from {data.library.filepath} " \
               f"and {where}; make the data local first, or link the slot to the Object " \
               "(edits to linked data are not saved)"
    if not slots and data.override_library is not None:
        return f"object '{obj.name}': its data '{data.name}' is a library override, which cannot keep " \
               "a new material slot; add the slot in the library, or make the data local first"
    return None


def object_problem(obj) -> str | None:
    """Why ``obj`` cannot be given the layered material now, or None."""
    return _kind_problem(obj) or linked_problem(obj)


def check_object(obj) -> None:
    """Raise DataBlockError unless ``obj`` is a local object of a type that renders the material."""
    problem = _kind_problem(obj)
    if problem is not None:
        raise DataBlockError("object", obj, SURFACE_KINDS, problem)
    if obj.library is not None:
        raise DataBlockError("object", obj, "a local object", linked_problem(obj))


def check_local_material(mat) -> None:
    if mat.library is not None:
        raise DataBlockError("material", mat, "a local material",
                             f"material '{mat.name}' is linked from {mat.library.filepath}: make it local first "
                             "(edits to linked data are not saved)")


def object_argument(value, argument: str):
    """The object ``value`` names (an object or its name), or ParameterError naming ``argument``."""
    if isinstance(value, bpy.types.Object):
        return value
    if isinstance(value, str):
        obj = bpy.data.objects.get(value)
        if obj is None:
            raise ParameterError(argument, value, "the name of an object in the file: "
                                 + ", ".join(sorted(o.name for o in bpy.data.objects))[:400])
        return obj
    raise ParameterError(argument, shown(value), "an object (bpy.types.Object) or its name"
                         + (", or a material" if argument == "target" else ""))


def params_argument(params) -> LayeredParams:
    """``params`` as validated parameters: a LayeredParams, a mapping of parameter values (checked
    by the parameter table, unknown names refused) or None for the defaults."""
    if params is None:
        return LayeredParams().validate()
    if isinstance(params, LayeredParams):
        return params.validate()
    if isinstance(params, Mapping):
        return LayeredParams.from_dict(dict(params))
    raise ParameterError("params", shown(params), "a LayeredParams, a dict of parameter values or None")
