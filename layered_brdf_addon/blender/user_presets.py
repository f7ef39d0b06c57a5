"""User presets: named parameter sets saved as JSON in the add-on's user directory.

Installed as an extension, the directory is the extension's own user directory
(``bpy.utils.extension_path_user``, kept across upgrades); otherwise it is
``<config>/layered_brdf/presets``.  Presets are shared by every .blend file.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import bpy

from ..model.params import LayeredParams, ParameterError
from ..model.presets import PRESETS, preset

FORMAT = "layered_brdf.preset"
FORMAT_VERSION = 1
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _.\-]{0,63}")
NAME_RULE = "1 to 64 letters, digits, spaces, '_', '-' or '.', starting with a letter or digit"


def extension_package() -> str | None:
    """The extension's package name (``bl_ext.<repository>.<id>``) when installed as one."""
    parts = __package__.split(".")
    if parts[0] == "bl_ext" and len(parts) >= 3:
        return ".".join(parts[:3])
    return None


def presets_dir() -> Path:
    package = extension_package()
    if package is not None:
        return Path(bpy.utils.extension_path_user(package, path="presets", create=True))
    return Path(bpy.utils.user_resource("CONFIG", path="layered_brdf/presets", create=True))


def check_name(name: str) -> str:
    name = name.strip()
    if not NAME_PATTERN.fullmatch(name) or name.endswith("."):
        raise ParameterError("name", name, NAME_RULE)
    if name in PRESETS:
        raise ParameterError("name", name, "a name that is not a built-in preset's")
    return name


def _path(name: str) -> Path:
    return presets_dir() / f"{check_name(name)}.json"


def user_preset_names() -> list[str]:
    return sorted((p.stem for p in presets_dir().glob("*.json") if NAME_PATTERN.fullmatch(p.stem)),
                  key=str.casefold)


def save_user_preset(name: str, params: LayeredParams) -> Path:
    """Write ``params`` as the preset ``name`` (replacing one of that name)."""
    path = _path(name)
    data = {"format": FORMAT, "version": FORMAT_VERSION, "name": path.stem, "params": params.validate().to_dict()}
    tmp = path.with_suffix(".json.partial")
    tmp.write_text(json.dumps(data, indent=2, sort_keys=True))
    tmp.replace(path)
    return path


def load_user_preset(name: str) -> LayeredParams:
    """The validated parameters of the user preset ``name``; ParameterError when missing or invalid."""
    path = _path(name)
    if not path.is_file():
        raise ParameterError("preset", name, "one of the saved presets: " + (", ".join(user_preset_names()) or "none"))
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ParameterError("preset", name, f"a readable preset file ({path}: {e})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT or not isinstance(data.get("params"), dict):
        raise ParameterError("preset", name, f"a file written by Save Preset ({path} has no '{FORMAT}' params)")
    version = data.get("version")
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise ParameterError("preset", name, f"a preset of format version 1 to {FORMAT_VERSION} "
                             f"({path} has version {version!r})")
    return LayeredParams.from_dict(data["params"])


def delete_user_preset(name: str) -> None:
    path = _path(name)
    if not path.is_file():
        raise ParameterError("preset", name, "one of the saved presets: " + (", ".join(user_preset_names()) or "none"))
    path.unlink()


# Preset identifiers in menus: built-in names as they are, user presets prefixed.
USER_PREFIX = "user:"


def preset_params(identifier: str) -> LayeredParams:
    """Parameters of a built-in preset name or of ``"user:<name>"``."""
    if identifier.startswith(USER_PREFIX):
        return load_user_preset(identifier[len(USER_PREFIX):])
    return preset(identifier)
