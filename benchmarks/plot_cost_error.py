"""Error vs cost plot from benchmarks/results/accuracy.json and the render costs of
benchmarks/results/scene_cost.json (the realistic scene; render_cost.json, the reference
sphere, where it is missing).

Left: the numpy evaluation of each mode (RGB and spectral N), cost relative to RGB,
mean CIEDE2000 of the specular part to the 1 nm ground truth.  Right: the Cycles
shaders (RGB; node group and OSL, Beckmann and Phong lobes), render cost per sample
relative to Principled BSDF + Thin Film, mean CIEDE2000 of their closure form.
The Pareto front (no other point both cheaper and more accurate) is drawn.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).resolve().parent
OUT = HERE.parent / "docs" / "images" / "cost_vs_error.png"


def pareto(points):
    """Indices of the points on the lower-left front (cost, error)."""
    order = sorted(range(len(points)), key=lambda k: (points[k][0], points[k][1]))
    front, best = [], float("inf")
    for k in order:
        if points[k][1] < best:
            front.append(k)
            best = points[k][1]
    return front


def load():
    acc = json.loads((HERE / "results" / "accuracy.json").read_text())
    scene = HERE / "results" / "scene_cost.json"
    cost = json.loads(scene.read_text()) if scene.exists() else None
    modes = acc["accuracy"]["modes"]
    thr = acc["throughput"]
    rgb_key = next(k for k in modes if k.startswith("RGB"))
    numpy_pts = []
    names = [rgb_key] + [k for k in modes if k.startswith("analytic")] + ["spectral 4", "spectral 8", "spectral 16",
                                                                         "spectral 32"]
    for name in names:
        numpy_pts.append((thr[rgb_key]["specular"] / thr[name]["specular"], modes[name]["specular"]["mean"],
                          name.split(" (")[0]))
    levels = acc["accuracy"]["closure_levels"]
    shader_pts = []

    def mode_point(ratio, backend, mode):
        """(cost ratio, mean CIEDE2000 of the mode's closure form, label), or None."""
        level = {"rgb": "closure form (beckmann)", "analytic": "closure form (beckmann), analytic"}.get(
            mode, f"closure form (beckmann), spectral {mode[len('spectral'):]}")
        if level not in levels:
            return None
        label = f"{backend} {'RGB' if mode == 'rgb' else mode.replace('spectral', 'spectral ')}"
        return ratio, levels[level]["vs_ground_truth"]["all"]["mean"], label

    if cost is not None:  # the realistic scene: fig6_medium in every accuracy mode, both backends
        points = [mode_point(r["vs_reference"], r["backend"], r["accuracy"]) for r in cost["cycles"]
                  if r.get("preset") == "fig6_medium" and r.get("backend") in ("nodes", "osl")]
        return numpy_pts, [p for p in points if p is not None]
    cost = json.loads((HERE / "results" / "render_cost.json").read_text())
    mode_rows = [r for r in cost["rows"] if r.get("which") == "mode"]
    if mode_rows:
        points = [mode_point(r["vs_principled"], r["backend"], r["mode"]) for r in mode_rows]
        shader_pts = [p for p in points if p is not None]
    else:
        for backend, lobe, level in (("nodes", "beckmann", "closure form (beckmann)"),
                                     ("osl", "beckmann", "closure form (beckmann)"),
                                     ("osl", "phong", "closure form (phong)")):
            rows = [r for r in cost["rows"] if r.get("backend") == backend and r.get("lobe") == lobe
                    and r.get("which") == "planned"]
            if rows:
                ratio = sum(r["vs_principled"] for r in rows) / len(rows)
                shader_pts.append((ratio, levels[level]["vs_ground_truth"]["all"]["mean"], f"{backend} {lobe}"))
    return numpy_pts, shader_pts


def main():
    numpy_pts, shader_pts = load()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, pts, xlabel, title in (
            (axes[0], numpy_pts, "numpy cost per evaluation (x RGB)", "numpy reference: RGB vs analytic vs spectral"),
            (axes[1], shader_pts, "render cost per sample (x Principled + Thin Film)", "Cycles shaders (Fig. 6 medium)")):
        xs, ys = [p[0] for p in pts], [p[1] for p in pts]
        ax.scatter(xs, ys, color="tab:blue", zorder=3)
        for x, y, label in pts:
            ax.annotate(label, (x, y), textcoords="offset points", xytext=(5, 5), fontsize=8)
        # One front per backend where there are several (the node group is the only backend for
        # GPUs without OptiX and for EEVEE, so its own front matters).
        backends = sorted({label.split(" ")[0] for _, _, label in pts}) if ax is axes[1] else [None]
        for colour, backend in zip(("tab:orange", "tab:green"), backends):
            sub = [q for q in pts if backend is None or q[2].split(" ")[0] == backend]
            front = pareto(sub)
            ax.plot([sub[k][0] for k in front], [sub[k][1] for k in front], "--", color=colour,
                    label="Pareto front" + (f" ({backend})" if backend else ""), zorder=2)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("mean CIEDE2000 to 1 nm ground truth")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    tmp = OUT.with_name(".cost_vs_error.partial.png")
    fig.savefig(tmp, dpi=120)
    os.replace(tmp, OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
