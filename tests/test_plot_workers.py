"""The fixed cost of a small run: plot workers draw its figures, few samples stay here.

With the process executor the CLI forks plot workers before the stages
(:mod:`corr_cad.run.stages.plot_workers`): they import matplotlib while the run
computes, then draw the Monte Carlo's and the datasheet's PNGs; the main process
never imports matplotlib for them. A Monte Carlo whose samples the cost model
prices below a process pool's start (``costs_montecarlo.pool_pays``) solves them
in the main process and starts no pool. Neither changes a byte of any file.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import textwrap
import tomllib
from concurrent.futures import ProcessPoolExecutor

import pytest

from corr_cad.run.budget.costs_montecarlo import (
    POOL_MIN_SECONDS,
    pool_pays,
    sample_seconds_one_core,
)
from corr_cad.run.scene.scene import parse_scene
from corr_cad.run.stages.plot_workers import draw, wait
from tests.helpers import folder_files

#: The drive of the fixed-cost benchmark (``bench_drive._cli_fixed_cost``) with the
#: datasheet too: Palmgren's law, 40 needles 6 x 12 mm with a 5 um clearance, one sample.
SCENE = """
[export]
formats = ["montecarlo", "datasheet"]
[load]
input_torque = 1.1e5
[solver]
model = "drive"
contact_law = "palmgren"
[tolerances]
roller_radius = { normal = 0.001 }
[montecarlo]
samples = {samples}
positions = 72
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
diametral_clearance = 0.005
"""


def _scene(samples: int = 1):
    return parse_scene(tomllib.loads(SCENE.replace("{samples}", str(samples))), name="s")


def test_few_samples_start_no_sample_pool_and_many_do():
    from corr_cad.run.cli import _executor

    args = argparse.Namespace(executor="process", workers=2, scheduler=None)
    few = _scene(1)
    # One sample (72 positions and its datasheet pass): milliseconds, against a worker's start.
    assert sample_seconds_one_core(few) < 0.1 * POOL_MIN_SECONDS
    assert not pool_pays(few)
    with _executor(args, few) as executor:
        assert executor is None
    many = _scene(2000)
    assert pool_pays(many)
    with _executor(args, many) as executor:
        assert isinstance(executor, ProcessPoolExecutor)


def test_a_drawing_s_error_is_raised_here_once_every_drawing_is_done(tmp_path):
    from corr_cad.run.cli import _start_pool

    pool = _start_pool(ProcessPoolExecutor, 1)
    try:
        bad = draw(pool, "corr_cad.export.plots_tolerance", "no_such_figure")
        good = draw(pool, "os.path", "join", "a", "b")
        with pytest.raises(AttributeError, match="no_such_figure"):
            wait([bad, good])
        assert good.result() == os.path.join("a", "b")
    finally:
        pool.shutdown()
    with pytest.raises(AttributeError, match="no_such_figure"):  # drawn here: at once
        draw(None, "corr_cad.export.plots_tolerance", "no_such_figure")


def _cli(folder, *extra) -> dict:
    (folder / "s.toml").write_text(SCENE.replace("{samples}", "1"))
    done = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet", *extra],
        cwd=folder,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    return folder_files(folder / "out")


@pytest.mark.slow
def test_the_cli_s_plot_workers_write_the_serial_runs_bytes(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    pooled = _cli(tmp_path / "a")
    serial = _cli(tmp_path / "b", "--executor", "serial")
    assert {"montecarlo.png", "hysteresis.png", "transmission_error.png"} <= set(pooled)
    assert pooled == serial


_PROBE = textwrap.dedent(
    """
    import json, sys, tomllib
    from pathlib import Path

    seen = []

    class Probe:  # does the main process ever ask for matplotlib?
        def find_spec(self, name, path=None, target=None):
            if name == "matplotlib":
                seen.append(name)
            return None

    sys.meta_path.insert(0, Probe())
    from corr_cad.run.cli import _start_pool
    from corr_cad.run.pipeline import run_scene, scene_plan
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.concurrent import kill_pool
    from corr_cad.run.stages.plot_workers import plot_pool

    scene = parse_scene(tomllib.loads(sys.argv[2]), name="s")
    out = Path(sys.argv[1])
    (out / "workers").mkdir()
    with plot_pool(_start_pool, kill_pool, scene_plan(scene), 2) as plotter:
        assert plotter is not None
        run_scene(scene, out / "workers", plotter=plotter)
    imported = bool(seen)
    (out / "here").mkdir()
    run_scene(scene, out / "here")
    print(json.dumps({"matplotlib": imported, "here": bool(seen)}))
    """
)


@pytest.mark.slow
def test_the_main_process_never_imports_matplotlib_for_the_plot_workers_figures(tmp_path):
    scene = SCENE.replace("{samples}", "1")
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, str(tmp_path), scene],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.strip().splitlines()[-1]) == {"matplotlib": False, "here": True}
    assert folder_files(tmp_path / "workers") == folder_files(tmp_path / "here")


def test_the_estimate_counts_the_plot_workers_and_no_pool_for_few_samples():
    from corr_cad.run.budget.resources import PLOT_WORKER_BYTES, estimate

    few = _scene(1)
    two, four = estimate(few, 2, "process"), estimate(few, 4, "process")
    serial = estimate(few, 1, "serial")
    # No pool worker: one plot worker on two cores, two on four; the main process as serial.
    assert two.worker_memory == PLOT_WORKER_BYTES
    assert four.worker_memory == 2 * PLOT_WORKER_BYTES
    assert serial.worker_memory == 0.0
    assert two.main_memory == serial.main_memory
    assert two.stages["montecarlo"].seconds == serial.stages["montecarlo"].seconds
    many = estimate(_scene(2000), 2, "process")  # the pool's two workers, and the plot worker
    assert many.worker_memory > 3 * PLOT_WORKER_BYTES
