"""Profile export: tolerance vs measured deviation, size and time, per representation.

Run:  python benchmarks/bench_profile.py
Prints a table and writes outputs/bench/profile_export.csv and .png (median of 3 runs).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from _common import machine, median_time, pyplot, save_figure, write_csv

from corr_cad import GearDesign, approximate, theoretical_profile, working_profile
from corr_cad.export import dxf

TOLERANCES = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)


def main() -> int:
    design = GearDesign()
    w, t = working_profile(design), theoretical_profile(design)
    print(f"machine: {machine()}; prototype working profile, tooth tip radius 1.76 mm")
    head = "repr        tol mm  measured mm  vertices   DXF kB  time s"
    print(head)
    print("-" * len(head))
    rows = []
    path = Path(tempfile.mkdtemp()) / "g.dxf"
    for rep in ("polyline", "arcs", "spline"):
        for tol in TOLERANCES:
            out = {}

            def run(rep=rep, tol=tol, out=out):
                out["a"] = approximate(w, rep, tol)
                b = approximate(t, rep, tol)
                dxf.write_inner_gear(design, out["a"], b, path)

            dt = median_time(run, 3)
            a = out["a"]
            size = path.stat().st_size / 1024
            rows.append(
                (rep, tol, a.max_deviation, a.entity_vertex_count, round(size, 1), round(dt, 4))
            )
            n = a.entity_vertex_count
            print(f"{rep:9s} {tol:8.0e} {a.max_deviation:12.3e} {n:9d} {size:8.0f} {dt:7.2f}")
    header = "representation,tolerance_mm,max_deviation_mm,vertices,dxf_kB,time_s"
    csv = write_csv("profile_export.csv", header, rows)
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for rep in ("polyline", "arcs", "spline"):
        sel = [r for r in rows if r[0] == rep]
        ax.loglog([r[5] for r in sel], [r[2] for r in sel], "o-", label=rep)
    ax.set_xlabel("time to approximate, measure and write [s] (median of 3)")
    ax.set_ylabel("measured max deviation [mm]")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    ax.set_title(f"inner gear profile: accuracy vs time ({machine()})")
    png = save_figure(fig, "profile_export.png")
    print(f"wrote {csv} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
