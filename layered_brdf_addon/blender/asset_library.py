"""The asset library of looks: one material asset per preset, for Blender's Asset Browser.

:func:`write_asset_library` writes two files into a folder:

* ``Layered BRDF Looks.blend``: a material per preset (the artist presets, the paper's
  figures, and on request user presets), named for people, each carrying its preset's
  values and node group, marked as an asset with description, author, tags, catalog and a
  rendered preview (:mod:`.assets`);
* ``blender_assets.cats.txt``: the catalogs (``Layered BRDF/Artist looks``, ``.../Paper
  figures``, ``.../User presets``) in Blender's catalog file format.  An existing catalog
  file is merged: its other catalogs and comments are kept.

It runs in the current session without saving it (``bpy.data.libraries.write``), so it
works inside an artist's file: the materials it makes for the library are removed again,
and the file's own data is as it was.  Files are written under temporary names in the
folder and renamed when complete.  A ``.blend`` of the library's name that the library did
not write (recorded with its SHA-256 in ``.layered_brdf_library.json``) is never replaced.

From a shell (or ``make assets``)::

    python -m layered_brdf_addon.blender.asset_library DIR [--presets NAME ...] [--user-presets]
        [--preview-size PX] [--samples N] [--hdri NAME]
"""
from __future__ import annotations

import hashlib
import json
import os
import secrets
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import bpy

from ..model.params import ParameterError
from ..model.policy import plan_effects
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS
from . import assets
from . import material as M
from . import user_presets

LIBRARY_FILE = "Layered BRDF Looks.blend"
CATALOG_FILE = "blender_assets.cats.txt"
MANIFEST_FILE = ".layered_brdf_library.json"  # what the library wrote: file names and their SHA-256
MANIFEST_FORMAT = "layered_brdf.asset_library"
MANIFEST_VERSION = 1
LIBRARY_NAME = "Layered BRDF Looks"  # its name in Preferences > File Paths > Asset Libraries
CATALOG_HEADER = """\
# This is an Asset Catalog Definition file for Blender.
#
# Empty lines and lines starting with `#` will be ignored.
# The first non-ignored line should be the version indicator.
# Other lines are of the format "UUID:catalog/path/for/assets:simple catalog name"

VERSION 1

"""
_TEMP_PREFIX = ".layered_brdf_partial_"


@dataclass
class LibraryResult:
    """What :func:`write_asset_library` wrote."""

    directory: Path
    blend: Path
    catalogs: Path
    assets: dict[str, str] = field(default_factory=dict)  # asset name -> preset identifier
    preview_seconds: list[float] = field(default_factory=list)
    seconds: float = 0.0


def default_presets(include_user: bool = False) -> list[str]:
    """The presets a library holds by default: the artist presets, the paper's figures and, with
    ``include_user``, the saved user presets (``user:<name>``)."""
    names = [*ARTIST_PRESETS, *PAPER_PRESETS]
    if include_user:
        names += [user_presets.USER_PREFIX + n for n in user_presets.user_preset_names()]
    return names


def all_catalogs() -> list[assets.Catalog]:
    return [assets.ROOT_CATALOG, *assets.CATALOGS.values()]


# --- checks ---------------------------------------------------------------------------------------
def _check_presets(presets) -> list[str]:
    if presets is None:
        return default_presets()
    if isinstance(presets, (str, bytes)) or not hasattr(presets, "__iter__"):
        raise ParameterError("presets", presets, "a list of preset names (built-in names or 'user:<name>')")
    names = list(dict.fromkeys(presets))
    if not names:
        raise ParameterError("presets", presets, "at least one preset name")
    for name in names:
        if not isinstance(name, str):
            raise ParameterError("presets", name, "preset names as strings")
        assets.kind_of(name)  # a built-in preset or user:<name>, else ParameterError naming 'preset'
        user_presets.preset_params(name)  # a user preset that exists and is valid
    return names


def _check_directory(directory) -> Path:
    if isinstance(directory, bytes) or not isinstance(directory, (str, os.PathLike)) or not str(directory):
        raise ParameterError("directory", directory, "a folder path (str or os.PathLike)")
    path = Path(directory).expanduser().absolute()
    if path.exists() and not path.is_dir():
        raise ParameterError("directory", str(directory), "a folder (this path is a file)")
    if not path.exists() and not path.parent.is_dir():
        raise ParameterError("directory", str(directory), "a folder that exists, or whose parent folder exists")
    target = path if path.exists() else path.parent
    if not os.access(target, os.W_OK | os.X_OK):
        raise ParameterError("directory", str(directory), "a folder you may write to")
    return path


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def read_manifest(directory: Path) -> dict | None:
    """The library's record in ``directory`` (None when there is none); ParameterError when a file
    of that name is not one the library wrote."""
    path = directory / MANIFEST_FILE
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        data = None
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT \
            or not isinstance(data.get("files"), dict):
        raise ParameterError("directory", str(directory), f"a folder whose {MANIFEST_FILE} was written by the "
                             "Layered BRDF asset library (this one was not; move it or choose another folder)")
    return data


def _owned_hashes(directory: Path) -> list[str]:
    """The SHA-256 of the library .blend that may be replaced: [] when there is none; ParameterError
    when the one there is not the library's (or was changed since the library wrote it)."""
    blend = directory / LIBRARY_FILE
    if not blend.exists() and not blend.is_symlink():
        return []
    manifest = read_manifest(directory)
    accepted = manifest["files"].get(LIBRARY_FILE, []) if manifest else []
    current = _sha256(blend) if blend.is_file() and not blend.is_symlink() else None
    if current is None or current not in accepted:
        why = "it was changed since" if manifest else "there is no record of it"
        raise ParameterError("directory", str(directory), f"a folder without a '{LIBRARY_FILE}' that the "
                             f"Layered BRDF asset library did not write (the one there is not its own: {why}); "
                             "move that file or choose another folder")
    return [current]


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


# --- writing ------------------------------------------------------------------------------------
def _temp_path(directory: Path, suffix: str) -> Path:
    """A new empty file in ``directory`` under a temporary name (permissions as the umask gives)."""
    while True:
        path = directory / f"{_TEMP_PREFIX}{secrets.token_hex(6)}{suffix}"
        try:
            with open(path, "x"):
                return path
        except FileExistsError:
            continue


def _write_text(directory: Path, text: str, suffix: str) -> Path:
    tmp = _temp_path(directory, suffix)
    tmp.write_text(text, encoding="utf-8")
    return tmp


def _manifest_text(hashes: list[str], names: dict[str, str]) -> str:
    return json.dumps({"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION, "files": {LIBRARY_FILE: hashes},
                       "assets": names, "catalogs": {c.uuid: c.path for c in all_catalogs()}},
                      indent=2, sort_keys=True) + "\n"


class _Registered:
    """The add-on registered for the duration (the materials need its settings); left as found."""

    def __enter__(self):
        from . import properties, registration

        self.registered = False
        if not hasattr(bpy.types.Material, properties.SETTINGS):
            registration.register()
            self.registered = True
        return self

    def __exit__(self, *exc):
        if self.registered:
            from . import registration

            registration.unregister()
        return False


def _unique_names(identifiers: list[str]) -> dict[str, str]:
    """Asset name -> identifier; a user preset named like a built-in look gets ' (user preset)'."""
    names: dict[str, str] = {}
    for ident in identifiers:
        name = assets.look_name(ident)
        if name in names:
            name = f"{name} (user preset)"
        if name in names:
            raise ParameterError("presets", ident, f"presets whose names differ ('{name}' twice)")
        names[name] = ident
    return names


def _make_looks(names: dict[str, str], made: list, step) -> None:
    """A material asset per look, named exactly so (a material of the file holding that name is
    renamed for the moment by the caller), appended to ``made`` as it is made."""
    from . import properties

    for name, ident in names.items():
        params = user_presets.preset_params(ident)
        mat = bpy.data.materials.new(name)
        made.append(mat)
        mat.node_tree.nodes.clear()  # the default Principled BSDF is not part of the look
        mat[M.MATERIAL_KEY] = True
        properties._apply(mat, params, "nodes", plan_effects(params), preview=False)
        properties.settings(mat).preset = ident
        if mat.name != name:
            raise RuntimeError(f"the look '{name}' was named '{mat.name}'")
        assets.mark_look(mat, ident)
        step()


def write_asset_library(directory, presets=None, preview_size: int = assets.PREVIEW_SIZE,
                        samples: int = assets.PREVIEW_SAMPLES, hdri: str | None = None,
                        progress=None) -> LibraryResult:
    """Write the looks library into ``directory``: ``Layered BRDF Looks.blend`` (a material asset
    per preset of ``presets``, default :func:`default_presets`) and ``blender_assets.cats.txt``.

    ``preview_size`` is the previews' size in pixels (0: no previews), rendered with ``samples``
    per pixel under the bundled HDRI ``hdri``.  The folder is made when only it is missing.
    Re-running replaces the library's own files; a ``.blend`` of that name the library did not
    write is never replaced (ParameterError naming ``directory``, nothing written).
    ``progress(done, total)`` is called as looks are made and previews rendered.
    """
    t0 = time.perf_counter()
    identifiers = _check_presets(presets)
    if preview_size != 0:
        from .lookdev import hdri_path

        assets.check_preview_options(preview_size, samples)
        hdri_path(hdri)  # a bundled HDRI, else ParameterError naming 'hdri'
        if bpy.app.is_job_running("RENDER"):
            raise ParameterError("preview_size", preview_size, "0 while a render is running "
                                 "(previews are Cycles renders): wait for the render to finish")
    path = _check_directory(directory)
    names = _unique_names(identifiers)
    _existing(path)  # refused now, before anything is made, when the folder holds files not ours

    result = LibraryResult(directory=path, blend=path / LIBRARY_FILE, catalogs=path / CATALOG_FILE, assets=names)
    before_groups = {g.as_pointer() for g in bpy.data.node_groups}
    before_texts = {t.as_pointer() for t in bpy.data.texts}
    renamed = []  # the file's own materials holding a look's name, renamed for the moment
    made = []
    temps: list[Path] = []
    total = len(names) * (2 if preview_size else 1)
    count = [0]

    def step(*_):
        count[0] += 1
        if progress is not None:
            progress(count[0], total)

    created_dir = False
    try:
        with _Registered():
            for name in names:
                other = bpy.data.materials.get(name)
                if other is not None and other.library is None:
                    other.name = f"{name} (set aside by the Layered BRDF library)"
                    renamed.append((other, name))
            _make_looks(names, made, step)
            if preview_size:
                result.preview_seconds = assets.render_previews(made, preview_size, samples, hdri, done=step)
            if not path.exists():
                path.mkdir()
                created_dir = True
            # Read again just before writing: the folder may have changed during the renders
            # (say the catalogs were edited in Blender's Asset Browser).
            old_hashes, cats = _existing(path)
            blend_tmp = _temp_path(path, ".blend")
            temps.append(blend_tmp)
            bpy.data.libraries.write(str(blend_tmp), set(made), fake_user=True, compress=True)
            new_hash = _sha256(blend_tmp)
            temps.append(cats_tmp := _write_text(path, cats, ".cats.txt"))
            # The record first accepts both the old and the new .blend, so that an interruption
            # between the renames leaves a library the next run still recognises as its own.
            temps.append(pending := _write_text(path, _manifest_text(old_hashes + [new_hash], names), ".json"))
            os.replace(pending, path / MANIFEST_FILE)
            os.replace(blend_tmp, result.blend)
            os.replace(cats_tmp, result.catalogs)
            temps.append(final := _write_text(path, _manifest_text([new_hash], names), ".json"))
            os.replace(final, path / MANIFEST_FILE)
    except BaseException:
        if created_dir and not any(p for p in path.iterdir() if p not in temps):
            for tmp in temps:
                tmp.unlink(missing_ok=True)
            path.rmdir()
        raise
    finally:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        try:
            _remove_made(made, before_groups, before_texts)
        finally:
            for mat, name in renamed:
                mat.name = name
    result.seconds = time.perf_counter() - t0
    return result


def _existing(path: Path) -> tuple[list[str], str]:
    """What the folder holds now: the hashes of a library .blend that may be replaced and the
    catalog file to write (its other catalogs kept).  ParameterError naming ``directory`` when the
    .blend there is not the library's or the catalog file is not one of VERSION 1."""
    if not path.exists():
        return [], catalog_text(None)
    old_hashes = _owned_hashes(path)
    cats = path / CATALOG_FILE
    if not cats.is_file():
        return old_hashes, catalog_text(None)
    try:
        text = cats.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterError("directory", str(path), f"a folder whose {CATALOG_FILE} is readable UTF-8 text "
                             f"({e})") from None
    return old_hashes, catalog_text(text)


def _remove_made(made, before_groups: set, before_texts: set) -> None:
    """Remove the looks made for the library and the add-on data only they used."""
    for mat in made:
        try:
            bpy.data.materials.remove(mat)
        except ReferenceError:
            continue
    while True:
        stale = [g for g in bpy.data.node_groups if g.as_pointer() not in before_groups and g.library is None
                 and g.users == 0]
        if not stale:
            break
        bpy.data.node_groups.remove(stale[0])
    for t in [t for t in bpy.data.texts if t.as_pointer() not in before_texts and t.users == 0]:
        bpy.data.texts.remove(t)


# --- Preferences > File Paths > Asset Libraries --------------------------------------------------
def registered_library(directory):
    """The asset library of Blender's preferences whose folder is ``directory``, or None."""
    target = os.path.realpath(os.fspath(directory))
    for lib in bpy.context.preferences.filepaths.asset_libraries:
        if lib.path and os.path.realpath(bpy.path.abspath(lib.path)) == target:
            return lib
    return None


def register_library(directory, name: str = LIBRARY_NAME):
    """Add ``directory`` to Preferences > File Paths > Asset Libraries (unless it is there);
    returns ``(library, added)``.  The preferences are saved with Blender's own rules (on quit
    when auto-save is on)."""
    path = Path(directory)
    if not path.is_dir():
        raise ParameterError("directory", str(directory), "an existing folder")
    lib = registered_library(path)
    if lib is not None:
        return lib, False
    prefs = bpy.context.preferences
    lib = prefs.filepaths.asset_libraries.new(name=name, directory=str(path.absolute()))
    prefs.is_dirty = True
    return lib, True


# --- command line ---------------------------------------------------------------------------------
def _parser():
    import argparse

    p = argparse.ArgumentParser(
        prog="python -m layered_brdf_addon.blender.asset_library",
        description=f"Write the Layered BRDF looks library ('{LIBRARY_FILE}' and '{CATALOG_FILE}') into DIR; "
                    "add DIR in Blender's Preferences > File Paths > Asset Libraries to drag looks onto objects.")
    p.add_argument("directory", metavar="DIR", help="the library folder (made when only it is missing)")
    p.add_argument("--presets", nargs="+", metavar="NAME",
                   help="presets to include (built-in names or 'user:<name>'; default: every built-in preset)")
    p.add_argument("--user-presets", action="store_true", help="also include every saved user preset")
    lo, hi = assets.PREVIEW_SIZE_RANGE
    p.add_argument("--preview-size", type=int, default=assets.PREVIEW_SIZE, metavar="PX",
                   help=f"preview size in pixels, {lo} to {hi}, or 0 for no previews (default {assets.PREVIEW_SIZE})")
    lo, hi = assets.PREVIEW_SAMPLES_RANGE
    p.add_argument("--samples", type=int, default=assets.PREVIEW_SAMPLES, metavar="N",
                   help=f"Cycles samples per preview pixel, {lo} to {hi} (default {assets.PREVIEW_SAMPLES})")
    p.add_argument("--hdri", default=None, metavar="NAME", help="a bundled HDRI for the previews (default forest)")
    return p


def _print_progress(done: int, total: int) -> None:
    print(f"\r{done}/{total}", end="\n" if done == total else "", file=sys.stderr, flush=True)


def main(argv=None) -> int:
    """Exit codes: 0 written, 2 invalid input (the message names the parameter), 1 another failure."""
    args = _parser().parse_args(argv)
    presets = args.presets or default_presets()
    if args.user_presets:
        presets = list(presets) + [user_presets.USER_PREFIX + n for n in user_presets.user_preset_names()]
    try:
        result = write_asset_library(args.directory, presets, preview_size=args.preview_size,
                                     samples=args.samples, hdri=args.hdri, progress=_print_progress)
    except ParameterError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except (OSError, RuntimeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(f"{len(result.assets)} looks in {result.blend}")
    print(f"catalogs in {result.catalogs}")
    if result.preview_seconds:
        ps = result.preview_seconds
        print(f"previews: {args.preview_size} px, {args.samples} samples, {sum(ps):.1f} s "
              f"({max(ps):.2f} s the slowest)")
    print(f"{result.seconds:.1f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
