"""The looks-library builder under faults: Ctrl-C and SIGTERM at every stage of a build, a build
killed while it puts its files in place, a full disk, a failed rename, and folders where the
library's files belong.

The command line runs as a separate process, as a shell or ``make assets`` runs it, with a TMPDIR
of its own; every subprocess call has a timeout.  Libraries hold one or two looks, with 16 px
previews of one sample where a test needs previews at all.
"""
from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from layered_brdf_addon.blender.asset_library import CATALOG_FILE, LIBRARY_FILE, MANIFEST_FILE, write_asset_library
from layered_brdf_addon.blender import assets, looks_library
from layered_brdf_addon.model.params import ParameterError

ROOT = Path(__file__).resolve().parents[1]
TIMEOUT = 180
PARTIAL = ".layered_brdf_partial_"
LIBRARY = sorted([LIBRARY_FILE, CATALOG_FILE, MANIFEST_FILE])
OLD_LOOKS = ["fig3_clay"]
NEW_LOOKS = ["fig3_thin_film", "fig3_old_metal"]

# Runs the builder as ``python -m`` does, after making it stop for a while (or until it is killed)
# when it is about to put its catalogs in place: its new .blend is in place by then.  argv: the
# marker file it creates when it stops there, the seconds it waits, the builder's arguments.
SLOW_RENAMES = r"""
import os, runpy, sys, time

marker, seconds = sys.argv[1], float(sys.argv[2])
real_replace = os.replace


def replace_slowly(src, dst, *args, **kwargs):
    placing_catalogs = os.path.basename(dst) == "blender_assets.cats.txt"
    if placing_catalogs and os.path.basename(src).startswith(".layered_brdf_partial_") and not os.path.exists(marker):
        open(marker, "w").close()
        time.sleep(seconds)
    return real_replace(src, dst, *args, **kwargs)


os.replace = replace_slowly
sys.argv = [sys.argv[0], *sys.argv[3:]]
runpy.run_module("layered_brdf_addon.blender.asset_library", run_name="__main__", alter_sys=True)
"""


def entries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def contents(folder: Path) -> dict[str, bytes] | None:
    """Every file of ``folder`` by name, with its bytes (None when there is no folder)."""
    if not folder.exists():
        return None
    return {p.name: p.read_bytes() if p.is_file() else b"<folder>" for p in folder.iterdir()}


def previous_library(folder: Path) -> dict[str, bytes]:
    """A library written in this process (one look, no previews): what an interrupted build must leave."""
    write_asset_library(folder, OLD_LOOKS, preview_size=0)
    assert entries(folder) == LIBRARY
    return contents(folder)


def dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait(timeout=30)
    return proc.pid


@pytest.fixture
def tmpdir_env(tmp_path) -> tuple[Path, dict]:
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    return tmp, {"TMPDIR": str(tmp), "TEMP": str(tmp), "TMP": str(tmp)}


def start_builder(*args, env: dict, slow_renames: tuple[Path, float] | None = None) -> subprocess.Popen:
    """The builder started as ``python -m layered_brdf_addon.blender.asset_library ARGS`` (with
    ``slow_renames``, (marker, seconds), stopping before it places its catalogs)."""
    if slow_renames is None:
        cmd = [sys.executable, "-m", "layered_brdf_addon.blender.asset_library", *map(str, args)]
    else:
        marker, seconds = slow_renames
        cmd = [sys.executable, "-c", SLOW_RENAMES, str(marker), str(seconds), *map(str, args)]
    return subprocess.Popen(cmd, cwd=ROOT, env={**os.environ, "PYTHONUNBUFFERED": "1", **env},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for(found, proc: subprocess.Popen, what: str, limit: float = TIMEOUT) -> None:
    deadline = time.monotonic() + limit
    while not found() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert proc.poll() is None, f"the build ended before {what}: {proc.communicate(timeout=30)[1][-2000:]}"
    assert found(), f"no {what} within {limit:g} s"


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.kill()
        proc.wait(timeout=30)


# --- interrupts ------------------------------------------------------------------------------------
INTERRUPTS = [  # (moment, signal, a library there before)
    ("loading", "SIGINT", True),  # Blender loaded, the looks not made yet
    ("previews", "SIGINT", True),  # Cycles rendering a preview
    ("previews", "SIGTERM", False),
    ("renaming", "SIGINT", True),  # the new .blend in place, the catalogs not yet
    ("renaming", "SIGTERM", False),
]


@pytest.mark.slow
@pytest.mark.parametrize("moment, signame, earlier", INTERRUPTS, ids=["-".join(map(str, c)) for c in INTERRUPTS])
def test_an_interrupted_build_exits_130_and_leaves_the_previous_library_whole(tmp_path, tmpdir_env, moment,
                                                                              signame, earlier):
    tmp, env = tmpdir_env
    library = tmp_path / "looks"
    before = previous_library(library) if earlier else None
    marker = tmp_path / "renaming"
    previews = ["--preview-size", 16, "--samples", 1] if moment == "previews" else ["--preview-size", 0]
    proc = start_builder(library, "--presets", *NEW_LOOKS, *previews, env=env,
                         slow_renames=(marker, 2.0) if moment == "renaming" else None)
    try:
        if moment == "loading":
            wait_for(lambda: any(tmp.rglob("blender_*")), proc, "Blender's session folder")
        elif moment == "previews":
            wait_for(lambda: any(tmp.rglob("layered_brdf_preview_*")), proc, "a preview render")
            time.sleep(0.3)
        else:
            wait_for(marker.exists, proc, "the catalogs' rename")
            time.sleep(0.2)
        proc.send_signal(getattr(signal, signame))
        _, err = proc.communicate(timeout=TIMEOUT)
    finally:
        stop(proc)
    assert proc.returncode == 130, err[-3000:]
    for noise in ("Traceback", "ReferenceError", "KeyboardInterrupt"):
        assert noise not in err, err[-3000:]
    assert contents(library) == before  # the earlier library, every file as it was; or still no folder
    assert entries(tmp) == []  # Blender's session folder and the previews' folder went with the build


@pytest.mark.slow
def test_a_build_killed_between_its_renames_is_cleaned_up_by_the_next_build(tmp_path, tmpdir_env):
    tmp, env = tmpdir_env
    library = tmp_path / "looks"
    previous_library(library)
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(300)"])  # a build still running
    try:
        running = [f"{PARTIAL}{sleeper.pid}_0123456789ab.blend", f"{PARTIAL}{sleeper.pid}_0123456789ab.cats.txt"]
        for name in running:
            (library / name).write_text("a build still writing")
        (library / "notes.txt").write_text("the artist's")
        others_tmp = ["blender_AbCdEf", f"layered_brdf_preview_{sleeper.pid}_x1y2"]  # another Blender's; a live one's
        for name in others_tmp:
            (tmp / name).mkdir()
        marker = tmp_path / "renaming"
        proc = start_builder(library, "--presets", *NEW_LOOKS, "--preview-size", 0, env=env,
                             slow_renames=(marker, 600.0))
        try:
            wait_for(marker.exists, proc, "the catalogs' rename")
            proc.kill()
            proc.wait(timeout=30)
        finally:
            stop(proc)
        left = [n for n in entries(library) if n.startswith(PARTIAL) and n not in running]
        assert left, "kill -9 between the renames leaves the build's temporary files"
        assert sorted(set(entries(tmp)) - set(others_tmp)), "and its temp folder"
        res = subprocess.run([sys.executable, "-m", "layered_brdf_addon.blender.asset_library", library,
                              "--presets", *OLD_LOOKS, "--preview-size", "0"], cwd=ROOT,
                             env={**os.environ, **env}, capture_output=True, text=True, timeout=TIMEOUT)
        assert res.returncode == 0, res.stderr[-3000:]
        assert entries(library) == sorted(LIBRARY + running + ["notes.txt"])
        assert entries(tmp) == sorted(others_tmp)
    finally:
        sleeper.kill()
        sleeper.wait(timeout=30)


def test_the_next_build_removes_only_the_temporary_files_of_dead_builds(tmp_path):
    library = tmp_path / "looks"
    previous_library(library)
    dead = dead_pid()
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(300)"])
    try:
        gone = [f"{PARTIAL}{dead}_0123456789ab{suffix}" for suffix in
                (".blend", ".blend@", ".cats.txt", ".json", ".previous.blend", ".previous.cats.txt", ".previous.json")]
        kept = [f"{PARTIAL}{sleeper.pid}_0123456789ab.blend",  # its build still runs
                f"{PARTIAL}0123456789ab.blend",  # no process named: whose it is cannot be told
                f"{PARTIAL}{dead}_0123456789ab.txt", f"{PARTIAL}{dead}_notes.blend",  # not names a build makes
                f"layered_brdf_partial_{dead}_0123456789ab.blend", "notes.txt"]
        for name in gone + kept:
            (library / name).write_text("x")
        (library / f"{PARTIAL}{dead}_aaaaaaaaaaaa.json").mkdir()  # a folder: never a build's
        (library / f"{PARTIAL}{dead}_bbbbbbbbbbbb.json").symlink_to(library / "notes.txt")
        kept += [f"{PARTIAL}{dead}_aaaaaaaaaaaa.json", f"{PARTIAL}{dead}_bbbbbbbbbbbb.json"]
        write_asset_library(library, NEW_LOOKS, preview_size=0)
        assert entries(library) == sorted(LIBRARY + kept)
    finally:
        sleeper.kill()
        sleeper.wait(timeout=30)


# --- a full disk, a failed rename -------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".cats.txt", ".json"])
def test_a_full_disk_keeps_the_previous_library_and_leaves_no_partial_file(tmp_path, monkeypatch, suffix):
    library = tmp_path / "looks"
    before = previous_library(library)
    real_write_text = Path.write_text

    def disk_fills_up(self, data, *args, **kwargs):
        if self.name.startswith(PARTIAL) and self.name.endswith(suffix):
            real_write_text(self, data[: len(data) // 2], *args, **kwargs)
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))
        return real_write_text(self, data, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", disk_fills_up)
    with pytest.raises(OSError) as e:
        write_asset_library(library, NEW_LOOKS, preview_size=0)
    assert e.value.errno == errno.ENOSPC
    assert contents(library) == before


@pytest.mark.parametrize("earlier", [True, False], ids=["over a library", "new folder"])
def test_a_failed_rename_puts_the_previous_library_back(tmp_path, monkeypatch, earlier):
    library = tmp_path / "looks"
    before = previous_library(library) if earlier else None
    real_replace = os.replace
    failed = []

    def catalogs_cannot_be_placed(src, dst, *args, **kwargs):
        if Path(dst).name == CATALOG_FILE and not failed:
            failed.append(dst)
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(dst))
        return real_replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", catalogs_cannot_be_placed)
    with pytest.raises(IsADirectoryError):
        write_asset_library(library, NEW_LOOKS, preview_size=0)
    assert failed, "the catalogs' rename was not reached"
    assert contents(library) == before


# --- folders where the library's files belong -------------------------------------------------------
def _folder_in_place_of(library: Path, name: str) -> Path:
    """``library`` with a folder (holding a file) named ``name``; beside the previous library for the
    catalogs, alone for the record (a folder the library never wrote to)."""
    if name == CATALOG_FILE:
        previous_library(library)
        (library / name).unlink()
    else:
        library.mkdir()
    (library / name).mkdir()
    (library / name / "kept.txt").write_text("x")
    return library / name


@pytest.mark.parametrize("name", [CATALOG_FILE, MANIFEST_FILE])
def test_a_folder_where_a_library_file_belongs_is_refused_before_anything_is_made(tmp_path, monkeypatch, name):
    library = tmp_path / "looks"
    folder = _folder_in_place_of(library, name)
    before = contents(library)

    def too_late(*_args, **_kwargs):
        raise AssertionError("looks made or rendered before the folder was refused")

    monkeypatch.setattr(looks_library, "_make_looks", too_late)
    monkeypatch.setattr(assets, "render_previews", too_late)
    with pytest.raises(ParameterError) as e:
        write_asset_library(library, NEW_LOOKS, preview_size=16, samples=1)
    assert e.value.name == "directory"
    assert f"'{folder}' is a folder" in str(e.value)
    assert contents(library) == before and entries(folder) == ["kept.txt"]


def test_the_command_line_exits_2_naming_a_catalog_folder_and_changes_nothing(tmp_path, tmpdir_env):
    tmp, env = tmpdir_env
    library = tmp_path / "looks"
    folder = _folder_in_place_of(library, CATALOG_FILE)
    before = contents(library)
    res = subprocess.run([sys.executable, "-m", "layered_brdf_addon.blender.asset_library", library,
                          "--presets", *NEW_LOOKS, "--preview-size", "16", "--samples", "1"], cwd=ROOT,
                         env={**os.environ, **env}, capture_output=True, text=True, timeout=TIMEOUT)
    assert res.returncode == 2, res.stderr[-3000:]
    assert f"'{folder}' is a folder" in res.stderr
    assert "Errno" not in res.stderr and "Traceback" not in res.stderr, res.stderr[-3000:]
    assert contents(library) == before
    assert entries(tmp) == []
