"""The bpy-free core: the layered BRDF, parameters, presets, the shading program and the effect policy."""
from .brdf import (average_refracted_cosine, diffuse_rd, diffuse_rho, diffuse_td, fresnel_f0, layered_brdf,
                   phong_lobe, schlick, specular_brdf, specular_terms, transmission_factor)
from .geometry import correlated_normal, reflect, refract, safe_normalize, tilted_normal
from .params import PARAM_SPECS, WAVELENGTHS_NM, LayeredParams, ParameterError, ParamSpec
from .presets import ARTIST_PRESETS, PAPER_PRESETS, PRESETS, preset
from .sphere import OrthoCamera, Sun, render_spheres, sphere_geometry

__all__ = [
    "average_refracted_cosine", "diffuse_rd", "diffuse_rho", "diffuse_td", "fresnel_f0", "layered_brdf",
    "phong_lobe", "schlick", "specular_brdf", "specular_terms", "transmission_factor", "correlated_normal",
    "reflect", "refract", "safe_normalize", "tilted_normal", "PARAM_SPECS", "WAVELENGTHS_NM", "LayeredParams",
    "ParameterError", "ParamSpec", "ARTIST_PRESETS", "PAPER_PRESETS", "PRESETS", "preset", "OrthoCamera", "Sun",
    "render_spheres", "sphere_geometry",
]
