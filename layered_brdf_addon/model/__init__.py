"""The bpy-free core: parameters, presets, the shading program and its numpy backend, the effect
policy, and the expected pixels of the reference scene's spheres.

The exact layered BRDF that the shaders approximate and the spectral ground truth are test
oracles, not part of the core: ``layered_brdf_reference.exact_model`` and
``layered_brdf_reference.spectral``.
"""
from .geometry import correlated_normal, reflect, refract, safe_normalize, tilted_normal
from .params import PARAM_SPECS, WAVELENGTHS_NM, LayeredParams, ParameterError, ParamSpec
from .presets import ARTIST_PRESETS, PAPER_PRESETS, PRESETS, preset
from .sphere import OrthoCamera, Sun, render_spheres, sphere_geometry

__all__ = [
    "correlated_normal", "reflect", "refract", "safe_normalize", "tilted_normal", "PARAM_SPECS", "WAVELENGTHS_NM",
    "LayeredParams", "ParameterError", "ParamSpec", "ARTIST_PRESETS", "PAPER_PRESETS", "PRESETS", "preset",
    "OrthoCamera", "Sun", "render_spheres", "sphere_geometry",
]
