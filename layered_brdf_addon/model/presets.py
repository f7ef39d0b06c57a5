"""Named materials: the paper's figures, artist presets and structural colour (film stacks), as data.

Each preset is a mapping of overrides on :class:`LayeredParams` defaults.
"""
from __future__ import annotations

from .media import layer_ior_values
from .params import LayeredParams, ParameterError
from .stack_presets import STACK_LABELS, STACK_PRESETS

__all__ = ["ARTIST_PRESETS", "PAPER_PRESETS", "PRESETS", "PRESET_LABELS", "STACK_PRESETS", "preset", "preset_label"]

PAPER_PRESETS: dict[str, dict] = {
    # Fig. 3: the diffuse part with thickness from Perlin noise.
    "fig3_old_metal": dict(r1_r=1.5, r1_g=1.5, r1_b=1.5, d_min=1.0, d_max=30.0, ks=0.0, kd=1.0,
                           base_r=0.55, base_g=0.5, base_b=0.45),
    "fig3_thin_film": dict(r1_r=1.3, r1_g=1.3, r1_b=1.3, d_min=1.0, d_max=210.0, ks=0.0, kd=1.0),
    "fig3_clay": dict(r1_r=1.4, r1_g=1.4, r1_b=1.4, d_min=67.0, d_max=73.0, ks=0.0, kd=1.0,
                      base_r=0.75, base_g=0.45, base_b=0.3),
    # Fig. 4: normal variation, parallel vs constant 10 degree deviation.
    "fig4_parallel": dict(e0=90.0, e1=170.0, r1_r=1.4, r1_g=1.45, r1_b=1.6, d_min=66.0, d_max=76.0,
                          ks=1.0, kd=0.7, normal_mode="parallel"),
    "fig4_tilted": dict(e0=90.0, e1=170.0, r1_r=1.4, r1_g=1.45, r1_b=1.6, d_min=66.0, d_max=76.0,
                        ks=1.0, kd=0.7, normal_mode="tilted", tilt=10.0),
    # Fig. 5: lower normal correlated with thickness (the paper gives no values; these are ours).
    "fig5_correlated": dict(e0=150.0, e1=250.0, r1_r=1.4, r1_g=1.5, r1_b=1.7, d_min=100.0, d_max=400.0,
                            ks=1.0, kd=0.0, normal_mode="correlated", bump_strength=1.0e-4,
                            noise_scale=3.0),
    # Fig. 6: specular and diffuse, 14 degree deviation, three thickness ranges.
    "fig6_thin": dict(r1_r=1.5, r1_g=1.6, r1_b=1.8, normal_mode="tilted", tilt=14.0, e0=130.0, e1=130.0,
                      ks=1.0, kd=0.5, d_min=1.0, d_max=30.0),
    "fig6_medium": dict(r1_r=1.5, r1_g=1.6, r1_b=1.8, normal_mode="tilted", tilt=14.0, e0=130.0, e1=130.0,
                        ks=1.0, kd=0.5, d_min=79.0, d_max=106.0),
    "fig6_thick": dict(r1_r=1.5, r1_g=1.6, r1_b=1.8, normal_mode="tilted", tilt=14.0, e0=130.0, e1=130.0,
                       ks=1.0, kd=0.5, d_min=146.0, d_max=200.0),
}

ARTIST_PRESETS: dict[str, dict] = {
    # Physical films (optics="physical": thin-film optics, measured media of model/data/media.json),
    # tuned and guarded under Blender's bundled forest, courtyard and interior HDRIs (docs/looks.md).
    # Each film is conformal, its lower boundary as rough as its upper one: e1 = e0 r1^2, so that
    # the transmitted lobe, seen from outside (exponent e1 / r1^2), is as sharp as the reflection
    # and the beams interfere where they coincide (docs/physical-optics.md).
    # A soap film (water) with air on both sides: it reflects a few percent, in colours that run
    # through the interference orders as it thickens downwards; the rest passes to the transparent
    # base, so the background shows through.
    "soap_bubble": dict(optics="physical", lower_medium="air", **layer_ior_values("water"), d_min=150.0,
                        d_max=900.0, thickness_mode="height", e0=3000.0, e1=5350.0, ks=1.0, kd=0.0, base_r=0.0,
                        base_g=0.0, base_b=0.0, base_layer="transparent"),
    # An oil film on water, over a dark wet base: a wide range of thickness in large, soft swirls.
    "oil_slick": dict(optics="physical", lower_medium="water", **layer_ior_values("oil"), d_min=100.0,
                      d_max=600.0, noise_scale=1.2, noise_detail=3.0, e0=1500.0, e1=3210.0, ks=1.0, kd=0.3,
                      base_r=0.01, base_g=0.01, base_b=0.012),
    # A jewel beetle's cuticle: a chitin-like film over air (the cuticle's lamellae), thick enough
    # for second-order green, over a dark, melanised base.
    "beetle_shell": dict(optics="physical", lower_medium="air", **layer_ior_values("chitin"), d_min=250.0,
                         d_max=290.0, e0=800.0, e1=1960.0, ks=1.0, kd=0.3, base_r=0.01, base_g=0.02,
                         base_b=0.015),
    # Anodised titanium: amorphous TiO2 on titanium (the metal is the film's lower boundary), the
    # anodising sequence from gold (thinnest) through purple to blue.
    "anodised_titanium": dict(optics="physical", lower_medium="titanium", **layer_ior_values("tio2_amorphous"),
                              d_min=25.0, d_max=75.0, noise_scale=1.2, e0=800.0, e1=4860.0, ks=1.0, kd=0.0,
                              base_layer="metal", base_r=0.22, base_g=0.21, base_b=0.2),
    # Copper (bronze) under patchy oxide films of high index (cuprite-like, 2.4-2.7), 0-120 nm.
    "old_metal": dict(optics="physical", lower_medium="copper", layer_index="ior", layer_ior=2.44,
                      layer_dispersion=3.0, d_min=0.0,
                      d_max=120.0, noise_scale=3.0, noise_detail=3.0, noise_roughness=0.6, e0=200.0, e1=1250.0,
                      ks=1.0, kd=0.0, base_layer="metal", base_r=0.45, base_g=0.3, base_b=0.15),
    # Terracotta under a thin glassy glaze (BK7-like) over an alumina-rich body: the glaze warms the
    # body and tints the reflections.
    "glazed_clay": dict(optics="physical", lower_medium="alumina", **layer_ior_values("glass"), d_min=60.0,
                        d_max=95.0, noise_scale=2.0, e0=1500.0, e1=3470.0, ks=1.0, kd=0.4, base_r=0.5,
                        base_g=0.2, base_b=0.1),
}

# The paper's figures keep the paper's colour model (three wavelengths as R, G, B); new
# materials and the artist presets use the analytic mode, the default.
for _overrides in PAPER_PRESETS.values():
    _overrides.setdefault("accuracy", "rgb")

PRESETS: dict[str, dict] = {**PAPER_PRESETS, **ARTIST_PRESETS, **STACK_PRESETS}


PRESET_LABELS: dict[str, str] = {
    "fig3_old_metal": "Fig. 3 old metal", "fig3_thin_film": "Fig. 3 thin film", "fig3_clay": "Fig. 3 clay",
    "fig4_parallel": "Fig. 4 parallel boundaries", "fig4_tilted": "Fig. 4 tilted boundary",
    "fig5_correlated": "Fig. 5 boundary follows thickness", "fig6_thin": "Fig. 6 thin layer",
    "fig6_medium": "Fig. 6 medium layer", "fig6_thick": "Fig. 6 thick layer",
    "soap_bubble": "Soap bubble", "oil_slick": "Oil slick", "beetle_shell": "Beetle shell",
    "anodised_titanium": "Anodised titanium", "old_metal": "Old metal", "glazed_clay": "Glazed clay",
    **STACK_LABELS,
}


def preset_label(name: str) -> str:
    """The preset's name for people (menus, previews)."""
    return PRESET_LABELS.get(name, name.replace("_", " ").capitalize())


def preset(name: str) -> LayeredParams:
    """The validated parameters of a named preset."""
    if name not in PRESETS:
        raise ParameterError("preset", name, "one of " + ", ".join(sorted(PRESETS)))
    return LayeredParams.from_dict(PRESETS[name])
