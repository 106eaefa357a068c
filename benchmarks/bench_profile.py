"""Profile export: tolerance vs measured deviation, size and time, per representation.

Run:  python benchmarks/bench_profile.py
Prints a table and writes outputs/bench/profile_export.csv and .png (median of 3 runs).
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from corr_cad import GearDesign, approximate, theoretical_profile, working_profile
from corr_cad.export import dxf

OUT = Path(__file__).resolve().parents[1] / "outputs" / "bench"
TOLERANCES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    design = GearDesign()
    w, t = working_profile(design), theoretical_profile(design)
    print(f"machine: {os.cpu_count()} cores; prototype working profile, tooth tip radius 1.76 mm")
    head = "repr        tol mm  measured mm  vertices   DXF kB  time s"
    print(head)
    print("-" * len(head))
    rows = []
    tmp = Path(tempfile.mkdtemp())
    for rep in ("polyline", "arcs", "spline"):
        for tol in TOLERANCES:
            times = []
            for _ in range(3):
                t0 = time.perf_counter()
                a = approximate(w, rep, tol)
                b = approximate(t, rep, tol)
                path = dxf.write_inner_gear(design, a, b, tmp / "g.dxf")
                times.append(time.perf_counter() - t0)
            size = path.stat().st_size / 1024
            dt = statistics.median(times)
            rows.append((rep, tol, a.max_deviation, a.entity_vertex_count, size, dt))
            n = a.entity_vertex_count
            print(f"{rep:9s} {tol:8.0e} {a.max_deviation:12.3e} {n:9d} {size:8.0f} {dt:7.2f}")
    with open(OUT / "profile_export.csv", "w") as f:
        f.write("representation,tolerance_mm,max_deviation_mm,vertices,dxf_kB,time_s\n")
        for r in rows:
            f.write(",".join(str(x) for x in r) + "\n")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for rep in ("polyline", "arcs", "spline"):
        sel = [r for r in rows if r[0] == rep]
        ax.loglog([r[5] for r in sel], [r[2] for r in sel], "o-", label=rep)
    ax.set_xlabel("time to approximate, measure and write [s] (median of 3)")
    ax.set_ylabel("measured max deviation [mm]")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    ax.set_title("inner gear profile: accuracy vs time")
    fig.tight_layout()
    fig.savefig(OUT / "profile_export.png", dpi=120)
    print(f"wrote {OUT / 'profile_export.csv'} and {OUT / 'profile_export.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
