"""Red-team findings on the plot workers and the few-sample pool decision, run as a user
runs the tool (the CLI in its own process)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

#: The CLI in a process allowed one core (``taskset -c 0``, a container's cpuset), with
#: every process pool it starts recorded (its size).
_ONE_CORE = textwrap.dedent(
    """
    import concurrent.futures as cf, json, os, sys

    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    sizes = []

    class Recorded(cf.ProcessPoolExecutor):
        def __init__(self, *a, **kw):
            super().__init__(*a, **kw)
            sizes.append(self._max_workers)

    cf.ProcessPoolExecutor = Recorded
    from corr_cad.run.cli import main

    code = main(["run", "s.toml", "--out", "out", "--quiet"])
    print(json.dumps({"code": code, "pools": sizes}))
    """
)

#: A paper-model Monte Carlo whose samples pay for a pool (``pool_pays``) and whose only
#: picture is montecarlo.png (a plot worker where the run has two cores or more).
_SCENE = """
[export]
formats = ["montecarlo"]
[load]
input_torque = 1.1e5
[tolerances]
roller_radius = { normal = 0.001 }
[montecarlo]
samples = 2000
positions = 36
"""


@pytest.mark.slow
@pytest.mark.skipif(
    not hasattr(os, "sched_setaffinity") or len(os.sched_getaffinity(0)) < 2,
    reason="needs two usable cores and sched_setaffinity",
)
def test_a_run_allowed_one_core_starts_the_processes_its_estimate_counts(tmp_path):
    """The estimate (and ``--max-memory``) counts the usable cores (the affinity); the
    sample pool and the plot workers were sized by ``os.cpu_count()``: on one allowed
    core of two the run started two sample workers and a plot worker where its
    estimate counted one worker and no plot worker."""
    from corr_cad.run.budget.costs_montecarlo import pool_pays
    from corr_cad.run.scene.scene import load_scene

    (tmp_path / "s.toml").write_text(_SCENE)
    assert pool_pays(load_scene(tmp_path / "s.toml"))
    done = subprocess.run(
        [sys.executable, "-c", _ONE_CORE],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    got = json.loads(done.stdout.strip().splitlines()[-1])
    # One sample worker, as the estimate counts on one core; no plot worker beside it.
    assert got == {"code": 0, "pools": [1]}


#: A few-sample Monte Carlo: no sample pool, its montecarlo.png drawn by a plot worker
#: where the run has two cores (in the main process with --executor serial).
_FEW = _SCENE.replace("samples = 2000", "samples = 4")


def _broken_matplotlib(folder, *extra) -> tuple[int, list[str]]:
    """The CLI where matplotlib cannot be imported (a broken install: a ``matplotlib``
    package first on the path whose import raises)."""
    folder.mkdir()
    (folder / "s.toml").write_text(_FEW)
    (folder / "notes.txt").write_text("mine\n")
    fake = folder.parent / f"{folder.name}_site" / "matplotlib"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("raise ImportError('matplotlib is broken here')\n")
    path = os.pathsep.join(x for x in (str(fake.parent), os.environ.get("PYTHONPATH")) if x)
    env = dict(os.environ, PYTHONPATH=path)
    done = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet", *extra],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt", "s.toml"]
    return done.returncode, done.stderr.splitlines()


def test_a_plot_module_that_fails_to_import_is_reported_as_in_a_serial_run(tmp_path):
    """The plot worker imported its modules in the pool's initializer: an import error
    there printed Python's "Exception in initializer:" traceback and broke the pool ("a
    worker process died (killed, or out of memory?)", exit 2), where a serial run says
    what failed in one line. The error is now raised by the drawing, in its stage."""
    pooled = _broken_matplotlib(tmp_path / "a")
    serial = _broken_matplotlib(tmp_path / "b", "--executor", "serial")
    assert pooled == serial
    code, err = pooled
    assert code == 3 and len(err) == 1 and "matplotlib is broken here" in err[0], err


def test_a_backend_the_user_set_for_other_programs_is_not_the_run_s(tmp_path):
    """Every picture is drawn by Agg: an ``MPLBACKEND`` that matplotlib does not know (its
    import fails) or another one leaves the run and its files as they are without it."""
    digests = []
    for backend in ("no-such-backend", "svg", None):
        folder = tmp_path / str(backend)
        folder.mkdir()
        (folder / "s.toml").write_text(_FEW)
        env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
        if backend:
            env["MPLBACKEND"] = backend
        done = subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
            cwd=folder,
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 0 and not done.stderr, done.stderr
        digests.append((folder / "out" / "montecarlo.png").read_bytes())
    assert digests[0] == digests[1] == digests[2]


def test_a_drawing_s_warning_reaches_the_run_s_warnings_not_the_worker_s_stderr(capfd):
    """A plot worker printed its drawing's warnings on stderr at once (even in a run that
    then failed, whose one line is its error); serially the CLI collects them and shows
    them once the run has succeeded. They are now raised again here, with the result."""
    import warnings
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.run.cli import _start_pool
    from corr_cad.run.stages.plot_workers import draw

    pool = _start_pool(ProcessPoolExecutor, 1)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert draw(pool, "warnings", "warn", "drawn with a warning").result() is None
    finally:
        pool.shutdown()
    assert [(w.category, str(w.message)) for w in caught] == [(UserWarning, "drawn with a warning")]
    assert "drawn with a warning" not in capfd.readouterr().err
