"""The Monte Carlo's resource model follows what the streaming Monte Carlo holds.

What grows with the samples is the main process's columns for the summary
(one float per metric and tolerance); a worker holds one bounded chunk. The
sizes are counted here from the result's own arrays, not from the model.
"""

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.run.budget.costs_montecarlo import SUMMARY_TEMP_BYTES, kept_bytes_per_sample
from corr_cad.run.budget.resources import GB, Budget, check_scene, estimate
from corr_cad.run.scene.scene import load_scene
from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

SCENE = (
    '[export]\nformats = ["montecarlo"]\n[load]\ninput_torque = 1.1e5\n[tolerances]\n'
    "roller_radius = { normal = 0.001 }\ncam_phase = { normal = 0.01 }\n"
    "[montecarlo]\nsamples = {n}\npositions = 36\n"
)
DEFAULT = Budget(3 * GB, 1 * GB, 60.0, "default", "default", "default")


def _scene(tmp_path, n: int, extra: str = ""):
    path = tmp_path / f"s{n}.toml"
    path.write_text(SCENE.replace("{n}", str(n)) + extra)
    return load_scene(path)


@pytest.mark.parametrize(
    ("workers", "executor"), [(1, "serial"), (2, "process"), (16, "process"), (16, "dask")]
)
def test_a_million_samples_fit_the_default_budget(tmp_path, workers, executor):
    est = check_scene(_scene(tmp_path, 10**6), workers, DEFAULT, executor)  # no refusal
    assert est.memory < DEFAULT.memory_bytes


def test_worker_memory_does_not_grow_with_the_samples_and_the_main_process_by_its_columns(
    tmp_path,
):
    a = estimate(_scene(tmp_path, 10**6), 2, "process")
    b = estimate(_scene(tmp_path, 4 * 10**6), 2, "process")
    assert a.worker_memory == b.worker_memory
    # 4 force metrics and 2 magnitudes a sample: 6 floats, and the summary's temporaries.
    per = (b.main_memory - a.main_memory) / (3 * 10**6)
    assert per == pytest.approx(8 * 6 + SUMMARY_TEMP_BYTES)


def test_the_columns_kept_are_those_the_result_holds():
    tol = {
        "roller_radius": Distribution("normal", 0.001),
        "cam_phase": Distribution("normal", 0.01),
    }
    res = monte_carlo(GearDesign(), 1.1e5, tol, 30, 1, 12, chunk=7)
    held = sum(v.nbytes for v in res.metrics.values()) + sum(
        v.nbytes for v in res.magnitudes.values()
    )
    assert held / 30 == kept_bytes_per_sample(4, 2) - SUMMARY_TEMP_BYTES
    assert all(v.dtype == np.float64 for v in res.metrics.values())


def test_the_longest_task_is_a_whole_chunk(tmp_path):
    """The Dask stall time-out is at least three tasks: a task is a chunk, not 50 samples."""
    small = estimate(_scene(tmp_path, 400), 16, "dask").stages["montecarlo"].task_seconds
    large = estimate(_scene(tmp_path, 10**6), 16, "dask").stages["montecarlo"].task_seconds
    assert large > 10 * small
    # ... of at most half a second: a --dask-stall-timeout of a few seconds holds.
    from corr_cad.tolerance.mc_chunks import CHUNK_SECONDS

    assert large <= CHUNK_SECONDS * (1 + 1e-9)


def test_bench_worker_counts_default_to_powers_of_two_up_to_the_cores(monkeypatch):
    from corr_cad.run.bench import bench_scaling

    monkeypatch.setattr(bench_scaling.os, "cpu_count", lambda: 12)
    assert bench_scaling.default_worker_counts() == [1, 2, 4, 8, 12]
    monkeypatch.setattr(bench_scaling.os, "cpu_count", lambda: 16)
    assert bench_scaling.default_worker_counts() == [1, 2, 4, 8, 16]


def test_bench_workers_flag_refuses_a_bad_count_in_one_line(tmp_path):
    import subprocess
    import sys

    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "bench", "--study", "montecarlo", "--workers", "0,2",
         "--out", str(tmp_path / "b")],
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert r.returncode == 2
    assert "--workers: '0,2': worker counts from 1 to 1024, comma-separated" in r.stderr
    assert not (tmp_path / "b").exists()


def test_bench_workers_sweep_runs_the_paper_s_row_and_the_drive_with_its_clearance():
    """The sweep's two scenes: the same study under the paper's row and under the drive on
    40 needles with a 5 um diametral clearance (what docs/budget.md says it sweeps)."""
    import tomllib

    from corr_cad.run.bench import bench_scaling
    from corr_cad.run.scene.scene import parse_scene

    assert list(bench_scaling.MODELS) == ["paper", "drive"]
    scenes = {
        k: parse_scene(tomllib.loads(v.replace("{samples}", "10")))
        for k, v in bench_scaling.MODELS.items()
    }
    assert not scenes["paper"].solver.drive
    drive = scenes["drive"]
    assert drive.solver.drive and drive.solver.contact_model == "palmgren"
    assert drive.bearing.needles == 40 and drive.bearing.diametral_clearance == 0.005
    assert drive.tolerances.keys() == scenes["paper"].tolerances.keys()
