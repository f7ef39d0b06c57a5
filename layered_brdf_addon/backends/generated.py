"""The generated files checked into the repository, and the command that writes them.

``osl/layered_brdf.osl`` is the OSL shader of the default material's plan, and
``node_groups/layered_brdf_<plan>.json`` describes the node group of the same plan (every
node, its settings, constant inputs and links), so that a change to the shading program
shows in review as a change to both.  Tests check that both are current.

    python -m layered_brdf_addon.backends.generated          # rewrite them
    python -m layered_brdf_addon.backends.generated --check  # exit 1 if stale
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

from ..model.params import LayeredParams
from ..model.plan import EffectPlan
from ..model.policy import plan_effects
from .osl_shader import shader_source

ROOT = Path(__file__).resolve().parents[2]
OSL_FILE = ROOT / "osl" / "layered_brdf.osl"
NODE_GROUPS_DIR = ROOT / "node_groups"


def default_plan() -> EffectPlan:
    """The default material's plan with its closures computed (the whole program; a material's
    tables are its own, baked in its file)."""
    return replace(plan_effects(LayeredParams(), backend="osl"), tables=False)


def node_group_file(plan: EffectPlan) -> Path:
    return NODE_GROUPS_DIR / f"layered_brdf_{plan.key}.json"


def osl_text(plan: EffectPlan | None = None) -> str:
    return shader_source(plan or default_plan())


def _value(v):
    try:
        return [round(float(c), 7) for c in v]
    except TypeError:
        return round(float(v), 7) if isinstance(v, float) else v


def describe_tree(tree) -> dict:
    """Nodes (type, settings, unlinked inputs) and links of a node tree, nested groups
    included, in a stable order."""
    settings = ("operation", "data_type", "distribution", "vector_type", "convert_from", "convert_to",
                "noise_dimensions", "noise_type", "normalize", "factor_mode", "clamp_factor", "clamp", "use_clamp")
    nodes = []
    for n in tree.nodes:
        entry = {"name": n.name, "type": n.bl_idname}
        if n.label:
            entry["label"] = n.label
        for s in settings:
            if hasattr(n, s):
                entry[s] = getattr(n, s)
        if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None:
            entry["group"] = n.node_tree.name
        consts = {s.identifier: _value(s.default_value) for s in n.inputs
                  if s.enabled and not s.is_linked and hasattr(s, "default_value")}
        if consts:
            entry["inputs"] = consts
        nodes.append(entry)
    links = sorted(f"{lk.from_node.name}:{lk.from_socket.identifier} -> {lk.to_node.name}:{lk.to_socket.identifier}"
                   for lk in tree.links)
    return {"nodes": nodes, "links": links}


def node_group_description(plan: EffectPlan | None = None) -> str:
    """JSON of the node group for ``plan`` and of the sub-groups it uses (needs bpy)."""
    from .node_group import ensure_group  # needs bpy, which writing the OSL shader does not

    plan = plan or default_plan()
    group = ensure_group(plan)
    out = {"plan": plan.key, "describe": plan.describe(), "groups": {}}
    todo = [group]
    while todo:
        g = todo.pop(0)
        if g.name in out["groups"]:
            continue
        out["groups"][g.name] = describe_tree(g)
        todo += [n.node_tree for n in g.nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None]
    out["node_count"] = sum(len(g["nodes"]) for g in out["groups"].values())
    return json.dumps(out, indent=1, sort_keys=True) + "\n"


def expected_files() -> dict[Path, str]:
    plan = default_plan()
    return {OSL_FILE: osl_text(plan), node_group_file(plan): node_group_description(plan)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Write (or check) the generated shader files.")
    parser.add_argument("--check", action="store_true", help="exit 1 if a generated file is stale")
    args = parser.parse_args(argv)
    stale = []
    for path, text in expected_files().items():
        current = path.read_text() if path.exists() else None
        if current == text:
            continue
        stale.append(path)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(path.name + ".tmp")
            tmp.write_text(text)
            tmp.replace(path)
    for path in stale:
        print(f"{'stale' if args.check else 'wrote'}: {path.relative_to(ROOT)}")
    return 1 if (stale and args.check) else 0


if __name__ == "__main__":
    sys.exit(main())
