"""The packages' imports run one way: no module imports, directly or through others, a module that
imports it back; function-level imports included (they only postpone a circle).  A function-level
import of a project module says why it is not at the top of its file (a comment on its line or the
line above), because Blender's loading order or a heavy optional dependency asks for it."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("layered_brdf_addon", "layered_brdf_reference")


def _modules() -> dict[str, tuple[Path, bool]]:
    modules = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            is_package = parts[-1] == "__init__"
            modules[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return modules


MODULES = _modules()


def _absolute(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".")[: None if is_package else -1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _project_module(name: str) -> str | None:
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _imports(module: str):
    """(imported project module, the import statement, whether it sits inside a function)."""
    path, is_package = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    in_function = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            in_function.update(id(n) for n in ast.walk(node) if n is not node)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _absolute(node, module, is_package)
            subs = [f"{base}.{alias.name}" for alias in node.names if f"{base}.{alias.name}" in MODULES]
            # ``from . import x`` imports the module x, not its package's __init__ (already loading)
            names = subs if len(subs) == len(node.names) else [base] + subs
        else:
            continue
        for name in names:
            target = _project_module(name)
            if target and target != module:
                yield target, node, id(node) in in_function


def _graph() -> dict[str, set[str]]:
    return {module: {target for target, _, _ in _imports(module)} for module in MODULES}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, stack, on_stack, found, counter = {}, {}, [], set(), [], 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_circles():
    cycles = _cycles(_graph())
    assert not cycles, "modules that import each other: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_every_function_level_import_of_the_add_on_says_why():
    silent = []
    for module, (path, _) in MODULES.items():
        if not module.startswith("layered_brdf_addon"):
            continue
        lines = path.read_text(encoding="utf-8").splitlines()
        for _, node, in_function in _imports(module):
            if not in_function:
                continue
            statement = lines[node.lineno - 2: node.end_lineno]
            if not any("#" in line for line in statement):
                silent.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not sorted(set(silent)), "function-level imports without a reason: " + ", ".join(sorted(set(silent)))


# Which layer may import which: the bpy-free core (model, backends, fit, io) never imports the command line
# or the Blender layer, and the Blender layer never imports the command line (both share io).
LAYERS = {
    "layered_brdf_addon.model": ("layered_brdf_addon.cli", "layered_brdf_addon.blender", "layered_brdf_addon.fit",
                                 "layered_brdf_addon.io"),
    "layered_brdf_addon.io": ("layered_brdf_addon.cli", "layered_brdf_addon.blender", "layered_brdf_addon.fit"),
    "layered_brdf_addon.fit": ("layered_brdf_addon.cli", "layered_brdf_addon.blender"),
    "layered_brdf_addon.blender": ("layered_brdf_addon.cli",),
}


def test_imports_run_down_the_layers():
    wrong = []
    for module in MODULES:
        for layer, forbidden in LAYERS.items():
            if module == layer or module.startswith(layer + "."):
                wrong += [f"{module} -> {target}" for target, _, _ in _imports(module)
                          if any(target == f or target.startswith(f + ".") for f in forbidden)]
    assert not wrong, "imports against the layers: " + "; ".join(sorted(wrong))


def test_the_add_on_s_warnings_are_defined_where_bpy_is_not_imported():
    """A warning's class is imported again wherever the warning is reported (pytest-xdist's controller
    imports the module that defines it): a warning defined in the Blender layer would load bpy in a process
    that does not render, which Blender's module does not leave cleanly."""
    in_blender = []
    for module, (path, _) in MODULES.items():
        if not module.startswith("layered_brdf_addon.blender"):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            bases = [b.id if isinstance(b, ast.Name) else getattr(b, "attr", "") for b in getattr(node, "bases", ())]
            if isinstance(node, ast.ClassDef) and any(base.endswith("Warning") for base in bases):
                in_blender.append(f"{module}.{node.name}")
    assert not in_blender, "warnings defined in the Blender layer: " + ", ".join(in_blender)
