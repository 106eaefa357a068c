"""Force-solver speed: vectorised cycle vs a straightforward per-position scipy root-find.

Run:  python benchmarks/bench_solver.py
Prints a table and writes outputs/bench/solver_speed.csv and .png.
The median of repeated runs is reported; the machine's core count is stated.
"""

from __future__ import annotations

import sys

import numpy as np
from _common import machine, median_time, pyplot, save_figure, write_csv

from corr_cad import GearDesign
from corr_cad.deviations import ManufacturingErrors
from corr_cad.reference import reference_position
from corr_cad.solver import solve_forces

M0 = 1.1e5


def main() -> int:
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

    print(f"machine: {machine()}")
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
        rows.append(
            (
                name,
                res.positions_solved,
                round(1e3 * t, 3),
                round(ref_total, 3),
                round(ref_total / t, 1),
            )
        )
        cells = f"{res.positions_solved:7d} {1e3 * t:9.1f} {ref_total:11.1f} {ref_total / t:9.0f}"
        print(f"{name:45s} {cells}")

    csv = write_csv(
        "solver_speed.csv", "case,positions_solved,time_ms,reference_estimate_s,speedup", rows
    )
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.barh([r[0] for r in rows], [r[2] for r in rows], color="C0")
    ax.set_xlabel("time for one full cycle [ms] (median of 7)")
    ref_cycle = ref_per_position * 3600
    ax.set_title(f"vectorised solver, {machine()}; scipy per position ~{ref_cycle:.0f} s")
    png = save_figure(fig, "solver_speed.png")
    print(f"wrote {csv} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
