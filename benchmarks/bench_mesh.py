"""Solids: chord tolerance vs triangles, STL size, volume error and build time (gear ring).

Run:  python benchmarks/bench_mesh.py
Prints a table and writes outputs/bench/mesh_tolerance.csv and .png (median of 3).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from _common import machine, median_time, pyplot, save_figure, write_csv

from corr_cad import GearDesign, working_profile
from corr_cad.export import mesh
from corr_cad.parts import part_outlines

TOLERANCES = (1e-1, 1e-2, 1e-3, 1e-4)


def main() -> int:
    design = GearDesign()
    w = working_profile(design)
    path = Path(tempfile.mkdtemp()) / "ring.stl"
    print(f"machine: {machine()}; gear ring of the prototype")
    print("chord tol mm  triangles   STL kB  volume err mm3  rel. error  time s")
    rows = []
    for tol in TOLERANCES:
        out = {}

        def build(tol=tol, out=out):
            o = part_outlines(design, w, tol)["ring"]
            tm = mesh.to_trimesh(mesh.solid(o))
            mesh.write_mesh(tm, path, "stl")
            out["o"], out["tm"] = o, tm

        dt = median_time(build, 3)
        o, tm = out["o"], out["tm"]
        err = tm.volume - o.exact_volume
        size = path.stat().st_size / 1024
        rows.append((tol, len(tm.faces), round(size, 1), err, err / o.exact_volume, round(dt, 4)))
        rel = err / o.exact_volume
        print(f"{tol:12.0e} {len(tm.faces):10d} {size:8.0f} {err:15.4g} {rel:11.2e} {dt:7.2f}")
    csv = write_csv(
        "mesh_tolerance.csv",
        "chord_tolerance_mm,triangles,stl_kB,volume_error_mm3,relative_error,time_s",
        rows,
    )
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.loglog([r[5] for r in rows], [abs(r[3]) for r in rows], "o-")
    for r in rows:
        ax.annotate(f"{r[0]:g} mm, {r[1]} tri", (r[5], abs(r[3])), fontsize=8)
    ax.set_xlabel("build + write time [s] (median of 3)")
    ax.set_ylabel("|volume error| [mm$^3$]")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(f"gear ring solid: accuracy vs time ({machine()})")
    png = save_figure(fig, "mesh_tolerance.png")
    print(f"wrote {csv} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
