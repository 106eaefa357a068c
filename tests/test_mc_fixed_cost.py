"""The Monte Carlo stage's fixed cost: the nominal metrics in the pool, warm workers.

The stage hands the nominal design's metrics to the local process pool in
its first task, before the first chunk of samples (the main process then
never loads numba nor the compiled kernels, and one worker loads them for
both), and the CLI's pool workers import the kernels' modules when they
start. While the pool works, a thread of the main process imports matplotlib
for the plot; the binding interval's normal quantile comes from
``scipy.special.ndtri`` (``scipy.stats`` is never imported). None of this
changes a byte of the stage's files.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from corr_cad.run.bench.bench_scaling import SCENE
from corr_cad.run.pipeline import run_scene
from corr_cad.run.pools import WARM_MODULES, _worker_init
from corr_cad.run.scene.scene import parse_scene
from tests.helpers import folder_files


def _scene(samples: int = 12):
    import tomllib

    return parse_scene(tomllib.loads(SCENE.replace("{samples}", str(samples))), name="mc")


def _run(scene, out, executor=None) -> None:
    out.mkdir()
    run_scene(scene, out, executor=executor)


class _Recording(ThreadPoolExecutor):
    """A pool that records the functions handed to it."""

    def __init__(self) -> None:
        super().__init__(1)
        self.names: list[str] = []

    def submit(self, fn, *args, **kwargs):
        self.names.append(fn.__name__)
        return super().submit(fn, *args, **kwargs)


@pytest.mark.slow
def test_the_nominal_metrics_ride_in_the_pools_first_task_and_the_files_keep_their_bytes(tmp_path):
    scene = _scene()
    _run(scene, tmp_path / "serial")
    with _Recording() as pool:
        _run(scene, tmp_path / "pool", pool)
    # 12 samples, one chunk: the nominal metrics and the samples in one task
    assert pool.names == ["_with_nominal"]
    assert folder_files(tmp_path / "pool") == folder_files(tmp_path / "serial")
    nominal = json.loads((tmp_path / "pool" / "montecarlo_summary.json").read_text())["nominal"]
    assert {"lost_motion_arcmin", "peak_gear_force"} <= set(nominal)


@pytest.mark.slow
def test_with_several_chunks_only_the_first_carries_the_nominal_metrics(tmp_path):
    scene = _scene(120)  # one worker: chunks of 50 samples, three of them
    _run(scene, tmp_path / "serial")
    with _Recording() as pool:
        _run(scene, tmp_path / "pool", pool)
    assert pool.names == ["_with_nominal", "_chunk_task", "_chunk_task"]
    assert folder_files(tmp_path / "pool") == folder_files(tmp_path / "serial")


@pytest.mark.slow
def test_warm_process_workers_write_the_serial_runs_bytes(tmp_path):
    scene = _scene()
    _run(scene, tmp_path / "serial")
    init = (os.getpid(), WARM_MODULES)
    with ProcessPoolExecutor(2, initializer=_worker_init, initargs=init) as pool:
        _run(scene, tmp_path / "pool", pool)
    assert folder_files(tmp_path / "pool") == folder_files(tmp_path / "serial")


def test_workers_import_the_kernels_ahead_only_where_the_samples_use_them():
    import tomllib

    from corr_cad.run.cli import _warm_modules

    def scene(text: str):
        return parse_scene(tomllib.loads(text), name="s")

    assert _warm_modules(_scene()) == WARM_MODULES  # the datasheet metrics: always compiled
    mc = "[load]\ninput_torque = 1.1e5\n[tolerances]\nroller_radius = { normal = 0.001 }\n"
    few = scene('[export]\nformats = ["montecarlo"]\n' + mc + "[montecarlo]\nsamples = 100\n")
    many = scene(
        '[export]\nformats = ["montecarlo"]\n' + mc + "[montecarlo]\nsamples = 30000\n"
        "positions = 36\n"  # 1.08e6 samples x positions: the compiled kernel
    )
    alloc = scene(
        '[export]\nformats = ["allocation"]\n' + mc + "[checks]\nmax_gear_force = 5000.0\n"
    )
    assert _warm_modules(few) == ()  # the numpy path: numba would only take memory
    assert _warm_modules(many) == WARM_MODULES
    assert _warm_modules(alloc) == ()
    assert _warm_modules(scene('[export]\nformats = ["forces"]\n' + mc)) == ()


@pytest.mark.parametrize("confidence", [0.5, 0.9, 0.95, 0.99, 0.999999])
@pytest.mark.parametrize("k, n", [(0, 4), (1, 4), (3, 1000), (1000, 1000), (7, 123457)])
def test_the_binding_interval_keeps_the_bits_of_scipy_stats_normal_quantile(confidence, k, n):
    from scipy.stats import norm  # the quantile the interval was first written with

    from corr_cad.tolerance.mc_datasheet import binding_probability

    z = float(norm.ppf(0.5 + 0.5 * confidence))
    p = k / n  # Wilson's interval, written out
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    lo = 0.0 if k == 0 else max(0.0, centre - half)
    hi = 1.0 if k == n else min(1.0, centre + half)
    got = binding_probability(np.array([1] * k + [0] * (n - k)), confidence)
    assert got["wilson_interval"] == [lo, hi]  # exactly: the same bits


_PROBE = textwrap.dedent(
    """
    import json, os, sys, threading, tomllib
    from concurrent.futures import ProcessPoolExecutor
    from pathlib import Path

    seen = {}

    class Probe:  # which thread first asks for matplotlib.pyplot
        def find_spec(self, name, path=None, target=None):
            if name == "matplotlib.pyplot":
                seen.setdefault(name, threading.current_thread().name)
            return None

    sys.meta_path.insert(0, Probe())
    from corr_cad.run.bench.bench_scaling import SCENE
    from corr_cad.run.pools import WARM_MODULES, _worker_init
    from corr_cad.run.pipeline import run_scene
    from corr_cad.run.scene.scene import parse_scene

    scene = parse_scene(tomllib.loads(SCENE.replace("{samples}", "12")), name="mc")
    out = Path(sys.argv[1])
    out.mkdir()
    init = (os.getpid(), WARM_MODULES)
    with ProcessPoolExecutor(1, initializer=_worker_init, initargs=init) as pool:
        run_scene(scene, out, executor=pool)
    print(json.dumps({"pyplot": seen.get("matplotlib.pyplot"),
                      "scipy.stats": "scipy.stats" in sys.modules,
                      "numba": "numba" in sys.modules}))
    """
)


@pytest.mark.slow
def test_on_a_process_pool_the_plot_imports_beside_the_samples_with_the_same_bytes(tmp_path):
    env = dict(os.environ, MPLBACKEND="Agg")
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, str(tmp_path / "pool")],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert seen == {"pyplot": "corr-cad-import-plots", "scipy.stats": False, "numba": False}
    _run(_scene(), tmp_path / "serial")
    assert folder_files(tmp_path / "pool") == folder_files(tmp_path / "serial")


_INIT = textwrap.dedent(
    """
    import os, sys
    import corr_cad.mechanics.row.mc_kernel as k
    from corr_cad.run.pools import WARM_MODULES, _worker_init

    calls = []
    k.load_target = lambda: calls.append(1)
    _worker_init(os.getppid(), sys.argv[1:] and WARM_MODULES or ())
    print(len(calls))
    """
)


@pytest.mark.parametrize("warm, built", [(True, 1), (False, 0)])
def test_a_warm_worker_builds_numbas_target_as_it_starts(warm, built):
    args = [sys.executable, "-c", _INIT] + (["warm"] if warm else [])
    done = subprocess.run(args, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[-1] == str(built)
