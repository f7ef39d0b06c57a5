"""Helpers the render benchmarks share: timed renders, cost per sample, statistics,
Blender's stock materials and a description of the machine."""
from __future__ import annotations

import os
import platform
import statistics
import time


def timed_render(scene=None) -> tuple[float, float]:
    """Render the scene's camera once; returns (process CPU seconds, wall seconds).

    With one render thread the process CPU time is the render's own work, much less
    disturbed than wall time by other jobs on a shared machine."""
    import bpy

    scene = scene or bpy.context.scene
    c0, w0 = time.process_time(), time.perf_counter()
    bpy.ops.render.render(write_still=False, scene=scene.name)
    return time.process_time() - c0, time.perf_counter() - w0


def cost_per_sample(t_lo: float, t_hi: float, n_lo: int, n_hi: int) -> float:
    """Seconds per sample from renders at two sample counts: what does not depend on the
    sample count (scene sync, BVH, shader compilation) cancels."""
    return (t_hi - t_lo) / (n_hi - n_lo)


def spread(values) -> dict:
    """min / median / max of a list of measurements (and the values themselves)."""
    values = list(values)
    return dict(min=min(values), median=statistics.median(values), max=max(values), n=len(values))


def machine_info() -> dict:
    """CPU count, platform, Python and Blender versions, and the date of the run."""
    import bpy

    return dict(cpu_count=os.cpu_count(), machine=platform.machine(), processor=platform.processor(),
                platform=platform.platform(), python=platform.python_version(),
                bpy=bpy.app.version_string, date=time.strftime("%Y-%m-%d %H:%M:%S %z"))


def stock_material(name: str, bsdf: str, inputs: dict | None = None):
    """A material with one of Blender's BSDF nodes (``bsdf``, its bl_idname) to the output,
    ``inputs`` the node's socket values by name."""
    import bpy

    mat = bpy.data.materials.new(name)
    nt = mat.node_tree
    nt.nodes.clear()
    node = nt.nodes.new(bsdf)
    for key, value in (inputs or {}).items():
        node.inputs[key].default_value = value
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


PRINCIPLED = "ShaderNodeBsdfPrincipled"
DIFFUSE = "ShaderNodeBsdfDiffuse"
GLOSSY = "ShaderNodeBsdfGlossy"


def thin_film_inputs(thickness: float, ior: float = 1.33, roughness: float | None = None) -> dict:
    """Principled BSDF socket values for its Thin Film."""
    d = {"Thin Film Thickness": thickness, "Thin Film IOR": ior}
    if roughness is not None:
        d["Roughness"] = roughness
    return d
