"""Registering the add-on: one list of classes, one property on materials, its handlers (those of
:mod:`.freshness` and four more).

Called only from the package's ``register()`` and ``unregister()`` (the add-on's entry point).
"""
from __future__ import annotations

import bpy
from bpy.props import PointerProperty

from . import assets, bake_jobs, fit_operator, freshness, operators, properties, stack_ui, sync, ui
from .stored_keys import SETTINGS

CLASSES = (
    properties.LayeredBRDFStackFilm,
    properties.LayeredBRDFSettings,
    operators.LAYERED_BRDF_OT_apply,
    operators.LAYERED_BRDF_OT_remove,
    operators.LAYERED_BRDF_OT_load_preset,
    operators.LAYERED_BRDF_OT_save_preset,
    operators.LAYERED_BRDF_OT_delete_preset,
    operators.LAYERED_BRDF_OT_mark_asset,
    operators.LAYERED_BRDF_OT_build_asset_library,
    operators.LAYERED_BRDF_OT_upgrade,
    operators.LAYERED_BRDF_OT_enable_osl,
    operators.LAYERED_BRDF_OT_param_info,
    fit_operator.LAYERED_BRDF_OT_fit_to_render,
    *stack_ui.CLASSES,
    ui.LAYERED_BRDF_MT_presets,
    ui.LAYERED_BRDF_MT_delete_presets,
    ui.LAYERED_BRDF_PT_material,
    *ui.PARAM_PANELS,
)


def _handlers():
    return (
        (bpy.app.handlers.load_post, sync.on_load_post),
        (bpy.app.handlers.undo_post, sync.on_undo_redo),  # an undo restores values, not an image's texels
        (bpy.app.handlers.redo_post, sync.on_undo_redo),
        (bpy.app.handlers.version_update, assets.on_version_update),  # older versions' asset marks off
    )


def _same_function(a, b) -> bool:
    """Also matches the handler of an earlier import of this module (after a reload)."""
    return a is b or (getattr(a, "__module__", None) == b.__module__
                      and getattr(a, "__qualname__", None) == b.__qualname__)


def _subclasses(base):
    for sub in base.__subclasses__():
        yield sub
        yield from _subclasses(sub)


def _package() -> str:
    """This copy's package: ``layered_brdf_addon`` installed with pip or from a checkout,
    ``bl_ext.<repository>.layered_brdf.layered_brdf_addon`` as an extension."""
    return __name__.rsplit(".blender.", 1)[0]


def _ours(obj) -> bool:
    """Whether ``obj`` (a class or handler) comes from this copy (this or an earlier import of it)."""
    module = getattr(obj, "__module__", None) or ""
    return module == _package() or module.startswith(_package() + ".")


def _registered_versions(cls, everyone: bool = False) -> list:
    """``cls`` and same-named classes of earlier imports of this module that Blender holds registered
    (with ``everyone``, also those of another copy of the add-on)."""
    bases = (bpy.types.PropertyGroup, bpy.types.Operator, bpy.types.Panel, bpy.types.Menu, bpy.types.UIList)
    base = next(b for b in bases if issubclass(cls, b))
    return [c for c in _subclasses(base) if c.__name__ == cls.__name__ and c.is_registered
            and (everyone or _ours(c))]


# The module holding another copy's material handlers: .blender.sync, or .blender.properties in
# versions before the sync module.
_SYNC_MODULES = (".blender.sync", ".blender.properties")


def _other_copy() -> str | None:
    """The package of another copy of the add-on that is registered now, or None."""
    for cls in CLASSES:
        for c in _registered_versions(cls, everyone=True):
            if not _ours(c):
                return c.__module__.rsplit(".blender.", 1)[0]
    for handlers, fn in _handlers():
        for f in handlers:
            if getattr(f, "__qualname__", None) == fn.__qualname__ and not _ours(f) and \
                    (getattr(f, "__module__", None) or "").endswith(_SYNC_MODULES):
                return f.__module__.rsplit(".blender.", 1)[0]
    return None


class AlreadyRegistered(RuntimeError):
    pass


def is_registered() -> bool:
    """Whether this copy of the add-on (this or an earlier import of it) is registered."""
    return (any(_registered_versions(cls) for cls in CLASSES)
            or any(_same_function(f, fn) for handlers, fn in _handlers() for f in handlers))


def register() -> None:
    """Register the add-on; when it already is (e.g. registered twice), unregister it first.

    Another copy of the add-on registered in the same Blender (say the pip-installed package and
    the extension) is not replaced: registering raises :class:`AlreadyRegistered`, naming it."""
    other = _other_copy()
    if other is not None:
        raise AlreadyRegistered(
            f"Layered BRDF is already enabled from '{other}'; this copy ('{_package()}') was not "
            "registered. Disable the other copy first (Edit > Preferences > Add-ons, or its "
            "unregister()), then enable this one.")
    if is_registered():
        unregister()
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    setattr(bpy.types.Material, SETTINGS, PointerProperty(
        type=properties.LayeredBRDFSettings, name="Layered BRDF",
        description="Settings of the layered material (enums, backend, preset)"))
    for handlers, fn in _handlers():
        handlers.append(fn)
    freshness.uninstall(everyone=True)  # those a script's import of any copy installed
    freshness.install()


def unregister() -> None:
    """Remove this copy's handlers, timers, material property and classes (whichever import of it
    registered them); another copy's registration is left as it is."""
    for handlers, fn in _handlers():
        for f in [f for f in handlers if _same_function(f, fn)]:
            handlers.remove(f)
    freshness.uninstall()
    assets.cancel_queued()
    bake_jobs.stop()
    if _other_copy() is None and hasattr(bpy.types.Material, SETTINGS):
        delattr(bpy.types.Material, SETTINGS)
    for cls in reversed(CLASSES):
        for registered in _registered_versions(cls):
            bpy.utils.unregister_class(registered)
