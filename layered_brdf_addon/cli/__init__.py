"""The command line (``python -m layered_brdf_addon``, the ``layered-brdf`` script).

* :mod:`.commands`: the argument parser, the sub-commands and their exit codes;
* :mod:`.requests`: validating a render request from options or a job entry (no bpy);
* :mod:`.job_files`: reading TOML/JSON job files into requests (no bpy);
* :mod:`.runner`: running jobs in ``render`` subprocesses, serially or on Dask (no bpy);
* :mod:`.render_job`: the in-process render of ``render`` and ``gallery`` and the sidecar
  builder (bpy);
* :mod:`.gallery`: the paper's figures as one labelled contact sheet;
* :mod:`.staging`: atomic output staging and the interrupt guard (no bpy);
* :mod:`.codecs`: PNG and EXR reading and writing (no bpy);
* :mod:`.sidecar`: the sidecar's schema, writing and reading it (no bpy).
"""
from .commands import main

__all__ = ["main"]
