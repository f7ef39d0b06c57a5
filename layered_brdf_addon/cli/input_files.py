"""The files a command reads: params files, job files and tables, .blend files.

Only regular files are read (a FIFO or a device is refused, never waited on), at most
:data:`MAX_INPUT_BYTES` of a table; a file that cannot be parsed is refused as a whole.  A
value read from a file that is invalid is a :class:`FileValueError` naming the file and the
key (:func:`from_file`), not an option nobody typed.  Nothing here imports bpy.
"""
from __future__ import annotations

import json
import os
import tomllib
from pathlib import Path
from typing import Any, Iterable, Mapping

from ..io.regular_files import MAX_INPUT_BYTES, FileRefused, read_regular_bytes
from ..io.regular_files import file_label  # noqa: F401 (the command line's name for it)
from ..model.params import LOWER_MEDIA, LOWER_MEDIUM_KEYS, ParameterError
from .option_values import MAX_INT_DIGITS, PARAM_NAMES, check_plain, short_name, shown

_BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd


class FileValueError(ParameterError):
    """An invalid value read from a file (a ``--params`` file, a job's ``params``): the
    message names the file and the key, not a command-line option nobody typed."""

    def __init__(self, name: str, value: Any, allowed: str, file: str):
        super().__init__(name, value, allowed)
        self.file = file
        self.args = (f"parameter '{name}' = {value!r} in {file}: allowed {allowed}",)


def from_file(e: ParameterError, values: Mapping[str, Any], file: str,
              overridden: Iterable[str] = ()) -> ParameterError:
    """``e`` as a :class:`FileValueError` naming ``file`` when the value it names was read
    from it (is one of ``values`` and not ``overridden`` by an option); else ``e``."""
    if isinstance(e, FileValueError) or e.name not in values or e.name in set(overridden):
        return e
    return FileValueError(e.name, e.value, e.allowed, file)


def merged_values(file_values: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """A params file's values with the typed options over them, validated as one set.

    Checked together, a file's ``d_min = 300`` and a typed ``--d-max 400`` make a valid
    range (checked one after the other, the file's value would meet the default ``d_max``).
    A lower medium typed as an option fills its n and k over the file's (as it would over
    a preset's), unless they are typed too.
    """
    values = dict(file_values)
    medium = overrides.get("lower_medium")
    if isinstance(medium, str) and medium in LOWER_MEDIA and medium != "custom":
        for key in LOWER_MEDIUM_KEYS:
            values.pop(key, None)
    values.update(overrides)
    return values


def read_regular_file(path: str | os.PathLike, name: str, allowed: str, limit: int | None = None,
                      head: int | None = None) -> bytes:
    """The bytes of a regular file (at most ``head`` of them), or :class:`ParameterError`
    naming ``name``: for a file that cannot be opened, one that is not a regular file (a
    FIFO, a device, a folder: never waited on or read), and one over ``limit`` bytes
    (:func:`..io.regular_files.read_regular_bytes`)."""
    try:
        return read_regular_bytes(path, limit=limit, head=head)
    except FileRefused as e:
        raise ParameterError(name, str(Path(path)), f"{allowed} ({e.reason})") from None


def read_table_file(path: str | os.PathLike, name: str, allowed: str) -> Any:
    """The contents of a ``.toml`` or ``.json`` file; :class:`ParameterError` naming ``name``
    (with ``allowed``) if it cannot be read or parsed, is not a regular file or is larger
    than :data:`MAX_INPUT_BYTES`.

    The standard parsers read it; the size cap bounds their work.  A file nested deeper
    than they follow (their RecursionError: some hundreds of levels of TOML, about 1,000
    of JSON on Python 3.11 and 10,000 on 3.13) is refused as a whole, and so is one with
    an integer of more digits than Python converts (4300): no option takes either."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise ParameterError(name, str(p), allowed)
    data = read_regular_file(p, name, allowed, limit=MAX_INPUT_BYTES)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ParameterError(name, str(p), f"{allowed} (UnicodeDecodeError: {e})") from None
    try:
        return tomllib.loads(text) if suffix == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as e:
        raise ParameterError(name, str(p), f"{allowed} ({str(e)[:200]})") from None
    except RecursionError:
        raise ParameterError(name, str(p), f"{allowed} (values nested deeper than can be read)") from None
    except ValueError:  # the parsers' only other error: int() refuses a literal of over 4300 digits
        raise ParameterError(name, str(p), f"{allowed} (an integer too long to read; options take at most "
                             f"{MAX_INT_DIGITS} digits)") from None


def load_params_file(path: str | os.PathLike, label: str | None = None) -> dict[str, Any]:
    """Parameter values from a ``.json`` or ``.toml`` file.

    The file holds ``{name: value}``; a ``params`` table inside it is used instead
    when present, so a render's sidecar can be given to re-render its material.  An
    unknown key or an absurd value is a :class:`FileValueError` naming the file as
    ``label`` (default: ``path``) and the key.
    """
    p = Path(path)
    label = str(p) if label is None else label
    allowed = "a readable .json or .toml file of parameter values (a regular file of at most 1 MiB)"
    data = read_table_file(p, "params", allowed)
    if isinstance(data, dict) and isinstance(data.get("params"), dict):
        data = data["params"]
    if not isinstance(data, dict):
        raise ParameterError("params", str(p), allowed + " (a table of name = value)")
    for key, value in data.items():
        if key not in PARAM_NAMES:
            raise FileValueError(short_name(key), shown(value), "a known parameter name: " + ", ".join(PARAM_NAMES),
                                 label)
        try:
            check_plain(key, value)
        except ParameterError as e:
            raise from_file(e, data, label) from None
    return data


def check_blend_file(path: str | os.PathLike) -> Path:
    """Raise :class:`ParameterError` unless ``path`` looks like a .blend Blender can read."""
    p = Path(path)
    allowed = "a readable .blend file"
    head = read_regular_file(p, "blend", allowed, head=7)
    if not any(head.startswith(m) for m in _BLEND_MAGIC):
        raise ParameterError("blend", str(p), f"{allowed} (this file is not a .blend)")
    return p.resolve()


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether writing ``a`` would replace ``b``: the same resolved path, or (both existing)
    the same file (a hard link, a symlink)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False
