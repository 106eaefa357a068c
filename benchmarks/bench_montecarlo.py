"""Monte Carlo throughput: samples per second, and confidence-interval width vs samples.

Run:  python benchmarks/bench_montecarlo.py [--samples 10000]
Prints tables and writes outputs/bench/montecarlo_throughput.csv and .png.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from _common import machine, pyplot, save_figure, write_csv

from corr_cad import GearDesign
from corr_cad.tolerance import Distribution, SerialExecutor, monte_carlo

TOL = {
    "roller_radius": Distribution("normal", 0.001),
    "cam_radius": Distribution("uniform", 0.002),
    "eccentricity": Distribution("uniform", 0.002),
    "slot_angle": Distribution("normal", 0.005),
}


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=int, default=10000)
    ap.add_argument("--positions", type=int, default=360)
    args = ap.parse_args()
    design = GearDesign()
    print(f"machine: {machine()}; prototype, {args.positions} positions per sample, 4 tolerances")
    rows = []
    for label, make in (
        ("serial", SerialExecutor),
        ("process pool", lambda: ProcessPoolExecutor(os.cpu_count())),
    ):
        n = min(args.samples, 1000) if label == "serial" else args.samples
        ex = make()
        t0 = time.perf_counter()
        mc = monte_carlo(design, 1.1e5, TOL, n, 1, args.positions, executor=ex, chunk=50)
        dt = time.perf_counter() - t0
        if hasattr(ex, "shutdown"):
            ex.shutdown()
        rows.append((label, n, round(dt, 3), round(n / dt, 1)))
        print(f"{label:14s} {n:7d} samples {dt:8.1f} s {n / dt:9.1f} samples/s")
    # Confidence-interval width of the 95th percentile of peak F_n (bootstrap).
    peak = mc.metrics["peak_gear_force"]
    rng = np.random.default_rng(0)
    ci = []
    for n in (100, 300, 1000, 3000, 10000):
        if n > len(peak):
            break
        boots = [np.percentile(rng.choice(peak[:n], n), 95) for _ in range(200)]
        lo, hi = np.percentile(boots, [2.5, 97.5])
        ci.append((n, float(np.percentile(peak[:n], 95)), float(hi - lo)))
        print(f"  n = {n:6d}: p95 peak F_n {ci[-1][1]:8.1f} N, 95% CI width {hi - lo:7.1f} N")
    csv = write_csv("montecarlo_throughput.csv", "executor,samples,time_s,samples_per_s", rows)
    write_csv("montecarlo_ci.csv", "samples,p95_peak_F_n,ci95_width_N", ci)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.loglog([c[0] for c in ci], [c[2] for c in ci], "o-")
    ax.set_xlabel("Monte Carlo samples")
    ax.set_ylabel("95% CI width of p95 peak $F_n$ [N]")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(f"Monte Carlo: confidence vs samples ({machine()})")
    png = save_figure(fig, "montecarlo_ci.png")
    print(f"wrote {csv} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
