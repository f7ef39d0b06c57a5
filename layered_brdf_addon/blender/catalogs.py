"""The add-on's asset catalogs (*Layered BRDF/Artist looks*, ...) and Blender's catalog file
``blender_assets.cats.txt``: read, and written with another tool's catalogs and comments kept.

Plain Python: imports no bpy.
"""
from __future__ import annotations

import uuid
from dataclasses import dataclass
from pathlib import Path

from ..model.params import ParameterError

CATALOG_FILE = "blender_assets.cats.txt"
CATALOG_HEADER = """\
# This is an Asset Catalog Definition file for Blender.
#
# Empty lines and lines starting with `#` will be ignored.
# The first non-ignored line should be the version indicator.
# Other lines are of the format "UUID:catalog/path/for/assets:simple catalog name"

VERSION 1

"""


@dataclass(frozen=True)
class Catalog:
    """One asset catalog: a stable UUID, its path in the Asset Browser and Blender's simple name."""

    uuid: str
    path: str

    @property
    def simple_name(self) -> str:
        return self.path.replace("/", "-")

    def line(self) -> str:
        """The catalog as a line of ``blender_assets.cats.txt``."""
        return f"{self.uuid}:{self.path}:{self.simple_name}"


def _catalog(path: str) -> Catalog:
    # Derived from the path, so every library (and every version of the add-on) uses the same UUIDs.
    return Catalog(str(uuid.uuid5(uuid.NAMESPACE_URL, "https://layered-brdf/asset-catalog/" + path)), path)


ROOT_CATALOG = _catalog("Layered BRDF")
CATALOGS = {
    "artist": _catalog("Layered BRDF/Artist looks"),
    "paper": _catalog("Layered BRDF/Paper figures"),
    "structural": _catalog("Layered BRDF/Structural colours"),
    "user": _catalog("Layered BRDF/User presets"),
}


def all_catalogs() -> list[Catalog]:
    return [ROOT_CATALOG, *CATALOGS.values()]


# --- the catalog file -----------------------------------------------------------------------------
def parse_catalogs(text: str) -> dict[str, tuple[str, str]]:
    """The catalogs of a ``blender_assets.cats.txt`` text: UUID -> (path, simple name).

    ParameterError (naming ``directory``) when the text is not a catalog file of VERSION 1."""
    catalogs: dict[str, tuple[str, str]] = {}
    version = None
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if version is None:
            if line != "VERSION 1":
                raise ParameterError("directory", line[:60], f"a folder whose {CATALOG_FILE} is a Blender "
                                     "catalog file of 'VERSION 1'")
            version = 1
            continue
        parts = line.split(":", 2)
        if len(parts) < 2:
            raise ParameterError("directory", line[:60], f"a folder whose {CATALOG_FILE} has lines "
                                 "'UUID:catalog/path:simple name'")
        catalogs[parts[0].strip()] = (parts[1].strip(), parts[2].strip() if len(parts) > 2 else "")
    return catalogs


def read_catalogs(path) -> dict[str, tuple[str, str]]:
    """The catalogs of the catalog file ``path``: UUID -> (path, simple name)."""
    return parse_catalogs(Path(path).read_text(encoding="utf-8"))


def catalog_text(existing: str | None) -> str:
    """The catalog file: ``existing`` (another tool's catalogs and comments kept as they are,
    lines with the library's UUIDs replaced) with the library's catalogs."""
    ours = all_catalogs()
    if existing is None:
        return CATALOG_HEADER + "".join(c.line() + "\n" for c in ours)
    parse_catalogs(existing)  # a VERSION 1 catalog file, else ParameterError
    uuids = {c.uuid for c in ours}
    kept = [line for line in existing.splitlines() if line.split(":", 1)[0].strip() not in uuids]
    while kept and not kept[-1].strip():
        kept.pop()
    return "\n".join(kept) + "\n" + "".join(c.line() + "\n" for c in ours)
