"""Fitting a layered material to a target: a render, a Principled BSDF material, a
reflectance table (``layered-brdf fit``, the panel's *Fit to Render...*).

The model fitted is the closure form, what the node group and the OSL shader render,
evaluated by the numpy backend of the shading program: a target rendered by Cycles is
matched by what Cycles will render from the fitted parameters.  A reflectance table is
matched by the film's mirror reflection (the amplitude step of the same program).

Numpy alone (its own bounded least squares, :mod:`.least_squares`, and CIELAB/CIEDE2000 with
the CIE tables baked, :mod:`.colour_space`), so it runs in Blender's own Python; imports no bpy.
"""
