"""Markdown tables of the measured results (benchmarks/results/*.json) for the docs."""
from __future__ import annotations

import json
from pathlib import Path

HERE = Path(__file__).resolve().parent / "results"


def table(header, rows, markdown: bool = False) -> str:
    """A measured table: markdown for the docs, or columns aligned for a terminal."""
    rows = [tuple(map(str, r)) for r in rows]
    header = tuple(map(str, header))
    if markdown:
        return "\n".join(["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
                         + ["| " + " | ".join(r) + " |" for r in rows])
    widths = [max(len(x) for x in col) for col in zip(header, *rows)]
    return "\n".join("  ".join(x.ljust(w) for x, w in zip(r, widths)) for r in (header, *rows))


def accuracy_tables() -> str:
    d = json.loads((HERE / "accuracy.json").read_text())
    modes = d["accuracy"]["modes"]
    thr = d["throughput"]
    out = ["| mode | specular mean / p95 | diffuse mean / p95 | numpy specular evals/s |", "|---|---|---|---|"]
    for name, m in modes.items():
        t = thr.get(name, {}).get("specular", float("nan"))
        out.append(f"| {name} | {m['specular']['mean']:.2f} / {m['specular']['p95']:.2f} | "
                   f"{m['diffuse']['mean']:.2f} / {m['diffuse']['p95']:.2f} | {t:,.0f} |")
    out += ["", "| closure level | vs 1 nm ground truth, mean / p95 | vs exact RGB model, mean / p95 | evals/s |",
            "|---|---|---|---|"]
    for name, lv in d["accuracy"]["closure_levels"].items():
        g, r = lv["vs_ground_truth"]["all"], lv["vs_rgb_exact"]["all"]
        t = thr.get(name, {}).get("specular", float("nan"))
        rate = f"{t:,.0f}" if t == t else ""  # no throughput measured: NaN
        out.append(f"| {name} | {g['mean']:.2f} / {g['p95']:.2f} | {r['mean']:.2f} / {r['p95']:.2f} | {rate} |")
    return "\n".join(out)


def cost_table() -> str:
    d = json.loads((HERE / "render_cost.json").read_text())
    rows = d["rows"]
    by = {(r.get("preset"), r.get("backend"), r.get("lobe"), r.get("which")): r for r in rows
          if r.get("which") != "mode"}
    out = [f"{d['size']} px sphere, {d.get('threads', 1)} thread, cost per sample from {d['samples'][0]} and "
           f"{d['samples'][1]} samples", "",
           "| configuration | backend | ms / sample | x Principled + Thin Film | planning saves |", "|---|---|---|---|---|"]
    modes = [r for r in rows if r.get("which") == "mode"]
    rows = [r for r in rows if r.get("which") != "mode"]
    for r in rows:
        saving = ""
        if r.get("which") == "planned":
            full = by[(r["preset"], r["backend"], r["lobe"], "full")]
            saving = f"{1.0 - r['per_sample'] / full['per_sample']:.0%}"
        lobe = f" ({r['lobe']})" if r.get("lobe") else ""
        out.append(f"| {r['config']} | {r['backend']}{lobe} | {1000 * r['per_sample']:.2f} | "
                   f"{r['vs_principled']:.1f} | {saving} |")
    if modes:
        out += ["", "| accuracy mode | backend | ms / sample | x RGB node group | x Principled + Thin Film |",
                "|---|---|---|---|---|"]
        for r in modes:
            out.append(f"| {r['config']} | {r['backend']} | {1000 * r['per_sample']:.2f} | {r['vs_rgb_nodes']:.2f} | "
                       f"{r['vs_principled']:.1f} |")
    return "\n".join(out)


def scene_modes_table(preset: str = "fig4_parallel") -> str:
    """Cost per sample of ``preset`` in every accuracy mode and backend on the realistic scene
    (``scene_cost.json``): against the same backend's RGB group and Principled + Thin Film."""
    d = json.loads((HERE / "scene_cost.json").read_text())
    rows = [r for r in d["cycles"] if r.get("preset") == preset]
    rgb = {r["backend"]: r["per_sample"]["median"] for r in rows if r["accuracy"] == "rgb"}
    out = ["| accuracy mode | backend | nodes interpreted | ms / sample | x its RGB | x Principled + Thin Film |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        ms = r["per_sample"]["median"]
        nodes = f"{r['nodes']:,}" if r.get("nodes") is not None else ""
        out.append(f"| {r['accuracy']} | {r['backend']} | {nodes} | {ms * 1e3:.0f} | {ms / rgb[r['backend']]:.2f} | "
                   f"{r['vs_reference']:.2f} |")
    return "\n".join(out)


def scene_presets_table() -> str:
    """Cost per sample of each preset in its own accuracy mode on the realistic scene (``scene_cost.json``):
    the node group reading baked tables, the group computing, OSL; against Principled + Thin Film, with
    the tables' bake time and size."""
    from layered_brdf_addon.model.presets import preset

    d = json.loads((HERE / "scene_cost.json").read_text())
    rows = {}
    for r in d["cycles"]:
        name = r.get("preset")
        if name and r["accuracy"] == preset(name).accuracy and r.get("optics") == preset(name).optics:
            rows.setdefault(name, {})[r["backend"]] = r
    out = ["| preset | accuracy | tables: nodes, x P+TF | computed: nodes, x P+TF | OSL tables: x P+TF "
           "| OSL computed: x P+TF | bake (ms) | tables (kB) |", "|---|---|---|---|---|---|---|---|"]
    for name, by in rows.items():
        t, n, ot, o = by.get("tables"), by.get("nodes"), by.get("osl-tables"), by.get("osl")
        baked = t is not None and t.get("bake_ms") is not None
        cells = [name, preset(name).accuracy]
        for r in (t, n):
            cells.append("" if r is None else f"{r['nodes']:,}, {r['vs_reference']:.2f}")
        if t is not None and not baked:
            cells[2] = f"computes ({cells[2]})"
        for r in (ot, o):
            cells.append("" if r is None else f"{r['vs_reference']:.2f}")
        cells.append(f"{t['bake_ms']:.1f}" if baked else "")
        cells.append(f"{t['table_bytes'] / 1024:.0f}" if baked else "")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


if __name__ == "__main__":
    print(accuracy_tables())
    print()
    print(cost_table())

