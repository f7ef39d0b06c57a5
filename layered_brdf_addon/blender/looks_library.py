"""Writing the looks library from the current session: a material asset per preset, made with
its preset's values and its preview rendered, saved with ``bpy.data.libraries.write`` (so it
works inside an artist's file, which is left as it was) into the library folder
(:mod:`.library_folder`), and the folder listed in Preferences > File Paths > Asset Libraries.

The add-on must be registered (the looks carry its settings); :mod:`.asset_library` is the entry
point for scripts and the command line.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import bpy

from ..io.staging import InterruptGuard
from ..model.params import ParameterError
from ..model.policy import render_plan
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS, STACK_PRESETS
from . import assets, library_folder, sync, user_presets
from .catalogs import CATALOG_FILE
from .library_folder import LIBRARY_FILE, Staging, check_directory, commit, read_folder, remove_stale_partials
from .lookdev import hdri_path
from .material_values import settings
from .stored_keys import MATERIAL_KEY, SETTINGS
from .tables import unused_tables

LIBRARY_NAME = "Layered BRDF Looks"  # its name in Preferences > File Paths > Asset Libraries


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
    """The presets a library holds by default: the artist presets, the structural colours, the paper's figures
    and, with ``include_user``, the saved user presets (``user:<name>``)."""
    names = [*ARTIST_PRESETS, *STACK_PRESETS, *PAPER_PRESETS]
    if include_user:
        names += [user_presets.USER_PREFIX + n for n in user_presets.user_preset_names()]
    return names


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
    for name, ident in names.items():
        params = user_presets.preset_params(ident)
        mat = bpy.data.materials.new(name)
        made.append(mat)
        mat.node_tree.nodes.clear()  # the default Principled BSDF is not part of the look
        mat[MATERIAL_KEY] = True
        sync.apply(mat, params, "nodes", render_plan(params), preview=False)
        settings(mat).preset = ident
        if mat.name != name:
            raise RuntimeError(f"the look '{name}' was named '{mat.name}'")
        assets.mark_look(mat, ident)
        step()


def write_library(directory, presets=None, preview_size: int = assets.PREVIEW_SIZE,
                  samples: int = assets.PREVIEW_SAMPLES, hdri: str | None = None,
                  progress=None, guard: InterruptGuard | None = None) -> LibraryResult:
    """Write the looks library into ``directory``: ``Layered BRDF Looks.blend`` (a material asset
    per preset of ``presets``, default :func:`default_presets`) and ``blender_assets.cats.txt``.

    ``preview_size`` is the previews' size in pixels (0: no previews), rendered with ``samples``
    per pixel under the bundled HDRI ``hdri``.  The folder is made when only it is missing.
    Re-running replaces the library's own files; a ``.blend`` of that name the library did not
    write is never replaced, and a folder (or anything but a file) under one of the library's
    file names is refused (ParameterError naming ``directory``, nothing made or written).
    Temporary files left in the folder by a build whose process is gone are removed.
    ``progress(done, total)`` is called as looks are made and previews rendered.  With an
    interrupt ``guard`` (the command line's), a signal ends the process at once with the
    folder as it was: the temporary files are removed and the previous library stays whole.
    The add-on must be registered (RuntimeError else).
    """
    if not hasattr(bpy.types.Material, SETTINGS):
        raise RuntimeError("the Layered BRDF add-on is not registered: the looks need its settings "
                           "(asset_library.write_asset_library registers it for the duration)")
    t0 = time.perf_counter()
    identifiers = _check_presets(presets)
    if preview_size != 0:
        assets.check_preview_options(preview_size, samples)
        hdri_path(hdri)  # a bundled HDRI, else ParameterError naming 'hdri'
        if bpy.app.is_job_running("RENDER"):
            raise ParameterError("preview_size", preview_size, "0 while a render is running "
                                 "(previews are Cycles renders): wait for the render to finish")
    path = check_directory(directory)
    names = _unique_names(identifiers)
    read_folder(path)  # refused now, before anything is made, when the folder holds files not ours
    remove_stale_partials(path)

    result = LibraryResult(directory=path, blend=path / LIBRARY_FILE, catalogs=path / CATALOG_FILE, assets=names)
    before_groups = {g.as_pointer() for g in bpy.data.node_groups}
    before_texts = {t.as_pointer() for t in bpy.data.texts}
    before_images = {i.as_pointer() for i in bpy.data.images}
    renamed = []  # the file's own materials holding a look's name, renamed for the moment
    made = []
    staged = Staging(path, guard)
    total = len(names) * (2 if preview_size else 1)
    count = [0]

    def step(*_):
        count[0] += 1
        if progress is not None:
            progress(count[0], total)

    if guard is not None:
        guard.add_cleanup(staged.discard)
    try:
        for name in names:
            other = bpy.data.materials.get(name)
            if other is not None and other.library is None:
                other.name = f"{name} (set aside by the Layered BRDF library)"
                renamed.append((other, name))
        _make_looks(names, made, step)
        if preview_size:
            result.preview_seconds = assets.render_previews(made, preview_size, samples, hdri, done=step,
                                                            guard=guard)
        staged.check()
        with staged.io():
            staged.make_folder()
            # Read again just before writing: the folder may have changed during the renders
            # (say the catalogs were edited in Blender's Asset Browser).
            old_hashes, cats = read_folder(path)
            blend_tmp = staged.new(".blend")
            bpy.data.libraries.write(str(blend_tmp), set(made), fake_user=True, compress=True)
            new_hash = library_folder.sha256(blend_tmp)
            cats_tmp = staged.text(cats, ".cats.txt")
            commit(staged, blend_tmp, cats_tmp, old_hashes, new_hash, names)
    except BaseException:
        staged.discard(folder=True)
        raise
    finally:
        staged.discard(folder=False)
        if guard is not None:
            guard.remove_cleanup(staged.discard)
        try:
            _remove_made(made, before_groups, before_texts, before_images)
        finally:
            for mat, name in renamed:
                mat.name = name
    result.seconds = time.perf_counter() - t0
    return result


def _remove_made(made, before_groups: set, before_texts: set, before_images: set) -> None:
    """Remove the looks made for the library and the add-on data only they used (their groups, OSL
    texts and baked tables)."""
    made_images = {i.as_pointer() for i in bpy.data.images} - before_images
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
    for image in unused_tables(among=made_images):  # the looks' baked tables, read by no group any more
        bpy.data.images.remove(image)


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

