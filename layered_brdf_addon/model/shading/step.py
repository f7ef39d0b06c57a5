"""The mark of the shading program's named steps, :func:`shader_function`.

A backend's ``ops.function`` runs a step: numpy and the node backend inline it, the OSL
backend emits it once as an OSL function of the same name and calls it.
"""
from __future__ import annotations

import functools


def shader_function(fn):
    """Mark ``fn(ops, *values, **settings)`` as a named step of the program.

    Values are backend scalars or vectors (or Python constants); keyword-only settings
    are Python values that select a variant.  A backend's ``ops.function`` runs it: numpy
    and the node backend inline it, the OSL backend emits an OSL function once and calls it.
    """
    @functools.wraps(fn)
    def step(ops, *values, **settings):
        return ops.function(fn, values, settings)

    step.program_step = fn
    return step
