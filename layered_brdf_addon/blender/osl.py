"""The OSL shader in Blender: an internal text (it travels in the .blend), compiled into a Script
node.  A plan that computes its closures has one text for every material of that plan; a plan with
tables has one per set of values, holding the tables baked for them (:mod:`.tables`), shared by the
materials of those values and stamped with their digest."""
from __future__ import annotations

import hashlib
import inspect
import os
import sys
import zlib

import bpy

from ..backends import osl_ops, osl_shader, osl_text
from ..backends.node_group import code_without_docs
from ..backends.osl_shader import shader_source, tabulated_shader_source
from ..model.params import LayeredParams
from ..model.plan import EffectPlan
from ..model.table_check import checked_bake
from . import bake_jobs, paths, tempdirs
from .stored_keys import TEXT_KEY
from .tables import SETTINGS_KEY, settings_json, wanted_digest

TABLES_KEY = "layered_brdf_osl_tables"  # on a text holding baked tables: the digest of what they were baked for
SOURCE_CRC_KEY = "layered_brdf_osl_crc"  # on such a text: checksum of the source written into it


def source(plan: EffectPlan) -> str:
    """The OSL shader for ``plan`` computing its closures, written from the shading program."""
    return shader_source(plan)


_WRITER_STAMP = None


def _writer_stamp() -> str:
    """Digest of the code that writes OSL (the program itself is in the tables' stamp)."""
    global _WRITER_STAMP
    if _WRITER_STAMP is None:
        h = hashlib.sha1()
        for module in (osl_shader, osl_ops, osl_text):
            h.update(code_without_docs(inspect.getsource(module)).encode())
        _WRITER_STAMP = h.hexdigest()[:8]
    return _WRITER_STAMP


def tables_digest(params: LayeredParams, plan: EffectPlan) -> str:
    """The stamp of a text holding the tables of ``params`` for ``plan``, written by this version."""
    return f"osl{osl_shader.OSL_VERSION}:{_writer_stamp()}:{wanted_digest(params, plan)}"


def _crc(src: str) -> str:
    return f"{zlib.crc32(src.encode()):08x}"


def text_intact(text) -> bool:
    """Whether a text holding tables still holds the source written into it (not edited by hand)."""
    return text.get(SOURCE_CRC_KEY) == _crc(text.as_string())


def text_current(text, params: LayeredParams, plan: EffectPlan, check_sources: bool = True) -> bool:
    """Whether ``text`` is the shader a build for ``plan`` and ``params`` writes (its source read back only
    with ``check_sources``)."""
    if text is None:
        return False
    if not plan.tables:
        return TABLES_KEY not in text and (not check_sources or text.as_string() == source(plan))
    return text.get(TABLES_KEY) == tables_digest(params, plan) and (not check_sources or text_intact(text))


def text_for(plan: EffectPlan, params: LayeredParams | None = None):
    """The internal text of the shader for ``plan`` (and, for a plan with tables, the values ``params``),
    created or refreshed; stamped as the add-on's."""
    if plan.tables:
        return _tables_text(plan, params or LayeredParams())
    name = f"layered_brdf_{plan.key}.osl"
    text = bpy.data.texts.get(name)
    src = source(plan)
    if text is None or text.library is not None:
        text = bpy.data.texts.new(name)
    if text.as_string() != src:
        text.from_string(src)
    text[TEXT_KEY] = True
    return text


def _tables_text(plan: EffectPlan, params: LayeredParams):
    """A text of this plan and these values: one already written (intact), or a new one with the tables baked."""
    digest = tables_digest(params, plan)
    for text in bpy.data.texts:
        if text.library is None and text.get(TABLES_KEY) == digest and text_intact(text):
            return text
    layout, texels, _ = checked_bake(params, plan)  # the bake its plan was checked with
    src = tabulated_shader_source(plan, layout, texels)
    text = bpy.data.texts.new(f"layered_brdf_{plan.key}_{digest[-8:]}.osl")
    text.from_string(src)
    text[TEXT_KEY] = True
    text[TABLES_KEY] = digest
    text[SETTINGS_KEY] = settings_json(params)  # what a copy of a node running it takes (.freshness)
    text[SOURCE_CRC_KEY] = _crc(src)
    return text


def ensure_text(node, params: LayeredParams, plan: EffectPlan, check_sources: bool = True) -> bool:
    """Give the Script ``node`` the text for ``plan`` and ``params`` (compiled); True when it changed."""
    if text_current(node.script, params, plan, check_sources):
        return False
    if plan.tables and bake_jobs.deferring(plan) and bake_jobs.start(params, plan, str(node.as_pointer())):
        return False  # baked beside the interface (.bake_jobs): the node keeps its text until they are done
    compile_script_node(node, script=text_for(plan, params))
    return True


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
