"""The Monte Carlo stage's fixed cost: the nominal metrics in the pool, warm workers.

The stage hands the nominal design's metrics to the local process pool
before the samples (the main process then never loads numba nor the compiled
kernels), and the CLI's pool workers import the kernels' modules when they
start. Neither changes a byte of the stage's files.
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import pytest

from corr_cad.run.bench.bench_scaling import SCENE
from corr_cad.run.cli import WARM_MODULES, _worker_init
from corr_cad.run.pipeline import run_scene
from corr_cad.run.scene.scene import parse_scene


def _scene(samples: int = 12):
    import tomllib

    return parse_scene(tomllib.loads(SCENE.replace("{samples}", str(samples))), name="mc")


def _run(scene, out, executor=None) -> None:
    out.mkdir()
    run_scene(scene, out, executor=executor)


def _files(out) -> dict:
    """Every file's bytes; the manifest without its timings."""
    got = {}
    for p in sorted(out.iterdir()):
        if p.name == "manifest.json":
            m = json.loads(p.read_text())
            m.pop("stages", None)
            got[p.name] = m
        else:
            got[p.name] = p.read_bytes()
    return got


class _Recording(ThreadPoolExecutor):
    """A pool that records the functions handed to it."""

    def __init__(self) -> None:
        super().__init__(1)
        self.names: list[str] = []

    def submit(self, fn, *args, **kwargs):
        self.names.append(fn.__name__)
        return super().submit(fn, *args, **kwargs)


@pytest.mark.slow
def test_the_nominal_metrics_go_to_the_pool_first_and_the_files_keep_their_bytes(tmp_path):
    scene = _scene()
    _run(scene, tmp_path / "serial")
    with _Recording() as pool:
        _run(scene, tmp_path / "pool", pool)
    assert pool.names[0] == "_nominal_task"
    assert pool.names.count("_nominal_task") == 1 and len(pool.names) > 1
    assert _files(tmp_path / "pool") == _files(tmp_path / "serial")
    nominal = json.loads((tmp_path / "pool" / "montecarlo_summary.json").read_text())["nominal"]
    assert {"lost_motion_arcmin", "peak_gear_force"} <= set(nominal)


@pytest.mark.slow
def test_warm_process_workers_write_the_serial_runs_bytes(tmp_path):
    scene = _scene()
    _run(scene, tmp_path / "serial")
    init = (os.getpid(), WARM_MODULES)
    with ProcessPoolExecutor(2, initializer=_worker_init, initargs=init) as pool:
        _run(scene, tmp_path / "pool", pool)
    assert _files(tmp_path / "pool") == _files(tmp_path / "serial")


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
