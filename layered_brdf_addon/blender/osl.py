"""The OSL shader in Blender: an internal text per plan (it travels in the .blend), compiled
into a Script node."""
from __future__ import annotations

import os
import sys

import bpy

from ..backends.osl_shader import shader_source
from ..model.plan import EffectPlan
from . import paths, tempdirs


def source(plan: EffectPlan) -> str:
    """The OSL shader for ``plan``, written from the shading program."""
    return shader_source(plan)


def text_for(plan: EffectPlan):
    """The internal text of the variant for ``plan``, created or refreshed."""
    name = f"layered_brdf_{plan.key}.osl"
    text = bpy.data.texts.get(name)
    src = source(plan)
    if text is None:
        text = bpy.data.texts.new(name)
    if text.as_string() != src:
        text.from_string(src)
    return text


def _ensure_oslquery():
    path = str(paths.osl_site_packages())
    if os.path.isdir(path) and path not in sys.path:
        sys.path.append(path)


_ensure_oslquery()  # before any Script node update runs Cycles' own compile callback


class OSLCompileError(RuntimeError):
    pass


def compile_script_node(node, script=None) -> None:
    """Compile ``node``'s script and create its sockets; raise with the compiler's message.

    With ``script`` (an internal text), assign it first: the assignment compiles too
    (Cycles' node update).  Cycles compiles an internal text into ``tmp*.osl``/``tmp*.oso``
    files of the temp folder and leaves the ``.oso``; here both compiles run in a private
    folder (:func:`.tempdirs.private_tempdir`) that is removed afterwards.  Nothing is
    ever written next to the add-on's own files.
    """
    _ensure_oslquery()
    import addon_utils

    addon_utils.enable("cycles", default_set=False)
    from cycles import osl as cycles_osl

    errors = []

    def report(kind, message):
        if "ERROR" in kind:
            errors.append(message)

    with tempdirs.private_tempdir("osl"):
        if script is not None:
            node.script = script
        ok = cycles_osl.update_script_node(node, report)
    if errors or ok is False:
        raise OSLCompileError("OSL compilation failed: " + "; ".join(errors or ["unknown error"]))


def scene_supports_osl(scene) -> tuple[bool, str]:
    """Whether ``scene`` will run Script nodes, and if not, why (Cycles drops them silently)."""
    if scene.render.engine != "CYCLES":
        return False, f"render engine is {scene.render.engine}: OSL needs Cycles"
    if not scene.cycles.shading_system:
        return False, "Cycles' Open Shading Language option is off"
    if scene.cycles.device == "GPU":
        prefs = bpy.context.preferences.addons.get("cycles")
        kind = getattr(prefs.preferences, "compute_device_type", "NONE") if prefs else "NONE"
        if kind != "OPTIX":
            return False, f"GPU device type {kind} cannot run OSL (CPU or OptiX only)"
    return True, ""
