"""Where the running Blender keeps the tools this package calls, found at run time.

Blender's layout moves between versions (Python 3.11 in 5.0, 3.13 in 5.2; the extension
tool's folder), so nothing here hard-codes a version: the paths follow ``bpy`` and the
running Python.

``python -m layered_brdf_addon.blender.paths --shell`` prints ``tool=...`` and ``tags=...``
for the Makefile's ``extension`` target.
"""
from __future__ import annotations

import shlex
import sys
from pathlib import Path

import bpy

_EXT_TOOL = "blender_ext.py"
_TAGS = "tags.py"


def _python_lib_dirs() -> list[Path]:
    """Blender's bundled Python library folders, the running Python's version first."""
    lib = Path(bpy.utils.resource_path("LOCAL")) / "python" / "lib"
    own = lib / f"python{sys.version_info.major}.{sys.version_info.minor}"
    others = sorted(p for p in lib.glob("python3*") if p != own) if lib.is_dir() else []
    return [own] + others


def osl_site_packages() -> Path:
    """The site-packages folder of Blender's bundled Python that holds ``oslquery`` (the OSL
    compiler's Python bindings); where none holds it, the running Python's (which may not
    exist: check before adding it to ``sys.path``)."""
    for lib in _python_lib_dirs():
        site = lib / "site-packages"
        if (site / "oslquery").exists():
            return site
    return _python_lib_dirs()[0] / "site-packages"


def _find(root: Path, name: str, preferred: tuple[str, ...]) -> Path:
    for rel in preferred:
        path = root.joinpath(*rel.split("/"))
        if path.is_file():
            return path
    found = sorted(root.rglob(name), key=lambda p: (len(p.parts), str(p)))
    if not found:
        raise FileNotFoundError(f"{name} not found under {root} (Blender {bpy.app.version_string})")
    return found[0]


def extension_tool() -> Path:
    """Blender's extension command-line tool, ``blender_ext.py`` (build, validate)."""
    scripts = Path(bpy.utils.system_resource("SCRIPTS"))
    return _find(scripts, _EXT_TOOL, ("addons_core/bl_pkg/cli/blender_ext.py",))


def extension_tags() -> Path:
    """The file of valid extension tags that ``blender_ext.py --valid-tags`` reads."""
    scripts = Path(bpy.utils.system_resource("SCRIPTS"))
    return _find(scripts, _TAGS, ("modules/_bpy_internal/extensions/tags.py",))


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    tool, tags = extension_tool(), extension_tags()
    if argv == ["--shell"]:
        print(f"tool={shlex.quote(str(tool))}")
        print(f"tags={shlex.quote(str(tags))}")
    elif not argv:
        print(f"Blender {bpy.app.version_string}")
        print(f"extension tool: {tool}")
        print(f"extension tags: {tags}")
        print(f"OSL site-packages: {osl_site_packages()}")
    else:
        print("usage: python -m layered_brdf_addon.blender.paths [--shell]", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
