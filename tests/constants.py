"""Constants shared by the render tests: suns, tolerances, masks."""
from __future__ import annotations

import numpy as np

from layered_brdf_addon.model.sphere import Sun


def sun_at(degrees: float, strength: float = 1.0) -> Sun:
    """A sun ``degrees`` off the view (the camera looks along +y), tilted up towards +z."""
    a = np.radians(degrees)
    return Sun(direction=(0.0, -np.cos(a), np.sin(a)), strength=strength)


# 40 degrees off the view, above it: spheres in a row along x never shadow each other.
SUN_40 = sun_at(40.0)
# Past 90 degrees: the sun lights the spheres from behind, grazing the visible rim.
SUN_GRAZING = sun_at(100.0)

# Renders vs numpy: a pixel fails when a channel is off by more than REL_TOL (plus a small
# floor); at most MAX_FAILING of the masked pixels may fail.
REL_TOL = 0.02            # shaders vs the closure form
REL_TOL_DIFFUSE = 0.01    # a diffuse-only sphere vs the reference
MAX_FAILING = 0.01
REL_TOL_COARSE = 0.05     # many presets or hard parameters in one image
MAX_FAILING_COARSE = 0.02
# lit_mask's cosine threshold for hard cases (grazing suns light only a thin crescent).
LIT_THRESHOLD_GRAZING = 0.05
# The numpy twin of a Cycles render under an HDRI (fit/environment.py) vs the render, 64 px at
# 256 samples: mean CIEDE2000 over the sphere.  Measured 0.46-0.74 at 96 px, mostly the
# render's noise.
ENVIRONMENT_TWIN_DELTA_E = 1.0
