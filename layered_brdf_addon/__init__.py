"""layered-brdf: iridescent layered materials (Granier & Heidrich 2003) for Blender.

``layered_brdf_addon.model`` is plain numpy; Blender code lives in
``layered_brdf_addon.blender`` and is imported only when Blender needs it.
"""

__version__ = "0.1.0"


def register():
    from .blender import registration  # needs bpy: loaded only when Blender registers the add-on
    registration.register()


def unregister():
    from .blender import registration  # needs bpy: loaded only when Blender registers the add-on
    registration.unregister()
