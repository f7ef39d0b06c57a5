"""What keeping renders fresh costs (blender/freshness.py): the three handlers timed over a file of N layered
materials with baked tables that nothing changed, in thread CPU time (the machine may be shared), the
median of repeated calls; and what an edit costs the material it touched.

    python benchmarks/freshness_cost.py [--materials 100] [--reps 50] [--json OUT.json]
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
from types import SimpleNamespace


def _cpu_ms(fn, reps: int) -> float:
    times = []
    for _ in range(reps):
        t = time.thread_time()
        fn()
        times.append(1000.0 * (time.thread_time() - t))
    return statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--materials", type=int, default=100, help="layered materials in the file (default 100)")
    ap.add_argument("--reps", type=int, default=50, help="calls per handler (default 50)")
    ap.add_argument("--json", help="write the table here as JSON")
    args = ap.parse_args(argv)

    import bpy

    from layered_brdf_addon.blender import freshness
    from layered_brdf_addon.blender.material import apply_layered_material, shader_node
    from layered_brdf_addon.blender.scene import reset_blender
    from layered_brdf_addon.model import preset

    reset_blender()
    t = time.perf_counter()
    mats = [apply_layered_material(bpy.data.materials.new(f"M{k}"), preset("oil_slick").replace(ks=0.3 + 0.001 * k))
            for k in range(args.materials)]
    build_s = time.perf_counter() - t
    scene = bpy.context.scene
    keyed = mats[0]
    rows = {
        "frame change, nothing animated": _cpu_ms(lambda: freshness.on_frame_change(scene), args.reps),
        "edit of one material (unchanged)": _cpu_ms(
            lambda: freshness.after_edit(scene, SimpleNamespace(mode="VIEWPORT", updates=[SimpleNamespace(id=keyed)])),
            args.reps),
        "before a render (every material)": _cpu_ms(lambda: freshness.before_render(scene), max(3, args.reps // 10)),
    }
    sock = shader_node(keyed).inputs["Thickness Min"]
    keyed.node_tree.keyframe_insert(sock.path_from_id("default_value"), frame=1)
    freshness.before_render(scene)
    rows["frame change, one material keyed"] = _cpu_ms(lambda: freshness.on_frame_change(scene), args.reps)
    per_100 = {k: v * 100.0 / args.materials for k, v in rows.items()}
    print(f"{args.materials} layered materials with baked tables, built in {build_s:.1f} s; thread CPU time, "
          f"median of {args.reps} calls")
    print("| handler | ms per call | ms per call per 100 materials |")
    print("| --- | ---: | ---: |")
    for k, v in rows.items():
        print(f"| {k} | {v:.3f} | {per_100[k]:.3f} |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"materials": args.materials, "reps": args.reps, "ms": rows}, f, indent=1)
    freshness.uninstall()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
