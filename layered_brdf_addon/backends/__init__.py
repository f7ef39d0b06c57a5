"""The shading program's shader backends: the node group (bpy) and the OSL source (bpy-free).

They import the bpy-free core (``..model``); the Blender layer imports them.
"""
