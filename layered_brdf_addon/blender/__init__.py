"""Blender layer: thin functions over the bpy-free core (``layered_brdf_addon.model``)."""
