"""Registering the add-on: one list of classes, one property on materials, two handlers."""
from __future__ import annotations

import bpy
from bpy.props import PointerProperty

from . import assets, operators, properties, ui

CLASSES = (
    properties.LayeredBRDFSettings,
    operators.LAYERED_BRDF_OT_apply,
    operators.LAYERED_BRDF_OT_remove,
    operators.LAYERED_BRDF_OT_load_preset,
    operators.LAYERED_BRDF_OT_save_preset,
    operators.LAYERED_BRDF_OT_delete_preset,
    operators.LAYERED_BRDF_OT_mark_asset,
    operators.LAYERED_BRDF_OT_upgrade,
    operators.LAYERED_BRDF_OT_enable_osl,
    operators.LAYERED_BRDF_OT_param_info,
    ui.LAYERED_BRDF_MT_presets,
    ui.LAYERED_BRDF_MT_delete_presets,
    ui.LAYERED_BRDF_PT_material,
    *ui.PARAM_PANELS,
)


def _handlers():
    return (
        (bpy.app.handlers.depsgraph_update_post, properties.on_depsgraph_update),
        (bpy.app.handlers.load_post, properties.on_load_post),
    )


def _same_function(a, b) -> bool:
    """Also matches the handler of an earlier import of this module (after a reload)."""
    return a is b or (getattr(a, "__module__", None) == b.__module__
                      and getattr(a, "__qualname__", None) == b.__qualname__)


def _subclasses(base):
    for sub in base.__subclasses__():
        yield sub
        yield from _subclasses(sub)


def _registered_versions(cls) -> list:
    """``cls`` and same-named classes of earlier imports of this module that Blender holds registered."""
    bases = (bpy.types.PropertyGroup, bpy.types.Operator, bpy.types.Panel, bpy.types.Menu)
    base = next(b for b in bases if issubclass(cls, b))
    return [c for c in _subclasses(base) if c.__name__ == cls.__name__ and c.is_registered]


def is_registered() -> bool:
    return (hasattr(bpy.types.Material, properties.SETTINGS)
            or any(_registered_versions(cls) for cls in CLASSES)
            or any(_same_function(f, fn) for handlers, fn in _handlers() for f in handlers))


def register() -> None:
    """Register the add-on; when it already is (e.g. registered twice), unregister it first."""
    if is_registered():
        unregister()
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    setattr(bpy.types.Material, properties.SETTINGS, PointerProperty(
        type=properties.LayeredBRDFSettings, name="Layered BRDF",
        description="Settings of the layered material (enums, backend, preset)"))
    for handlers, fn in _handlers():
        handlers.append(fn)


def unregister() -> None:
    """Remove every handler, the material property and every class, whichever import registered them."""
    for handlers, fn in _handlers():
        for f in [f for f in handlers if _same_function(f, fn)]:
            handlers.remove(f)
    assets.cancel_queued()
    if hasattr(bpy.types.Material, properties.SETTINGS):
        delattr(bpy.types.Material, properties.SETTINGS)
    for cls in reversed(CLASSES):
        for registered in _registered_versions(cls):
            bpy.utils.unregister_class(registered)
