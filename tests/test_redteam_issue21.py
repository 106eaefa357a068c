"""Issue 21 red-team findings, each through the real CLI on a real folder."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import without_progress

#: A z = 1000 drive (r = 7 mm, just below its undercut limit of 7.17 mm).
Z1000 = """
[design]
tooth_count = 1000
cam_radius = 5000.0
roller_radius = 7.0
roller_length = 12.0
eccentricity = 3.5
[export]
formats = ["interference"]
interference_positions = 36
"""


def _run(tmp_path: Path, scene: str, *args: str) -> subprocess.CompletedProcess:
    (tmp_path / "notes.txt").write_text("user file\n")
    path = tmp_path / "scene.toml"
    path.write_text(scene)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(path), "--out", str(tmp_path / "out"), *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=dict(os.environ),
        timeout=600,
    )


def test_exact_interference_is_not_refused_for_a_mesh_it_does_not_make(tmp_path):
    # The exact clearance meshes nothing: the assembly mesh's triangle limit
    # (chord_tolerance, here its default 0.001 that the scene never set) must
    # not refuse it. Before the fix: exit 2, "chord_tolerance = 0.001: too fine".
    r = _run(tmp_path, Z1000)
    assert r.returncode == 0, r.stderr
    assert "chord_tolerance" not in r.stderr
    assert (tmp_path / "out" / "clearance.csv").is_file()
    assert (tmp_path / "notes.txt").read_text() == "user file\n"


def test_mesh_interference_still_meets_the_triangle_limit(tmp_path):
    r = _run(tmp_path, Z1000.replace("formats", 'interference_method = "mesh"\nformats'))
    assert r.returncode == 2
    line = r.stderr.strip().splitlines()[-1]
    assert "chord_tolerance" in line and "triangles" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_the_last_worker_killed_later_in_the_run_leaks_no_dask_log_or_traceback(tmp_path):
    """Stopped, then killed, while results were being gathered, the run printed
    distributed's 'Couldn't gather ... rescheduling' warning and an asyncio
    'Task exception was never retrieved ... Traceback ... AllExit' block before
    its one line."""
    pytest.importorskip("dask.distributed")
    import signal
    import subprocess
    import sys
    import time

    import psutil

    from tests.test_dask_faults import MC, Cluster

    cluster = Cluster(tmp_path)
    try:
        # The worker stops itself as its first task starts (an event, not a time).
        cluster.add_workers(1, fault="SIGSTOP")
        w = cluster.workers[0]
        (tmp_path / "mc.toml").write_text(MC.format(samples=400))
        p = subprocess.Popen(
            [sys.executable, "-m", "corr_cad", "run", "mc.toml", "--out", "out",
             "--executor", "dask", "--scheduler", cluster.address,
             "--dask-no-workers-timeout", "3", "--dask-stall-timeout", "600"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
        )  # fmt: skip
        while psutil.Process(w.pid).status() != psutil.STATUS_STOPPED:
            assert p.poll() is None, p.communicate()
            time.sleep(0.05)
        # Stopped, the worker holds the client's result() calls until their 1 s
        # polls time out (each leaves a gather pending); then it dies.
        time.sleep(3.0)
        os.kill(w.pid, signal.SIGKILL)
        stdout, stderr = p.communicate(timeout=600)
        proc = subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr)
    finally:
        cluster.close()
    assert proc.returncode == 2, proc.stderr
    other = [
        ln
        for ln in without_progress(proc.stderr).splitlines()
        if ln.strip() and not ln.startswith("corr-cad: ")
    ]
    assert other == [], proc.stderr
    err = [ln for ln in proc.stderr.splitlines() if ln.startswith("corr-cad: error")]
    assert len(err) == 1 and "every worker left the scheduler" in err[0], proc.stderr


def test_a_dask_connection_keeps_distributed_and_asyncio_logs_off_the_terminal(tmp_path):
    """Deterministic half of the test above: once connected, what distributed.client
    (its own WARNING level in distributed's config) and asyncio would log stays off
    stderr; the run's own lines are its only output."""
    pytest.importorskip("dask.distributed")
    from tests.test_dask_faults import Cluster

    cluster = Cluster(tmp_path)
    try:
        cluster.add_workers(1)
        code = (
            "import logging, sys\n"
            "from corr_cad.run.dask_exec import DaskTimeouts, connect\n"
            f"ex = connect({cluster.address!r}, DaskTimeouts())\n"
            "logging.getLogger('distributed.client').warning(\"Couldn't gather 1 keys\")\n"
            "logging.getLogger('asyncio').error('Task exception was never retrieved')\n"
            "ex.close()\n"
            "print('done', file=sys.stderr)\n"
        )
        r = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=600
        )
    finally:
        cluster.close()
    assert r.returncode == 0, r.stderr
    assert r.stderr.strip() == "done", r.stderr
