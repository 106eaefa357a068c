"""Benchmarks of what accuracy costs: profile export, solids, solver fidelity, interference."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from corr_cad.export.bench_plots import figure as _figure
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.geometry.profile import theoretical_profile, working_profile
from corr_cad.geometry.sampling import approximate
from corr_cad.mechanics.row.solver import cycle_angles, roller_geometry, solve_forces
from corr_cad.run.bench.bench_common import (
    M0,
    _machine,
    _median_cpu_time,
    _median_time,
    _table,
    _write_csv,
)


def profile_export(out: Path, quick: bool = False) -> list:
    """Tolerance vs measured deviation, vertices, DXF size and time per representation.

    ``profile_s``: approximate, measure (both ways) and write one profile (the
    working profile alone in a DXF), wall time; ``profile_cpu_s`` the same in
    process CPU time (what it costs on a busy machine); ``file_s``: the whole ``inner_gear.dxf``
    (working and theoretical profiles, ring circle). Medians of 5 runs (1 with
    ``quick``).
    """
    from corr_cad.export import dxf

    design = GearDesign()
    w, t = working_profile(design), theoretical_profile(design)
    tols = (1e-2, 1e-3, 1e-4) if quick else (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
    folder = Path(tempfile.mkdtemp())
    path, one = folder / "g.dxf", folder / "one.dxf"
    rows = []
    for rep in ("polyline", "arcs", "spline"):
        for tol in tols:
            keep = {}

            def one_profile(rep=rep, tol=tol, keep=keep):
                keep["a"] = approximate(w, rep, tol)
                doc = dxf._new_doc(design, "working_profile")
                dxf._add_profile(doc.modelspace(), keep["a"], dxf._layer(doc, "WORKING_PROFILE"))
                dxf._save(doc, one)

            def whole_file(rep=rep, tol=tol):
                dxf.write_inner_gear(
                    design, approximate(w, rep, tol), approximate(t, rep, tol), path
                )

            repeat = 1 if quick else 5
            dt_one = _median_time(one_profile, repeat)
            cpu_one = _median_cpu_time(one_profile, repeat)
            dt_file = _median_time(whole_file, repeat)
            a = keep["a"]
            rows.append(
                [
                    rep,
                    tol,
                    a.max_deviation,
                    a.entity_vertex_count,
                    path.stat().st_size / 1024,
                    dt_one,
                    cpu_one,
                    dt_file,
                ]
            )
    header = [
        "representation",
        "tolerance_mm",
        "max_deviation_mm",
        "vertices",
        "dxf_kB",
        "profile_s",
        "profile_cpu_s",
        "file_s",
    ]
    _table("profile export", header, rows)
    _write_csv(out, "profile_export.csv", header, rows)

    def draw(ax):
        for rep in ("polyline", "arcs", "spline"):
            sel = [r for r in rows if r[0] == rep]
            ax.loglog([r[6] for r in sel], [r[2] for r in sel], "o-", label=rep)
        ax.set_xlabel("CPU time to approximate, measure and write one profile [s]")
        ax.set_ylabel("measured max deviation [mm]")
        ax.legend()
        ax.set_title(f"DXF profile: accuracy vs time ({_machine()})")

    _figure(out, "profile_export.png", draw)
    return rows


def solids(out: Path, quick: bool = False) -> list:
    """Chord tolerance vs triangles, STL size, volume error and build time (gear ring)."""
    from corr_cad.export import mesh
    from corr_cad.geometry.parts import part_outlines

    design = GearDesign()
    w = working_profile(design)
    path = Path(tempfile.mkdtemp()) / "ring.stl"
    rows = []
    for tol in (1e-1, 1e-2, 1e-3) if quick else (1e-1, 1e-2, 1e-3, 1e-4):
        keep = {}

        def build(tol=tol, keep=keep):
            o = part_outlines(design, w, tol)["ring"]
            tm = mesh.to_trimesh(mesh.solid(o))
            mesh.write_mesh(tm, path, "stl")
            keep["o"], keep["tm"] = o, tm

        dt = _median_time(build, 1 if quick else 3)
        err = float(keep["tm"].volume - keep["o"].exact_volume)
        rows.append(
            [
                tol,
                len(keep["tm"].faces),
                path.stat().st_size / 1024,
                err,
                err / keep["o"].exact_volume,
                dt,
            ]
        )
    header = [
        "chord_tolerance_mm",
        "triangles",
        "stl_kB",
        "volume_error_mm3",
        "relative_error",
        "time_s",
    ]
    _table("solids (gear ring)", header, rows)
    _write_csv(out, "mesh_tolerance.csv", header, rows)

    def draw(ax):
        ax.loglog([r[5] for r in rows], [abs(r[3]) for r in rows], "o-")
        ax.set_xlabel("build + write time [s]")
        ax.set_ylabel("|volume error| [mm$^3$]")
        ax.set_title(f"gear ring solid: accuracy vs time ({_machine()})")

    _figure(out, "mesh_tolerance.png", draw)
    return rows


def _rigid_forces(design: GearDesign, angles: np.ndarray, share: float = 0.55) -> np.ndarray:
    """No compliance: force ratios from geometry, load shared in proportion to the arm."""
    g = roller_geometry(design, angles)
    a = np.maximum(g.arm, 0.0)
    return share * M0 * a / np.sum(a * a, axis=1, keepdims=True)


def fidelity(out: Path, quick: bool = False) -> list:
    """Solver fidelity ladder, positions per cycle, and solver tolerance, against time."""
    design = GearDesign()
    n = 3640
    err = ManufacturingErrors(eccentricity_error=0.005)
    finest = solve_forces(design, M0, positions=n, errors=err)

    def metrics(Fj):
        fj = Fj[:, 0]
        return float(fj[fj > 0].mean()), float(fj.max())

    ref_mean, ref_peak = metrics(finest.F_j)
    nominal = solve_forces(design, M0, positions=n)
    rungs = [
        ("rigid (no compliance)", lambda: _rigid_forces(design, cycle_angles(n))),
        (
            "linear contact",
            lambda: solve_forces(design, M0, positions=n, contact_model="linear").F_j,
        ),
        ("nonlinear contact", lambda: solve_forces(design, M0, positions=n).F_j),
        ("nonlinear + errors", lambda: solve_forces(design, M0, positions=n, errors=err).F_j),
    ]
    rows = []
    for name, fn in rungs:
        dt = _median_time(fn, 1 if quick else 5)
        mean, peak = metrics(fn())
        rows.append(["ladder", name, n, abs(mean / ref_mean - 1), abs(peak / ref_peak - 1), dt])
    # Against the nominal nonlinear model too (what errors are worth).
    nom_mean, nom_peak = metrics(nominal.F_j)
    for name, fn in rungs[:3]:
        mean, peak = metrics(fn())
        rows.append(
            ["vs nominal", name, n, abs(mean / nom_mean - 1), abs(peak / nom_peak - 1), 0.0]
        )
    # Positions per cycle: error of mean and peak against 72,800 positions.
    fine = solve_forces(design, M0, positions=72800)
    f_mean, f_peak = metrics(fine.F_j)
    for N in (36, 360, 3600) if quick else (36, 360, 3600, 36000):
        dt = _median_time(lambda N=N: solve_forces(design, M0, positions=N), 1 if quick else 3)
        mean, peak = metrics(solve_forces(design, M0, positions=N).F_j)
        rows.append(
            ["positions", f"{N} per cycle", N, abs(mean / f_mean - 1), abs(peak / f_peak - 1), dt]
        )
    # Solver tolerance.
    exact = solve_forces(design, M0, positions=3600, errors=err, rtol=1e-14)
    for rt in (1e-2, 1e-4, 1e-6, 1e-9, 1e-13):
        dt = _median_time(
            lambda rt=rt: solve_forces(design, M0, positions=3600, errors=err, rtol=rt), 3
        )
        r = solve_forces(design, M0, positions=3600, errors=err, rtol=rt)
        e = float(np.abs(r.F_j - exact.F_j).max() / exact.F_j.max())
        rows.append(["solver rtol", f"{rt:g}", 3600, e, e, dt])
    header = ["study", "setting", "positions", "mean_rel_error", "peak_rel_error", "time_s"]
    _table("solver fidelity", header, rows)
    _write_csv(out, "solver_fidelity.csv", header, rows)

    def draw(ax):
        for study, mark in (("ladder", "o"), ("positions", "s"), ("solver rtol", "^")):
            sel = [r for r in rows if r[0] == study]
            ax.loglog(
                [max(r[5], 1e-5) for r in sel],
                [max(r[4], 1e-16) for r in sel],
                mark + "-",
                label=study,
            )
        ax.set_xlabel("time [s] (median)")
        ax.set_ylabel(
            "relative error of roller 1's peak $F_j$ [-]\n(exact agreement drawn at 1e-16)"
        )
        ax.legend(fontsize=8, loc="lower left")
        ax.set_title(f"force solver: accuracy vs time ({_machine()})")
        shown = ("ladder", "positions", "solver rtol")
        return [(max(r[5], 1e-5), max(r[4], 1e-16), str(r[1])) for r in rows if r[0] in shown]

    _figure(out, "solver_fidelity.png", draw)
    return rows


def interference(out: Path, quick: bool = False) -> list:
    """Exact clearance against the mesh booleans: time per crank position and resolution.

    Resolution: the smallest interference each method can tell from contact.
    The exact method's is its round-off (the largest |clearance| of the
    nominal prototype's working contacts over the cycle); the mesh's is its
    tessellation allowance, ``2 chord_tolerance`` of gap.
    """
    from corr_cad.export import mesh
    from corr_cad.geometry.clearance import clearance
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.run.pipeline import interference_allowance

    design = GearDesign()
    rows = []
    for n in (36, 360) if quick else (36, 360, 3600):
        ang = cycle_angles(n)
        clearance(design, ang)
        t = _median_time(lambda ang=ang: clearance(design, ang), 3 if quick else 7)
        c = clearance(design, ang)
        res = max(np.abs(c.cam).max(), np.abs(c.ring).max())
        rows.append(["exact", n, "-", t, 1e3 * t / n, float(res)])
    w = working_profile(design)
    for tol in (0.01,) if quick else (0.01, 0.001):
        outlines = part_outlines(design, w, tol)
        solids = {k: mesh.solid(o) for k, o in outlines.items()}
        stack = mesh.frame_stack(design, solids["frame"])
        pieces = mesh.frame_pieces(design, stack)
        n = 2

        def sweep(solids=solids, stack=stack, pieces=pieces, tol=tol, n=n):
            for a in cycle_angles(n):
                asm = mesh.assembly(design, solids, float(a), stack=stack, pieces=pieces)
                mesh.interference_at(asm, search_length=max(0.1, 50 * tol))

        t = _median_time(sweep, 1 if quick else 3)
        gap = interference_allowance(design, tol)["ring"]["gap_mm"]
        rows.append(["mesh", n, tol, t, 1e3 * t / n, gap])
    header = ["method", "positions", "chord_tol_mm", "time_s", "ms_per_position", "resolution_mm"]
    _table("interference: exact clearance vs mesh booleans (prototype)", header, rows)
    _write_csv(out, "interference_methods.csv", header, rows)

    def draw(ax):
        for r in rows:
            ax.loglog(
                r[4], r[5], "o" if r[0] == "exact" else "s", color="C0" if r[0] == "exact" else "C1"
            )
            label = f"{r[0]} ({r[1]} pos.)" if r[0] == "exact" else f"mesh, chord {r[2]} mm"
            ax.annotate(label, (r[4], r[5]), fontsize=8)
        ax.set_xlabel("time per crank position [ms]")
        ax.set_ylabel("smallest interference told from contact [mm]")
        ax.set_title(f"interference check: exact vs mesh ({_machine()})")

    _figure(out, "interference_methods.png", draw)
    return rows


#: ``templates/prototype.toml`` without its comments (the design is GearDesign's default).
