"""What each stage of a run costs: peak memory, time and output bytes, before any work.

One estimator per stage of :data:`corr_cad.run.stages.stages.STAGES`, registered
with :func:`stage_cost`; :func:`corr_cad.run.budget.resources.estimate` adds them up
along the planned stages. A new stage (a datasheet, a modification study)
registers its own (``@stage_cost("name")`` on a function of ``(scene, env)`` that
returns a :class:`Cost`: memory, seconds, output bytes by file, the knobs). Every
constant below was measured on this project's 2-core machine (peak RSS above the
RSS at the stage's start with ``/proc/self/clear_refs``; the bytes of the files
written; wall time) and rounded up; ``corr-cad bench
--study resources`` checks the sum against whole runs. Memory is in bytes,
time in seconds. A *cell* is one (crank position, roller) pair.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from corr_cad.run.budget.costs_bodies import elastic_terms, stage_terms
from corr_cad.run.budget.costs_datasheet import datasheet_size
from corr_cad.run.budget.costs_friction import friction_seconds
from corr_cad.run.budget.costs_measured import measured_points, measured_stage
from corr_cad.run.budget.costs_montecarlo import DRIVE_FORCE_SECONDS, datasheet_pass, drive_seconds
from corr_cad.run.budget.costs_sizing import sizing_work

__all__ = ["Cost", "Env", "ESTIMATORS", "LIBRARY_BYTES", "stage_cost", "MB"]

MB = 1024.0**2

#: Resident bytes of the libraries a stage imports, counted once per run
#: (each measured as the RSS a fresh interpreter gains importing it).
LIBRARY_BYTES = {
    "matplotlib": 60 * MB,
    "trimesh": 70 * MB,  # trimesh, manifold3d, shapely, networkx, lxml
    "ocp": 300 * MB,  # Open CASCADE
    "numba": 130 * MB,  # numba, llvmlite and the compiled kernel
    "ezdxf": 25 * MB,
    "jinja2": 15 * MB,
}
#: A process-pool worker before its first task (a forked interpreter with numpy).
WORKER_BYTES = 110 * MB


@dataclass(frozen=True)
class Env:
    """What the estimate knows beyond the scene."""

    #: Processes sample work runs on (1: serial; Dask: the cluster's, not here).
    workers: int = 1
    #: Pool workers on this machine (0: serial or Dask).
    local_workers: int = 0
    #: Samples solved on a Dask cluster (not in this process).
    remote: bool = False
    #: Assembly-mesh triangles and DXF vertices (from :mod:`corr_cad.run.budget.resources`).
    triangles: float = 0.0
    part_triangles: float = 0.0
    vertices: float = 0.0
    spline_points: float = 0.0
    #: Bytes of the measured-profile file (0: none).
    measured_bytes: int = 0
    measured_dxf: bool = False
    #: A measured CSV's lines and kept points (``measured_io.csv_points_kept``; 0: size-based).
    measured_lines: int = 0
    measured_kept: int = 0
    #: The same of ``[errors.row_b] measured_profile`` (ring B's).
    measured_b_bytes: int = 0
    measured_b_dxf: bool = False
    measured_b_lines: int = 0
    measured_b_kept: int = 0


@dataclass(frozen=True)
class Cost:
    """One stage's needs."""

    #: Peak bytes above what the earlier stages left, in the main process.
    memory: float = 0.0
    #: Bytes it leaves alive for the stages after it.
    keeps: float = 0.0
    #: Bytes in other processes of this machine while it runs (pool workers).
    workers: float = 0.0
    seconds: float = 0.0
    #: File name (or pattern) -> bytes written.
    output: dict[str, float] = field(default_factory=dict)
    #: Libraries it imports (keys of ``LIBRARY_BYTES``).
    libraries: tuple[str, ...] = ()
    #: Scene keys that drive its size, the main one first.
    knobs: tuple[str, ...] = ()
    #: Seconds of its longest single task on one worker (sample work).
    task_seconds: float = 0.0


#: Stage name -> estimator ``(scene, env) -> Cost``.
ESTIMATORS: dict[str, Callable] = {}


def stage_cost(name: str):
    """Register the estimator of stage ``name``."""

    def register(fn):
        ESTIMATORS[name] = fn
        return fn

    return register


def _rollers(scene) -> int:
    return scene.design.roller_count


def _plots(n: int = 1) -> dict:
    return {"libraries": ("matplotlib",), "seconds": 0.8 * n}


# --- profile ---------------------------------------------------------------------------
@stage_cost("undercut")
def _undercut(scene, env):
    return Cost(seconds=0.01)


@stage_cost("profiles")
def _profiles(scene, env):
    return Cost(memory=2 * MB, keeps=1 * MB, seconds=0.05)


#: Seconds a DXF vertex (control point) takes to approximate, per representation:
#: measured on a z = 8 design at tolerance 1e-3, 1e-5 and 1e-7 mm (polyline
#: 1.0e-5 s at 1e5 vertices, arcs 1.6e-4 s at 7.4e3 arcs, spline 5e-5 s at 1.7e3
#: control points, dxf_geometry's time in manifest.json) and rounded up twofold.
VERTEX_SECONDS = {"polyline": 2e-5, "arcs": 2.5e-4, "spline": 1e-4}


@stage_cost("drive")
def _whole_drive(scene, env):
    # [first_stage]: the gears' outlines, the parts' areas and moments (0.57 s measured
    # on templates/compound.toml, manifest.json), rounded up.
    return Cost(memory=40 * MB, seconds=1.0)


@stage_cost("dxf_geometry")
def _dxf_geometry(scene, env):
    # Two profiles approximated; ~2 kB a vertex while the nodes are refined.
    v = env.vertices
    return Cost(
        memory=10 * MB + 2 * 2048 * v,
        keeps=2 * 200 * v,
        seconds=0.2 + VERTEX_SECONDS[scene.representation] * v,
        knobs=("[export] tolerance",),
    )


@stage_cost("dxf_files")
def _dxf_files(scene, env):
    # inner_gear.dxf holds both profiles, ~50 bytes a vertex (737 kB at 2 x 7800).
    return Cost(
        memory=20 * MB + 2 * 600 * env.vertices,
        seconds=0.3 + 2 * 2e-5 * env.vertices,
        output={"*.dxf": 80e3 + 2 * 60 * env.vertices},
        libraries=("ezdxf",),
        knobs=("[export] tolerance",),
    )


@stage_cost("preview_png")
def _preview_png(scene, env):
    if scene.first_stage is not None:  # and first_stage.png
        out = {"preview.png": 0.4 * MB, "first_stage.png": 0.3 * MB}
        return Cost(memory=40 * MB, output=out, **_plots(2))
    return Cost(memory=40 * MB, output={"preview.png": 0.4 * MB}, **_plots())


@stage_cost("measured_profile")
def _measured(scene, env):
    return Cost(**measured_stage(scene, env))


# --- forces ------------------------------------------------------------------------
def _force_cells(scene) -> tuple[str, int]:
    angles = scene.solver.crank_angles_deg
    if angles is not None:
        return "[solver] crank_angles_deg", len(angles) * _rollers(scene)
    return "[solver] positions", scene.solver.positions * _rollers(scene)


@stage_cost("forces")
def _forces(scene, env):
    # The solution (every (position, roller) array) is kept for the later
    # stages: 133-194 bytes a cell measured (36 000 and 120 855 positions).
    key, cells = _force_cells(scene)
    m, s, f = stage_terms(scene)
    mem, sec = 240 * cells + m, 0.05 + 1e-6 * cells * f + s
    return Cost(memory=mem, keeps=220 * cells, seconds=sec, knobs=(key,))


@stage_cost("force_files")
def _force_files(scene, env):
    # forces.csv is formatted 100 000 rows at a time (~40 MB); the plots take
    # ~130 bytes a cell (+140 MB at 936 000 cells, +380 MB at 3.14 million).
    key, cells = _force_cells(scene)
    return Cost(
        memory=60 * MB + 150 * cells,
        seconds=1.0 + 3e-6 * cells,
        output={"forces.csv": 66 * cells, "forces plots": 0.6 * MB},
        libraries=("matplotlib",),
        knobs=(key,),
    )


@stage_cost("checks")
def _checks(scene, env):
    return Cost(seconds=0.01)


# --- datasheet -------------------------------------------------------------------------
#: windup.csv: bytes per row (torque, angle, windup at 9 and 12 digits).
WINDUP_ROW_BYTES = 45


#: A drive windup cell (both rows, the cams on their bearings) against the paper's row:
#: 0.76-0.89 s for 52 positions and 104 transmission-error classes of the prototype
#: with 40-needle bearings (tests/test_drive.py's span case), 0.12 s by the row's rate.
DRIVE_CELLS = 10.0
#: With ``[crankshaft]`` / ``[bearings.crank]``: the drive's solves a windup cell takes
#: (the crank's fixed point, drive_crank): 2.9 s against 0.42 s CPU for the prototype's
#: datasheet with 40-needle bearings (16 positions a mesh), 7.
CRANK_SOLVES = 7.0


@stage_cost("datasheet")
def _datasheet(scene, env):
    # The geometry of every windup position is kept (a solver cell a roller
    # and a torque level), the transmission error solves each of its positions
    # forward and reverse.
    R = _rollers(scene)
    positions, levels, solved, _ = datasheet_size(scene)
    cells = positions * R
    m, s, f = stage_terms(scene)
    memory = 20 * MB + cells * (600 + 16 * levels) + solved * (600 * R + 40) + m
    return Cost(
        memory=memory,
        keeps=cells * 16 * levels + solved * 32,
        seconds=0.05
        + 1.1e-6
        * R
        * (levels * positions + 2 * solved)
        * (DRIVE_CELLS if scene.solver.drive else 1)
        * (CRANK_SOLVES if getattr(scene, "crank", None) is not None else 1)
        * f
        + s
        + friction_seconds(scene, positions, R, DRIVE_CELLS),
        knobs=(
            "[datasheet] positions_per_mesh",
            "[datasheet] transmission_error_positions_per_turn",
        ),
    )


#: A selective-assembly class's datasheet against the datasheet stage's
#: (the same ring, one roller size more): 85 s for 4 classes after a 23.4 s
#: datasheet, a measured ring of 10,400 positions; 0.91, taken as 1.
CLASS_DATASHEETS = 1.0


@stage_cost("datasheet_files")
def _datasheet_files(scene, env):
    positions, levels, _, te_rows = datasheet_size(scene)
    rows = positions * levels
    classes = len((getattr(scene, "assembly", None) or {}).get("roller_classes_um") or ())
    # [assembly]: one full datasheet a roller class, one at a time.
    sheet = _datasheet(scene, env) if classes else Cost()
    return Cost(
        memory=max(30 * MB + 200 * rows + 200 * te_rows, sheet.memory),
        seconds=1.6 + 2e-6 * (rows + te_rows) + classes * CLASS_DATASHEETS * sheet.seconds,
        output={
            "windup.csv": WINDUP_ROW_BYTES * rows,
            "transmission_error.csv": 40 * te_rows,
            "datasheet.json": 20e3,
            "datasheet plots": 0.4 * MB,
            "datasheet.html": 0.6 * MB,  # the plots again, as base64
            **({"assembly.json": 20e3 + 2e3 * classes} if classes else {}),
        },
        libraries=("matplotlib", "jinja2"),
        knobs=(("[assembly] roller_classes_um",) if classes else ())
        + ("[datasheet] positions_per_mesh",),
    )


# --- solids, meshes, STEP, interference ----------------------------------------------
#: Bytes a triangle of each mesh format (measured on the prototype's assembly).
MESH_FILE_BYTES = {"stl": 50.0, "ply": 20.0, "glb": 15.0, "3mf": 25.0}


@stage_cost("solids")
def _solids(scene, env):
    # manifold3d solids and trimesh meshes of the four parts (+64 MB at an
    # assembly of 162 000 triangles, +129 MB at 510 000).
    t = env.triangles
    return Cost(
        memory=30 * MB + 400 * t,
        keeps=20 * MB + 350 * t,
        seconds=0.5 + 2e-6 * t,
        libraries=("trimesh",),
        knobs=("[export] chord_tolerance",),
    )


@stage_cost("mesh_files")
def _mesh_files(scene, env):
    from corr_cad.run.stages.stages_geometry import MESH_FORMATS

    fmts = [f for f in MESH_FORMATS if f in scene.formats]
    n = len(scene.assembly_angles_deg)
    t = env.triangles
    per_tri = sum(MESH_FILE_BYTES[f] for f in fmts)
    return Cost(
        # One assembly at a time: +166 MB at 162 000 triangles, +510 MB at 510 000.
        memory=30 * MB + 1100 * t,
        seconds=0.3 + (n * t + env.part_triangles) * (2e-6 + 2e-6 * len(fmts)),
        output={
            "part meshes": per_tri * env.part_triangles,
            "assembly meshes": n * per_tri * t,
        },
        libraries=("trimesh",),
        knobs=("[export] assembly_angles_deg", "[export] chord_tolerance"),
    )


@stage_cost("step_files")
def _step_files(scene, env):
    # The ring's spline: ~5 kB of STEP a control point, each assembly file
    # about the four parts again (3.4 MB ring, 4.0 MB assembly at 1e-3).
    # Open CASCADE holds an edge a knot span: +100 MB and +39 s (load ~10) from
    # 729 to 2757 control points (a wavy normal table), one assembly angle:
    # ~50 kB and ~4 ms (unloaded) a control point in each file holding the ring.
    n = len(scene.assembly_angles_deg)
    parts = 0.6 * MB + 6e3 * env.spline_points
    return Cost(
        memory=60 * MB + 50e3 * env.spline_points,
        # With FreeCAD's variant written and read back: 7.9 s for the prototype's
        # step_files at a load average of 2.3 (2 CPUs) against 10.3 s estimated here.
        seconds=2.0 + (4 + n) * 0.5 + (1 + n) * 4e-3 * env.spline_points,
        # FreeCAD's variant of each assembly writes each instance's solid
        # again: 2.2 times the assembly (the prototype: the ring twice, the
        # frame three times; 8.7 MB beside 4.0 MB at 1e-3).
        output={"*.step": (1 + n) * parts + 2.2 * n * parts},
        libraries=("ocp",),
        knobs=("[export] assembly_angles_deg", "[export] chord_tolerance"),
    )


@stage_cost("clearance")
def _clearance(scene, env):
    from corr_cad.run.stages.stages_geometry import CLEARANCE_CHUNK_CELLS

    n, R = scene.positions_for("exact"), _rollers(scene)
    if scene.solver.drive:  # both rows: twice the cells, rows and envelopes
        n *= 2
    # One 100 000-cell chunk (~400 bytes a cell) and the per-position envelope.
    return Cost(
        memory=30 * MB + 420 * min(CLEARANCE_CHUNK_CELLS, n * R) + 250 * n,
        keeps=80 * n,
        seconds=0.8 + 2e-6 * n * R,
        output={"clearance.csv": 54 * n * R, "clearance.png": 0.1 * MB},
        libraries=("matplotlib",),
        knobs=("[export] interference_positions",),
    )


@stage_cost("interference")
def _interference(scene, env):
    n, R = scene.positions_for("mesh"), _rollers(scene)
    rows = 2 * n * R  # a dict per row (two cams) kept for the summary and plot
    return Cost(
        memory=40 * MB + 700 * env.triangles + 1500 * rows,
        keeps=1500 * rows,
        seconds=1.0 + 0.03 * n * R,
        output={"interference.csv": 80 * rows, "interference.png": 0.15 * MB},
        libraries=("trimesh", "matplotlib"),
        knobs=("[export] interference_positions", "[export] chord_tolerance"),
    )


# --- tolerances ----------------------------------------------------------------------
def _mc_seconds(samples: int, positions: int, R: int, kernel: bool, workers: int) -> float:
    from corr_cad.tolerance.mc_chunks import CELL_SECONDS

    per_cell = CELL_SECONDS[bool(kernel)]
    return samples * positions * R * per_cell / workers + (2.0 if kernel else 0.0)


def _sample_work(scene, env, samples: int, positions: int, kernel: bool, grid: int) -> dict:
    """Main-process and worker memory of sample work, its libraries, its chunk
    (:mod:`corr_cad.run.budget.costs_montecarlo`)."""
    from corr_cad.run.budget.costs_montecarlo import sample_work
    from corr_cad.tolerance.montecarlo import draw_width

    return sample_work(
        _rollers(scene),
        draw_width(scene.tolerances, _rollers(scene)),
        len(scene.tolerances),
        samples,
        positions,
        kernel,
        grid,
        env.workers,
        env.local_workers,
        env.remote,
        drive=scene.solver.drive,
    )


@stage_cost("montecarlo")
def _montecarlo(scene, env):
    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    mc, R = scene.montecarlo, _rollers(scene)
    n, pos = mc["samples"], mc["positions"]
    kernel = n * pos >= KERNEL_MIN_WORK
    sheet_s, grid = datasheet_pass(scene, n, env.workers)
    work = _sample_work(scene, env, n, pos, kernel, grid)
    work.pop("chunk")
    task = work.pop("task_seconds")
    # The nominal solve and the plots.
    work["memory"] += 240 * pos * R + 40 * MB
    force = _mc_seconds(n, pos, R, kernel, env.workers)
    if scene.solver.drive:  # both rows and the cams' bearings, compiled
        force = n * pos * R * drive_seconds(scene, DRIVE_FORCE_SECONDS) / env.workers
    return Cost(
        keeps=0.0,
        seconds=1.0 + force + 1e-6 * pos * R + sheet_s,
        output={"montecarlo.csv": 70 * n, "montecarlo.png": 0.25 * MB},
        knobs=("[montecarlo] samples", "[montecarlo] positions"),
        task_seconds=task,
        **{**work, "libraries": work["libraries"] + ("matplotlib",)},
    )


ESTIMATORS["sizing"] = lambda s, env: Cost(**sizing_work(s, env.workers, env.local_workers))


@stage_cost("allocation")
def _allocation(scene, env):
    from corr_cad.run.stages.stages_tolerance import ALLOCATION_EVALUATIONS
    from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

    mc, R = scene.montecarlo, _rollers(scene)
    n, pos = mc["allocation_samples"], min(mc["positions"], 72)
    runs = 2 * len(scene.tolerances) * ALLOCATION_EVALUATIONS
    kernel = n * pos * ALLOCATION_EVALUATIONS >= KERNEL_MIN_WORK
    per_run = _mc_seconds(n, pos, R, kernel, env.workers) - (2.0 if kernel else 0.0)
    if scene.solver.drive:
        per_run = n * pos * R * drive_seconds(scene, DRIVE_FORCE_SECONDS) / env.workers
    sheet_s, grid = datasheet_pass(scene, n, env.workers)
    work = _sample_work(scene, env, n, pos, kernel, grid)
    work.pop("chunk")
    task = work.pop("task_seconds")
    if sheet_s:
        per_run += sheet_s - (1.0 if scene.solver.drive else 8.0)
    return Cost(
        seconds=0.5
        + runs * (0.02 + per_run)
        + (2.0 if kernel else 0.0)
        + (8.0 if sheet_s else 0.0),
        output={"allocation.*": 4e3 * len(scene.tolerances)},
        knobs=("[montecarlo] allocation_samples", "[montecarlo] positions"),
        task_seconds=task,
        **work,
    )


#: Seconds a candidate takes besides its cells: its curve built and checked
#: (8193 points), the exact clearance projected onto it. CPU time measured at
#: 10 samples x 8 positions (2080 cells): 8.3 ms (equidistant), 8.7 ms (+shift),
#: 11.5 ms (free: a spline table, a modified curve), rounded up 1.3 times.
CANDIDATE_SECONDS = {"equidistant": 0.011, "equidistant+shift": 0.011, "free": 0.015}


@stage_cost("modification_design")
def _modification_design(scene, env):
    # The samples' gaps are built once (~200 bytes a (sample, position, roller)
    # cell); each candidate projects its modification and re-reads them (~1 us a
    # cell: 49 candidates of 200 x 64 x 26 cells took 10.3 s with the start,
    # 256 took 38 s), after building and checking its curve (CANDIDATE_SECONDS);
    # the feasible few get a force Monte Carlo each. Every candidate's row is
    # kept for modification.json (~2.3 kB of Python objects, then the text).
    # Under the drive a cell of each row, and the samples' drive solver holds both rows
    # joined, their contacts and directions (~160 bytes a cell more: 444 MB peak at
    # 200 x 64 x 52 cells with 40-needle bearings).
    md, R = scene.modification_design, _rollers(scene)
    solver_bytes = 0
    if scene.solver.drive:
        R, solver_bytes = 2 * R, 160
    steps = md["steps"]
    candidates = {"equidistant": steps, "equidistant+shift": steps**2, "free": steps**4}[
        md["family"]
    ]
    cells = md["samples"] * md["positions"] * R
    force = md["force_candidates"] * _mc_seconds(
        md["samples"], md["positions"], R, False, env.workers
    )
    if scene.solver.drive:  # its samples' drive (R counts both rows: a row's cell cost / 2)
        force *= drive_seconds(scene, DRIVE_FORCE_SECONDS) / 2 / 6e-7  # CELL_SECONDS[False]
    return Cost(
        memory=40 * MB + (200 + 40 + solver_bytes) * cells + 4e3 * candidates,
        seconds=2.0 + candidates * (CANDIDATE_SECONDS[md["family"]] + cells * 1e-6) + force,
        output={
            "modification.json": 2e3 * candidates,
            "modification_tradeoff.png": 0.3 * MB,
            "modified.toml": 20e3,
        },
        libraries=("matplotlib",),
        knobs=(
            "[modification.design] steps",
            "[modification.design] samples",
            "[modification.design] positions",
        ),
        task_seconds=CANDIDATE_SECONDS[md["family"]] + cells * 1e-6,
    )


@stage_cost("sweeps")
def _sweeps(scene, env):
    from corr_cad.tolerance.sweeps import PAPER_SWEEPS

    R, pts, pos = _rollers(scene), scene.sweeps["points"], scene.sweeps["positions"]
    solve = 240.0 * pos * R + 10 * MB  # one full-cycle solve
    local = env.local_workers
    count = len(PAPER_SWEEPS) * pts
    # On the crank: its fixed point's solves (as the datasheet's); on the elastic bodies
    # the coupled solve and each design point's own FE reduction (uncached: the worst case).
    chain = CRANK_SOLVES if getattr(scene, "crank", None) is not None else 1.0
    m, fe, f = elastic_terms(scene)
    designs = sum(1 for w in PAPER_SWEEPS.values() if w[0] == "design") * pts if fe else 0
    point = 0.006 + 0.8e-6 * pos * R * chain * f
    return Cost(
        memory=30 * MB + 4e3 * count + (0 if local or env.remote else solve + m),
        workers=local * (WORKER_BYTES + solve + m),
        seconds=1.0 + (count * point + designs * fe) / env.workers + 0.2 * len(PAPER_SWEEPS),
        output={"sweep_*": len(PAPER_SWEEPS) * (0.12 * MB + 120 * pts) + 3e3 * count},
        libraries=("matplotlib",),
        knobs=("[sweeps] points", "[sweeps] positions"),
        task_seconds=point + (fe if designs else 0.0),
    )


# --- shop and inspection -------------------------------------------------------------
@stage_cost("edm_files")
def _edm_files(scene, env):
    return Cost(
        memory=15 * MB + 2000 * env.vertices,
        seconds=3.0 + 5e-4 * env.vertices,
        output={"inner_gear_edm.*": 0.1 * MB + 60 * env.vertices},
        libraries=("ezdxf",),
        knobs=("[export] tolerance",),
    )


def _cmm_count(scene) -> float:
    d = scene.design
    return 2 * math.pi * (d.link_length + d.roller_radius) / scene.inspection["point_spacing"]


@stage_cost("cmm_points")
def _cmm_points(scene, env):
    n = _cmm_count(scene)
    return Cost(
        memory=5 * MB + 600 * n,
        seconds=0.05 + 3e-6 * n,
        output={"inner_gear_nominal.csv": 100 * n},
        knobs=("[inspection] point_spacing",),
    )


@stage_cost("inspection")
def _inspection(scene, env):
    drive = scene.solver.drive
    row_b = (scene.inspection.get("row") or "a") == "b"
    if row_b:
        path = scene.measured_profile_b
        file = (env.measured_b_bytes, env.measured_b_dxf, env.measured_b_lines, env.measured_b_kept)
    else:
        path = scene.measured_profile
        file = (env.measured_bytes, env.measured_dxf, env.measured_lines, env.measured_kept)
    _, kept = measured_points(path, *file)
    key, cells = _force_cells(scene)
    memory, seconds, knobs = 0.0, 0.0, ()
    if drive:  # both rows, at the drive's cost per cell (bearings included)
        cells *= DRIVE_CELLS
    if drive or not ("datasheet" in scene.formats or scene.checks.datasheet_active()):
        # inspection.json "predicted": five windup solves at every transmission-error
        # position of the measured ring (mechanics.datasheet.play_figures); under the drive
        # always (the datasheet follows the scene's rows, the prediction the measured ring).
        R = _rollers(scene)
        turn = scene.datasheet["transmission_error_positions_per_turn"]
        memory = turn * (600.0 * R * R + 40 * R)
        seconds = 1.1e-6 * R * 5 * R * turn * (DRIVE_CELLS if drive else 1.0)
        knobs = ("[datasheet] transmission_error_positions_per_turn",)
    return Cost(
        # 54 MB above the stages before at 200,000 kept points, matplotlib's import included.
        memory=30 * MB + 300 * kept + 2 * 240 * cells + memory,
        seconds=6.0 + 2e-5 * kept + 2e-6 * cells + seconds,
        output={"inspection.*": 0.3 * MB},
        libraries=("matplotlib",),
        knobs=(f"[errors{'.row_b' if row_b else ''}] measured_profile", *knobs),
    )


@stage_cost("report")
def _report(scene, env):
    # Every PNG embedded in base64 (4/3), the page rendered as one string.
    return Cost(
        memory=40 * MB, seconds=1.0, output={"report.html": 2.5 * MB}, libraries=("jinja2",)
    )
