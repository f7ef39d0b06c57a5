"""A flaky render farm: a bad --report target, something that is not a Dask scheduler,
Dask workers that die, and temporary files left by renders that end badly.

Everything runs as local processes on 127.0.0.1, every subprocess call has a timeout
(a hang fails the test instead of blocking the suite), renders are 32 px with one
sample unless a test needs a render that lasts.
"""
from __future__ import annotations

import http.server
import json
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from process_helpers import interrupt_once_started, start_cli, stop

REPO = Path(__file__).resolve().parents[1]
TIMEOUT = 240

SMALL_JOBS = """
[defaults]
resolution = 32
samples = 1

[[job]]
name = "clay"
preset = "fig3_clay"

[[job]]
name = "film"
preset = "fig3_thin_film"
"""


def cli(*args, cwd: Path, env: dict | None = None, timeout: float = TIMEOUT) -> subprocess.CompletedProcess:
    """``python -m layered_brdf_addon ARGS`` in ``cwd``."""
    return subprocess.run([sys.executable, "-m", "layered_brdf_addon", *map(str, args)], cwd=cwd,
                          env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
                          capture_output=True, text=True, timeout=timeout)


def entries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.fixture
def job_dir(tmp_path) -> Path:
    (tmp_path / "jobs.toml").write_text(SMALL_JOBS)
    return tmp_path


# ---------------------------------------------------------------------------
# 19. --report is checked before any job runs, and written atomically
def _report_targets(tmp_path: Path) -> dict[str, Path]:
    (tmp_path / "a_folder.json").mkdir()
    (tmp_path / "plain_file").write_text("x")
    targets = {"is a folder": tmp_path / "a_folder.json", "under a file": tmp_path / "plain_file" / "r.json"}
    if sys.platform.startswith("linux"):
        targets["unwritable folder"] = Path("/proc/layered_brdf_report.json")  # even root cannot create it
    return targets


@pytest.mark.slow
@pytest.mark.parametrize("case", ["is a folder", "under a file", "unwritable folder"])
def test_bad_report_target_fails_before_any_job_runs(job_dir, case):
    target = _report_targets(job_dir).get(case)
    if target is None:
        pytest.skip("needs /proc (Linux)")
    t0 = time.monotonic()
    res = cli("batch", "jobs.toml", "--output-dir", "out", "--report", target, "--no-progress", cwd=job_dir)
    assert res.returncode == 2, res.stderr
    assert "--report" in res.stderr and "Traceback" not in res.stderr, res.stderr
    assert not (job_dir / "out").exists(), "jobs rendered before the report target was checked"
    assert time.monotonic() - t0 < 60


def test_report_target_check_and_atomic_write(tmp_path, monkeypatch):
    from layered_brdf_addon.cli import runner
    from layered_brdf_addon.model.params import ParameterError

    for case, target in _report_targets(tmp_path).items():
        with pytest.raises(ParameterError, match="--report"):
            runner.check_report_target(target)
    with pytest.raises(ParameterError, match="--report"):
        runner.check_report_target(tmp_path / "report.txt")
    # a folder that does not exist yet is fine when it can be made; the check leaves nothing
    assert runner.check_report_target(tmp_path / "new" / "r.json") == tmp_path / "new" / "r.json"
    assert not (tmp_path / "new").exists()

    report = tmp_path / "r.json"
    runner.write_report(report, {"results": [1]})
    assert json.loads(report.read_text()) == {"results": [1]}

    def broken(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", broken)
    with pytest.raises(OSError):
        runner.write_report(report, {"results": [2]})
    assert json.loads(report.read_text()) == {"results": [1]}, "a failed write must keep the old report"
    assert entries(tmp_path) == sorted(["a_folder.json", "plain_file", "r.json"])


# ---------------------------------------------------------------------------
# 20. --scheduler that is not a Dask scheduler; Dask workers that die
class _Quiet(http.server.BaseHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture
def http_server():
    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Quiet)
    t = threading.Thread(target=srv.serve_forever, daemon=True)
    t.start()
    yield srv.server_address[1]
    srv.shutdown()
    srv.server_close()


@pytest.fixture
def silent_server():
    """Accepts connections and never sends a byte."""
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    held, stop_flag = [], threading.Event()

    def accept():
        sock.settimeout(0.2)
        while not stop_flag.is_set():
            try:
                conn, _ = sock.accept()
                held.append(conn)
            except OSError:
                pass

    t = threading.Thread(target=accept, daemon=True)
    t.start()
    yield sock.getsockname()[1]
    stop_flag.set()
    t.join(timeout=5)
    for c in held:
        c.close()
    sock.close()


@pytest.mark.slow
@pytest.mark.parametrize("server", ["http_server", "silent_server"])
def test_scheduler_that_is_not_dask_fails_cleanly(job_dir, server, request):
    port = request.getfixturevalue(server)
    t0 = time.monotonic()
    res = cli("batch", "jobs.toml", "--output-dir", "out", "--scheduler", f"tcp://127.0.0.1:{port}",
              "--no-progress", cwd=job_dir, timeout=90)
    seconds = time.monotonic() - t0
    assert res.returncode == 2, res.stderr
    assert "--scheduler" in res.stderr, res.stderr
    for bad in ("Traceback", "MemoryError", "EiB"):
        assert bad not in res.stderr, res.stderr
    assert seconds < 10 + 30, f"took {seconds:.0f} s for a 10 s connect timeout"
    assert not (job_dir / "out").exists()


def _dask_cli() -> Path:
    exe = Path(sys.executable).parent / "dask"
    if not exe.exists():
        pytest.skip(f"no dask command next to {sys.executable}")
    return exe


class DaskCluster:
    """A real ``dask scheduler`` and workers (no nanny: a killed worker stays dead) on 127.0.0.1."""

    def __init__(self, folder: Path, n_workers: int):
        self.folder = folder
        self.procs: list[subprocess.Popen] = []
        self.workers: list[subprocess.Popen] = []
        exe = _dask_cli()
        info = folder / "scheduler.json"
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        log = open(folder / "dask.log", "w")
        self.log = log
        self.procs.append(subprocess.Popen([str(exe), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                            "--no-dashboard", "--scheduler-file", str(info)],
                                           stdout=log, stderr=subprocess.STDOUT, env=env, cwd=folder))
        deadline = time.monotonic() + 60
        while not info.exists() and time.monotonic() < deadline:
            if self.procs[0].poll() is not None:
                self.close()
                pytest.skip("dask scheduler did not start: " + (folder / "dask.log").read_text()[-500:])
            time.sleep(0.2)
        time.sleep(0.3)
        try:
            self.address = json.loads(info.read_text())["address"]
        except (OSError, ValueError, KeyError):
            self.close()
            pytest.skip("dask scheduler did not start within 60 s")
        for k in range(n_workers):
            w = subprocess.Popen([str(exe), "worker", self.address, "--nthreads", "1", "--no-nanny",
                                  "--no-dashboard", "--host", "127.0.0.1", "--name", f"w{k}"],
                                 stdout=log, stderr=subprocess.STDOUT, env=env, cwd=folder)
            self.procs.append(w)
            self.workers.append(w)
        self._wait_for_workers(n_workers)

    def _wait_for_workers(self, n: int) -> None:
        code = ("import sys; from distributed import Client; c = Client(sys.argv[1], timeout='20s'); "
                "c.wait_for_workers(int(sys.argv[2]), timeout=60); c.close()")
        try:
            subprocess.run([sys.executable, "-c", code, self.address, str(n)], check=True, timeout=90,
                           capture_output=True, text=True)
        except (subprocess.CalledProcessError, subprocess.TimeoutExpired) as e:
            self.close()
            pytest.skip(f"dask workers did not start: {e}")

    def close(self) -> None:
        for p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=10)
        self.log.close()


@pytest.fixture
def dask_cluster(tmp_path):
    made = []

    def make(n_workers: int) -> DaskCluster:
        c = DaskCluster(tmp_path, n_workers)
        made.append(c)
        return c

    yield make
    for c in made:
        c.close()


def _wait_for_renders(folder: Path, proc: subprocess.Popen, limit: float = 90) -> None:
    """Until a job's render has begun (it makes the output folder when it starts rendering)."""
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline and proc.poll() is None:
        if folder.exists():
            time.sleep(1.0)
            return
        time.sleep(0.1)


SLOW_JOBS = """
[defaults]
resolution = 320
samples = 256

[[job]]
name = "a"
preset = "fig4_tilted"

[[job]]
name = "b"
preset = "fig3_clay"
"""


@pytest.mark.slow
def test_batch_whose_workers_all_die_ends_within_its_timeout(tmp_path, dask_cluster):
    cluster = dask_cluster(1)
    (tmp_path / "jobs.toml").write_text(SLOW_JOBS)
    proc = start_cli("batch", "jobs.toml", "--output-dir", "out", "--scheduler", cluster.address, "--timeout", 30,
                     "--report", "report.json", "--no-progress", cwd=tmp_path)
    try:
        _wait_for_renders(tmp_path / "out", proc)
        assert proc.poll() is None, proc.communicate(timeout=30)
        cluster.workers[0].kill()
        t_kill = time.monotonic()
        out, err = proc.communicate(timeout=30 + 60)
        waited = time.monotonic() - t_kill
    finally:
        stop(proc)
    assert proc.returncode == 1, err
    assert "no Dask worker" in err and "Traceback" not in err, err
    assert waited < 30 + 20, f"ended {waited:.0f} s after the last worker died (--timeout 30)"
    report = json.loads((tmp_path / "report.json").read_text())
    assert {r["status"] for r in report["results"]} <= {"cancelled", "crashed"}
    assert all(r["error"] for r in report["results"])


@pytest.mark.slow
def test_one_of_two_workers_killed_all_jobs_complete(tmp_path, dask_cluster):
    cluster = dask_cluster(2)
    jobs = "[defaults]\nresolution = 160\nsamples = 16\n" + "".join(
        f'\n[[job]]\nname = "j{k}"\npreset = "{p}"\n'
        for k, p in enumerate(["fig3_clay", "fig3_thin_film", "fig4_tilted", "fig3_clay"]))
    (tmp_path / "jobs.toml").write_text(jobs)
    proc = start_cli("batch", "jobs.toml", "--output-dir", "out", "--scheduler", cluster.address, "--timeout", 120,
                     "--report", "report.json", "--no-progress", cwd=tmp_path)
    try:
        _wait_for_renders(tmp_path / "out", proc)
        cluster.workers[0].kill()
        out, err = proc.communicate(timeout=240)
    finally:
        stop(proc)
    assert proc.returncode == 0, err
    report = json.loads((tmp_path / "report.json").read_text())
    assert [r["status"] for r in report["results"]] == ["ok"] * 4, report


# ---------------------------------------------------------------------------
# 21. temporary files: OSL compiles, interrupted and killed renders
@pytest.fixture
def tmpdir_env(tmp_path) -> tuple[Path, dict]:
    t = tmp_path / "tmp"
    t.mkdir()
    return t, {"TMPDIR": str(t), "TEMP": str(t), "TMP": str(t)}


def _oso_in_source() -> list[str]:
    return sorted(str(p.relative_to(REPO)) for p in (REPO / "osl").glob("*.oso"))


@pytest.mark.slow
def test_osl_render_leaves_no_temp_files(tmp_path, tmpdir_env):
    tmp, env = tmpdir_env
    before = _oso_in_source()
    res = cli("render", "--preset", "fig3_thin_film", "--backend", "osl", "--resolution", 32,
              "--output", tmp_path / "out" / "x", cwd=tmp_path, env=env, timeout=120)
    assert res.returncode == 0, res.stderr
    assert entries(tmp) == []
    assert _oso_in_source() == before == []


@pytest.mark.slow
def test_osl_compile_in_blender_leaves_no_temp_files(tmp_path, tmpdir_env):
    """The add-on in Blender (no command line): compiling the script node leaves nothing."""
    tmp, env = tmpdir_env
    code = """
import os, sys, tempfile
import bpy
from layered_brdf_addon.blender.scene import SceneSpec, build_scene, reset_blender
from layered_brdf_addon.blender.material import apply_layered_material
from layered_brdf_addon.model.presets import preset
reset_blender()
obj = build_scene(SceneSpec(osl=True))[0]
apply_layered_material(obj, preset("fig3_thin_film"), "osl")
apply_layered_material(obj, preset("fig4_tilted"), "osl")
session = os.path.basename(os.path.normpath(bpy.app.tempdir))
print(sorted(n for n in os.listdir(tempfile.gettempdir()) if n != session))
"""
    res = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env={**os.environ, **env},
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip().splitlines()[-1] == "[]"
    assert entries(tmp) == []


@pytest.mark.slow
def test_interrupted_render_leaves_no_temp_folder(tmp_path, tmpdir_env):
    tmp, env = tmpdir_env
    out = tmp_path / "out"
    proc = start_cli("render", "--preset", "fig4_tilted", "--resolution", 320, "--samples", 64,
                     "--output", out / "x", cwd=tmp_path, env=env)
    try:
        err, _ = interrupt_once_started(proc, out)
    finally:
        stop(proc)
    assert proc.returncode == 130, err
    assert entries(tmp) == []
    assert entries(out) == []


@pytest.mark.slow
def test_render_killed_during_the_aov_passes_is_swept_by_the_next_run(tmp_path, tmpdir_env):
    tmp, env = tmpdir_env
    proc = start_cli("render", "--preset", "fig4_tilted", "--backend", "osl", "--resolution", 256,
                     "--samples", 64, "--output", tmp_path / "out" / "x", cwd=tmp_path, env=env)
    try:
        deadline = time.monotonic() + 180
        while proc.poll() is None and time.monotonic() < deadline:
            if any(tmp.rglob("layered_brdf_aov_*")):
                break
            time.sleep(0.05)
        assert proc.poll() is None, "the render ended before its AOV passes could be killed"
        assert any(tmp.rglob("layered_brdf_aov_*")), "no AOV pass folder within 180 s"
        time.sleep(0.3)
        proc.kill()
        proc.wait(timeout=30)
    finally:
        stop(proc)
    assert entries(tmp) != [], "kill -9 leaves the dead render's folder (swept by the next run)"
    res = cli("render", "--preset", "fig3_clay", "--backend", "osl", "--resolution", 32,
              "--output", tmp_path / "out" / "y", cwd=tmp_path, env=env, timeout=120)
    assert res.returncode == 0, res.stderr
    assert entries(tmp) == []


def test_sweep_removes_only_folders_of_dead_processes(tmp_path):
    from layered_brdf_addon.blender import tempdirs

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait(timeout=30)
    mine = tempdirs.owned_dir("aov", tmp_path)
    gone = tmp_path / f"layered_brdf_aov_{dead.pid}_abc123"
    gone.mkdir()
    (gone / "render.exr").write_bytes(b"x")
    other = tmp_path / "layered_brdf_preview_1_x"  # process 1 is alive: kept
    other.mkdir()
    stranger = tmp_path / "blender_abc"
    stranger.mkdir()
    assert tempdirs.owner_pid(mine) == os.getpid()
    assert tempdirs.sweep_stale(tmp_path) == [gone]
    assert entries(tmp_path) == sorted([mine.name, other.name, stranger.name])
    shutil.rmtree(mine)
