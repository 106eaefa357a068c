"""Force-solver speed: vectorised cycle vs a straightforward per-position scipy root-find.

Run:  python benchmarks/bench_solver.py
Prints a table and writes outputs/bench/solver_speed.csv and .png.
The median of repeated runs is reported; the machine's core count is stated.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from corr_cad import GearDesign
from corr_cad.deviations import ManufacturingErrors
from corr_cad.reference import reference_position
from corr_cad.solver import solve_forces

OUT = Path(__file__).resolve().parents[1] / "outputs" / "bench"
M0 = 1.1e5


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    design = GearDesign()
    cases = [
        ("nominal, 3600 positions", 3600, ManufacturingErrors()),
        ("nominal, 3640 positions (multiple of z+1)", 3640, ManufacturingErrors()),
        ("eccentricity error 0.02 mm, 3600", 3600, ManufacturingErrors(eccentricity_error=0.02)),
        ("roller error -0.01 mm, 3600", 3600, ManufacturingErrors(roller_radius_error=-0.01)),
        (
            "per-roller errors (no periodicity), 3600",
            3600,
            ManufacturingErrors(roller_radius_errors=tuple(np.linspace(-0.005, 0.005, 26))),
        ),
    ]
    # Reference: per-position scalar brentq solver, timed on a sample and scaled.
    sample = np.radians(np.linspace(0, 360, 12, endpoint=False))
    t_ref = median_time(lambda: [reference_position(design, M0, a) for a in sample], 3)
    ref_per_position = t_ref / len(sample)

    print(f"machine: {os.cpu_count()} cores, Python {sys.version.split()[0]}")
    print(f"reference (scipy brentq per position): {1e3 * ref_per_position:.1f} ms per position")
    header = f"{'case':45s} {'solved':>7s} {'time ms':>9s} {'ref est. s':>11s} {'speed-up':>9s}"
    print(header)
    print("-" * len(header))
    rows = []
    for name, n, err in cases:
        solve_forces(design, M0, positions=n, errors=err)  # warm-up
        t = median_time(lambda n=n, err=err: solve_forces(design, M0, positions=n, errors=err), 7)
        res = solve_forces(design, M0, positions=n, errors=err)
        ref_total = ref_per_position * n
        rows.append((name, res.positions_solved, 1e3 * t, ref_total, ref_total / t))
        cells = f"{res.positions_solved:7d} {1e3 * t:9.1f} {ref_total:11.1f} {ref_total / t:9.0f}"
        print(f"{name:45s} {cells}")

    with open(OUT / "solver_speed.csv", "w") as f:
        f.write("case,positions_solved,time_ms,reference_estimate_s,speedup\n")
        for r in rows:
            f.write(f'"{r[0]}",{r[1]},{r[2]:.3f},{r[3]:.3f},{r[4]:.1f}\n')

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.barh([r[0] for r in rows], [r[2] for r in rows], color="C0")
    ax.set_xlabel("time for one full cycle [ms] (median of 7)")
    ref_cycle = ref_per_position * 3600
    ax.set_title(
        f"vectorised solver, {os.cpu_count()} cores; scipy per position ~{ref_cycle:.0f} s"
    )
    fig.tight_layout()
    fig.savefig(OUT / "solver_speed.png", dpi=120)
    print(f"wrote {OUT / 'solver_speed.csv'} and {OUT / 'solver_speed.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
