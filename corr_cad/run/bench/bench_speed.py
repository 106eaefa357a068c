"""Benchmarks of speed: the solver, the Monte Carlo, its kernel, the cold start."""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from corr_cad.export.bench_plots import figure as _figure
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.run.bench.bench_common import (
    M0,
    _machine,
    _median_time,
    _table,
    _write_csv,
)


def _tolerances(slots: bool) -> dict:
    """The benchmarks' tolerances: roller sigma 1 um, cam radius and eccentricity +-2 um."""
    from corr_cad.tolerance.montecarlo import Distribution

    tol = {
        "roller_radius": Distribution("normal", 0.001),
        "cam_radius": Distribution("uniform", 0.002),
        "eccentricity": Distribution("uniform", 0.002),
    }
    if slots:
        tol["slot_angle"] = Distribution("normal", 0.005)
    return tol


def montecarlo(out: Path, quick: bool = False) -> list:
    """Samples vs time and the confidence-interval width of the p95 peak gear force."""
    from corr_cad.tolerance.montecarlo import SerialExecutor
    from corr_cad.tolerance.montecarlo import monte_carlo as mc

    tol = _tolerances(slots=False)
    design = GearDesign()
    rows = []
    rng = np.random.default_rng(0)
    for n in (50, 200) if quick else (100, 300, 1000, 3000):
        t0 = time.perf_counter()
        res = mc(design, M0, tol, n, 1, 180, executor=SerialExecutor())
        dt = time.perf_counter() - t0
        peak = res.metrics["peak_gear_force"]
        boots = [np.percentile(rng.choice(peak, n), 95) for _ in range(200)]
        lo, hi = np.percentile(boots, [2.5, 97.5])
        rows.append([n, float(np.percentile(peak, 95)), float(hi - lo), dt])
    header = ["samples", "p95_peak_F_n", "ci95_width_N", "time_s"]
    _table("Monte Carlo (serial, 180 positions)", header, rows)
    _write_csv(out, "montecarlo_ci.csv", header, rows)

    def draw(ax):
        ax.loglog([r[3] for r in rows], [r[2] for r in rows], "o-")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("95% CI width of p95 peak $F_n$ [N]")
        ax.set_title(f"Monte Carlo: confidence vs time ({_machine()})")
        return [(r[3], r[2], f"{r[0]} samples") for r in rows]

    _figure(out, "montecarlo_ci.png", draw)
    return rows


def solver_speed(out: Path, quick: bool = False) -> list:
    """Vectorised full cycle against a straightforward per-position scipy root-find."""
    from corr_cad.mechanics.reference import reference_position

    design = GearDesign()
    cases = [
        ("nominal, 3600 positions", 3600, ManufacturingErrors()),
        ("nominal, 3640 positions (multiple of z+1)", 3640, ManufacturingErrors()),
        ("eccentricity error 0.02 mm, 3600", 3600, ManufacturingErrors(eccentricity_error=0.02)),
        (
            "per-roller errors (no periodicity), 3600",
            3600,
            ManufacturingErrors(roller_radius_errors=tuple(np.linspace(-0.005, 0.005, 26))),
        ),
    ]
    sample = np.radians(np.linspace(0, 360, 4 if quick else 12, endpoint=False))
    t_ref = _median_time(
        lambda: [reference_position(design, M0, a) for a in sample], 1 if quick else 3
    )
    per_position = t_ref / len(sample)
    rows = []
    for name, n, err in cases:
        solve_forces(design, M0, positions=n, errors=err)  # warm-up
        t = _median_time(lambda n=n, err=err: solve_forces(design, M0, positions=n, errors=err), 7)
        solved = solve_forces(design, M0, positions=n, errors=err).positions_solved
        rows.append([name, solved, 1e3 * t, per_position * n, per_position * n / t])
    header = ["case", "positions_solved", "time_ms", "scipy_estimate_s", "speedup"]
    _table(f"solver speed (scipy per position: {1e3 * per_position:.0f} ms)", header, rows)
    _write_csv(out, "solver_speed.csv", header, rows)

    def draw(ax):
        ax.barh([r[0] for r in rows], [r[2] for r in rows], color="C0")
        ax.set_xlabel("time for one full cycle [ms] (median of 7)")
        ax.set_title(
            f"vectorised solver ({_machine()})\n"
            f"per-position scipy root-find: ~{per_position * 3600:.0f} s a cycle",
            fontsize=10,
        )

    _figure(out, "solver_speed.png", draw)
    return rows


def throughput(out: Path, quick: bool = False) -> list:
    """Monte Carlo samples per second: in this process, and on 1 and 2 pool workers."""
    from concurrent.futures import ProcessPoolExecutor

    from corr_cad.tolerance.montecarlo import SerialExecutor
    from corr_cad.tolerance.montecarlo import monte_carlo as mc

    tol = _tolerances(slots=True)
    design = GearDesign()
    rows = []
    n_pool = 1000 if quick else 10000
    repeat = 3
    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    mc(design, M0, tol, 2, 1, 4, kernel=True)  # load (or compile) the kernel once
    for label, n, workers, kernel in (
        ("serial", min(n_pool, 1000), 0, False),
        ("serial", min(n_pool, 1000), 0, True),
        ("process pool, 1 worker", n_pool, 1, None),
        ("process pool, 2 workers", n_pool, 2, None),
    ):
        times = []
        for _ in range(repeat):
            ex = SerialExecutor() if workers == 0 else ProcessPoolExecutor(workers)
            t0 = time.perf_counter()
            mc(design, M0, tol, n, 1, 360, executor=ex, chunk=50, kernel=kernel)
            times.append(time.perf_counter() - t0)
            if hasattr(ex, "shutdown"):
                ex.shutdown()
        dt = statistics.median(times)
        if kernel is None:
            kernel = n * 360 >= KERNEL_MIN_WORK
        rows.append([label, "kernel" if kernel else "numpy", n, dt, n / dt])
    header = ["executor", "solver", "samples", "time_s", "samples_per_s"]
    _table(
        f"Monte Carlo throughput (360 positions, 4 tolerances, median of {repeat})", header, rows
    )
    _write_csv(out, "montecarlo_throughput.csv", header, rows)
    return rows


PROTOTYPE_SCENE = """[export]
formats = ["dxf", "png", "forces", "stl", "step", "interference"]
representation = "arcs"
tolerance = 0.001
assembly_angles_deg = [0.0]
interference_method = "exact"
[load]
input_torque = 1.1e5
[solver]
positions = 3600
load_share = 0.55
"""
#: The z = 39 drive near its undercut limit of tests/test_step.py, STEP only.
Z39_STEP_SCENE = """[design]
tooth_count = 39
cam_radius = 150.0
roller_radius = 5.35
eccentricity = 3.0
ring_outer_radius = 180.0
cam_bore_radius = 40.0
frame_inner_radius = 100.0
frame_outer_radius = 172.0
frame_thickness = 6.0
[export]
formats = ["step"]
chord_tolerance = 0.001
"""


def cold_start(out: Path, quick: bool = False) -> list:
    """Wall and CPU time of a fresh ``python -m corr_cad run`` for typical scenes.

    CPU is the child processes' user + system time (the STEP worker's too),
    which a busy machine distorts less than the wall time.
    """
    import resource
    import subprocess
    import sys

    scenes = {
        "dxf only (arcs, 1 um)": '[export]\nformats = ["dxf"]\nrepresentation = "arcs"\n',
        "forces only (3600 positions)": (
            '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        ),
        "clearance only (3600 positions)": '[export]\nformats = ["interference"]\n',
        "step only, z = 39 near undercut": Z39_STEP_SCENE,
        "prototype, all its formats": PROTOTYPE_SCENE,
        "prototype, all its formats, --executor serial": PROTOTYPE_SCENE,
        "import only": None,
    }
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, text in scenes.items():
            if text is None:
                cmd = [sys.executable, "-c", "import corr_cad.run.cli"]
            else:
                (Path(tmp) / "s.toml").write_text(text)
                cmd = [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "o", "--quiet"]
                if "serial" in label:
                    cmd += ["--executor", "serial"]
            cpu: list[float] = []

            def once(cmd=cmd, cpu=cpu):
                r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                subprocess.run(cmd, cwd=tmp, check=True, capture_output=True)
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu.append(r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)

            wall = _median_time(once, 3 if quick else 5)
            rows.append([label, wall, statistics.median(cpu)])
    header = ["run", "wall_s", "cpu_s"]
    _table("cold start: a fresh process, median", header, rows)
    _write_csv(out, "cold_start.csv", header, rows)
    return rows


_KERNEL_SCRIPT = """
import sys
from concurrent.futures import ProcessPoolExecutor
from corr_cad import GearDesign
from corr_cad.run.bench.bench_speed import _tolerances
from corr_cad.tolerance.montecarlo import monte_carlo
n, positions, kernel = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3] == "kernel"
with ProcessPoolExecutor(2) as pool:
    monte_carlo(GearDesign(), 1.1e5, _tolerances(True), n, 1, positions, executor=pool,
                kernel=kernel)
"""


def kernel_crossover(out: Path, quick: bool = False) -> list:
    """Whole-process wall time of a Monte Carlo on 2 workers: numpy against the kernel.

    Each run is a fresh ``python`` (imports included). ``kernel, first run``
    compiles into an empty numba cache (once per installation); ``kernel``
    loads the cached machine code. The crossover justifies
    :data:`corr_cad.tolerance.montecarlo.KERNEL_MIN_WORK`.
    """
    import subprocess
    import sys

    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    sizes = (
        [(200, 364), (1000, 360)] if quick else [(200, 364), (1000, 360), (2778, 360), (10000, 360)]
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:

        def once(n, P, path, cache):
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            cmd = [sys.executable, "-c", _KERNEL_SCRIPT, str(n), str(P), path]
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True, env=env)
            return time.perf_counter() - t0

        warm = str(Path(tmp) / "warm")
        once(10, 36, "kernel", warm)  # fill the cache once
        for n, P in sizes:
            repeat = 1 if (quick or n * P > 2e6) else 3
            t_np = statistics.median(once(n, P, "numpy", warm) for _ in range(repeat))
            t_cold = statistics.median(
                once(n, P, "kernel", str(Path(tmp) / f"cold{n}_{i}")) for i in range(repeat)
            )
            t_warm = statistics.median(once(n, P, "kernel", warm) for _ in range(repeat))
            chosen = "kernel" if n * P >= KERNEL_MIN_WORK else "numpy"
            rows.append([n, P, n * P, t_np, t_cold, t_warm, chosen])
    header = ["samples", "positions", "work", "numpy_s", "kernel_first_run_s", "kernel_s", "chosen"]
    _table(
        f"Monte Carlo, 2 workers, whole process (4 tolerances; kernel from "
        f"{KERNEL_MIN_WORK:,} samples x positions)",
        header,
        rows,
    )
    _write_csv(out, "kernel_crossover.csv", header, rows)

    _draw_kernel_crossover(out, rows)
    return rows


def _draw_kernel_crossover(out: Path, rows: list) -> Path:
    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    def draw(ax):
        w = [r[2] for r in rows]
        ax.loglog(w, [r[3] for r in rows], "o-", label="numpy")
        ax.loglog(w, [r[4] for r in rows], "s--", label="kernel, first run (compiles)")
        ax.loglog(w, [r[5] for r in rows], "^-", label="kernel (cached)")
        ax.axvline(KERNEL_MIN_WORK, color="0.5", lw=0.8)
        ax.text(KERNEL_MIN_WORK, ax.get_ylim()[1], " kernel used from here", va="top", fontsize=8)
        ax.set_xlabel("samples x crank positions")
        ax.set_ylabel("wall time of the whole process [s]")
        lo, hi = ax.get_ylim()
        ticks = [t for t in (0.5, 1, 2, 5, 10, 20, 50, 100) if lo <= t <= hi]
        ax.set_yticks(ticks, [f"{t:g}" for t in ticks])
        ax.set_yticks([], minor=True)
        ax.set_title(f"Monte Carlo on 2 workers: numpy vs compiled kernel ({_machine()})")
        ax.legend(fontsize=8)

    return _figure(out, "kernel_crossover.png", draw)
