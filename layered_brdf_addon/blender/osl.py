"""The OSL backend: the shader source as an internal text (it travels in the .blend)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

import bpy

from ..model.plan import EffectPlan
from . import paths
from ..model.spectral_tables import tables

OSL_VERSION = 1
OSL_PATH = Path(__file__).resolve().parents[2] / "osl" / "layered_brdf.osl"

THICKNESS_CODES = {"noise": 0, "height": 1, "constant": 2}
NORMAL_CODES = {"parallel": 0, "tilted": 1, "correlated": 2}


def defines(plan: EffectPlan) -> str:
    """Preprocessor lines selecting the compiled variant of the shader for ``plan``."""
    lines = [
        f"#define LAYERED_SPECULAR {int(plan.specular)}",
        f"#define LAYERED_DIFFUSE {int(plan.diffuse)}",
        f"#define LAYERED_THICKNESS {THICKNESS_CODES[plan.thickness]}",
        f"#define LAYERED_NORMALS {NORMAL_CODES[plan.normals]}",
        f"#define LAYERED_DISPERSION {int(plan.dispersion)}",
        f"#define LAYERED_LOBE {1 if plan.lobe == 'phong' else 0}",
        f"#define LAYERED_SPECTRAL {plan.spectral}",
        f"#define LAYERED_INTERFERENCE {int(plan.interference)}",
    ]
    if plan.spectral:
        lines += _spectral_defines(plan)
    return "\n".join(lines) + "\n"


def _spectral_defines(plan: EffectPlan) -> list[str]:
    """Baked tables and lobe groups of the spectral variant (as program.shade_spectral)."""
    from ..model import program

    t = tables(plan.spectral)
    groups, leads = program.spectral_groups(t["wavelengths"], plan.dispersion)
    lead = [leads.get(g, -1) for g in range(3)]

    def arr(values, fmt="{:.9g}"):
        return "{" + ", ".join(fmt.format(v) for v in values) + "}"

    return [
        f"#define LAYERED_SPECTRAL_3N {3 * plan.spectral}",
        f"#define LAYERED_SPECTRAL_LAMBDA {arr(t['wavelengths'])}",
        f"#define LAYERED_SPECTRAL_CAUCHY {arr([x for row in t['cauchy'] for x in row])}",
        f"#define LAYERED_SPECTRAL_RGB {arr([x for row in t['rgb'] for x in row])}",
        f"#define LAYERED_SPECTRAL_GROUP {arr(groups, '{:d}')}",
        f"#define LAYERED_SPECTRAL_LEAD {arr(lead, '{:d}')}",
    ]


def source(plan: EffectPlan) -> str:
    return f"// layered-brdf OSL v{OSL_VERSION}, variant {plan.key}\n" + defines(plan) + OSL_PATH.read_text()


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


def compile_script_node(node) -> None:
    """Compile ``node``'s script and create its sockets; raise with the compiler's message."""
    _ensure_oslquery()
    import addon_utils

    addon_utils.enable("cycles", default_set=False)
    from cycles import osl as cycles_osl

    errors = []

    def report(kind, message):
        if "ERROR" in kind:
            errors.append(message)

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
