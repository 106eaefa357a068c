"""What accuracy costs in time: the benchmarks behind ``corr-cad bench``.

Each study prints a table (median of repeated runs, the machine's core
count stated), writes a CSV and a PNG under the output folder, and returns
its rows. Nothing here asserts a time: the numbers are for reading.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.geometry.profile import theoretical_profile, working_profile
from corr_cad.geometry.sampling import approximate
from corr_cad.mechanics.solver import cycle_angles, roller_geometry, solve_forces

__all__ = ["STUDIES", "run"]

M0 = 1.1e5


def _median_time(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _median_cpu_time(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times)


def _machine() -> str:
    return f"{os.cpu_count()} cores"


def _write_csv(out: Path, name: str, header: Sequence[str], rows) -> Path:
    from corr_cad.export.files import write_csv

    return write_csv(out / name, header, ([_cell(x) for x in r] for r in rows))


def _cell(x) -> str:
    return f"{x:.6g}" if isinstance(x, float) else str(x)


def _figure(out: Path, name: str, draw: Callable) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    labels = draw(ax)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    if labels:
        # Room on the right for the labels, which run rightwards from their points.
        lo, hi = ax.get_xlim()
        ax.set_xlim(lo, hi * 4.0 if ax.get_xscale() == "log" else hi + 0.25 * (hi - lo))
        _place_labels(ax, labels)
    fig.savefig(out / name, dpi=120, metadata={"Software": None})
    plt.close(fig)
    return out / name


def _place_labels(ax, labels: list[tuple[float, float, str]], size: float = 7.0) -> None:
    """Annotate points so that no two labels print over each other.

    Points whose labels would collide (in display space) get their labels
    stacked downwards, one line each.
    """
    ax.figure.canvas.draw()  # fix the limits and transforms
    placed: list[tuple[float, float]] = []
    line = size * 1.35 * ax.figure.dpi / 72.0  # one text line, pixels
    for x, y, text in labels:
        px, py = ax.transData.transform((x, y))
        k = 0
        while any(abs(px - qx) < 90 and abs(py - k * line - qy) < line for qx, qy in placed):
            k += 1
        placed.append((px, py - k * line))
        ax.annotate(
            text,
            (x, y),
            xytext=(4, -k * size * 1.35 + 2),
            textcoords="offset points",
            fontsize=size,
            annotation_clip=False,
        )


def _table(title: str, header: Sequence[str], rows) -> None:
    print(f"\n{title} ({_machine()})")
    print("  ".join(f"{h:>14s}" for h in header))
    for r in rows:
        print("  ".join(f"{_cell(x):>14s}" for x in r))


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
from corr_cad.run.bench import _tolerances
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


STUDIES = {
    "profile": profile_export,
    "solids": solids,
    "solver": fidelity,
    "speed": solver_speed,
    "montecarlo": montecarlo,
    "throughput": throughput,
    "kernel": kernel_crossover,
    "interference": interference,
    "coldstart": cold_start,
}


def run(out: Path, studies: Sequence[str] = tuple(STUDIES), quick: bool = False) -> dict:
    """Run the chosen studies, writing into ``out``; returns their rows."""
    import platform

    from corr_cad._version import __version__
    from corr_cad.export.files import write_json

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_json(
        out / "machine.json",
        {
            "cores": os.cpu_count(),
            "machine": platform.machine(),
            "python": platform.python_version(),
            "numpy": np.__version__,
            "corr_cad": __version__,
            "quick": quick,
        },
    )
    return {name: STUDIES[name](out, quick) for name in studies}
