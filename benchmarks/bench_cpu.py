"""CPU time (not wall time) of the solver, the Monte Carlo and clearance: for a shared machine.

Run it on two checkouts to compare them on the same (busy) machine, e.g.
``git archive a2b5611 corr_cad | tar -x -C /tmp/old`` then
``PYTHONPATH=/tmp/old python benchmarks/bench_cpu.py`` and
``python benchmarks/bench_cpu.py``. CPU time of one process is far less
disturbed by other load than wall time; best of several runs.
"""

import time

import numpy as np

import corr_cad
from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.tolerance.montecarlo import Distribution, SerialExecutor, monte_carlo


def best(fn, repeat):
    fn()
    ts = []
    for _ in range(repeat):
        t = time.process_time()
        fn()
        ts.append(time.process_time() - t)
    return min(ts)


def main() -> None:
    d = GearDesign()
    print(f"corr_cad from {corr_cad.__file__}")
    per = ManufacturingErrors(roller_radius_errors=tuple(np.linspace(-0.005, 0.005, 26)))
    for label, P, err in (
        ("nominal, 3600 positions", 3600, None),
        ("nominal, 3640 positions", 3640, None),
        ("per-roller errors, 3600", 3600, per),
    ):
        t = best(lambda P=P, err=err: solve_forces(d, 1.1e5, positions=P, errors=err), 40)
        print(f"solver {label}: {1e3 * t:.1f} ms CPU (best of 40)")
    tol = {
        "roller_radius": Distribution("normal", 0.001),
        "slot_angle": Distribution("normal", 0.005),
        "cam_radius": Distribution("uniform", 0.002),
        "eccentricity": Distribution("uniform", 0.002),
    }
    n = 200
    t = best(lambda: monte_carlo(d, 1.1e5, tol, n, 1, 360, executor=SerialExecutor()), 3)
    print(f"Monte Carlo, 360 positions, 4 tolerances: {n / t:.0f} samples/s per core (best of 3)")
    try:
        from corr_cad.geometry.clearance import clearance
    except ImportError:
        return
    ang = 2 * np.pi * np.arange(3600) / 3600
    t = best(lambda: clearance(d, ang), 10)
    print(f"exact clearance, 3600 positions: {1e3 * t:.0f} ms CPU (best of 10)")


if __name__ == "__main__":
    main()
