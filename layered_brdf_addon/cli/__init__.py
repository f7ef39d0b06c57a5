"""The command line (``python -m layered_brdf_addon``, the ``layered-brdf`` script).

* :mod:`.commands`: the argument parser, the sub-commands and their exit codes;
* :mod:`.option_table`: every command's options, declared once (:mod:`.option_spec`: one option;
  ``fit``'s in :mod:`.fit_options`; docs/options.md made by :mod:`.option_docs`) (no bpy);
* :mod:`.options`: the parameters' options, the exit codes, Blender's output;
* :mod:`.option_values`: the values an option may take, checked (no bpy);
* :mod:`.input_files`: reading params files, job files, tables and .blend headers (no bpy);
* :mod:`.requests`: validating a render request from options or a job entry (no bpy);
  :mod:`.batch_request` and :mod:`.fit_request` the same for ``batch`` and ``fit``;
* :mod:`.job_files`: reading TOML/JSON job files into requests (no bpy);
* :mod:`.runner`: running jobs in ``render`` subprocesses, serially or on Dask (no bpy);
* :mod:`.render_job`: the in-process render of ``render`` and ``gallery`` and the sidecar
  builder (bpy);
* :mod:`.gallery`: the paper's figures as one labelled contact sheet;
* :mod:`.lookdev`: every preset on the look-dev shader ball, one labelled sheet;
* :mod:`.fit_command`: ``fit``, with its targets (:mod:`.fit_targets`) and its outputs
  (:mod:`.fit_outputs`).

Files in and out (staging, codecs, sidecars) are the bpy-free :mod:`layered_brdf_addon.io`'s.
"""
from __future__ import annotations

from typing import Sequence

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m layered_brdf_addon`` and ``layered-brdf``: :func:`.commands.main`."""
    # Loaded on the call: the add-on imports modules of this package in Blender (staging, sidecar,
    # codecs), which then leave the sub-commands unloaded.
    from .commands import main as run

    return run(argv)
