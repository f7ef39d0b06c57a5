"""Test oracles of layered-brdf: what a render should look like, computed in numpy.

* :mod:`.exact_model`: the exact layered BRDF of Granier & Heidrich (2003) in every
  accuracy mode, what the shaders approximate; :mod:`.exact_spheres`: it on the reference
  scene's spheres;
* :mod:`.spectral`: the 1 nm spectral ground truth (colour-science) and the writer of the
  shaders' baked spectral tables;
* :mod:`.closures`: the numpy twin of Cycles' evaluation of the closures the shaders
  return (the *closure form*), to predict renders pixel by pixel;
* :mod:`.lighting`: Monte-Carlo integration of the model under an environment or an
  area light;
* :mod:`.compare`: agreement metrics between rendered and expected pixels.

Used by the tests and the benchmarks only; not part of the Blender extension (the
manifest packs ``layered_brdf_addon/``, ``node_groups/`` and ``osl/``).  Imports run
one way: this package uses :mod:`layered_brdf_addon.model`, never the reverse.
"""
