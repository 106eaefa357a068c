"""Memory, time and file-size estimates, checked before any heavy work.

Every size a scene can set has a static upper bound in the scene schema;
on top of that :func:`check_scene` estimates what the run would need and
refuses a scene that would pass ``MEMORY_BUDGET`` bytes of memory or write
an exploding file, with one line naming the key and a value that would work.

The per-cell costs are measured (peak RSS, prototype design, numpy 2):

* ``solve_forces``: 36 000 positions x 26 rollers raised the peak RSS by
  285 MB, 305 bytes per (position, roller) cell; a whole forces-only run
  (solver, then forces.csv formatted while the result is alive) peaked at
  260 MB for 10 000 positions and 678 MB for 40 000: 561 bytes per cell
  -> ``SOLVER_CELL_BYTES`` (a DXF-only run peaks at 103 MB, below ``BASE_BYTES``).
* ``monte_carlo``: a chunk of 50 samples x 3600 positions x 26 rollers
  raised it by 3.0 GB, 650 bytes per (sample, position, roller) cell ->
  ``BATCH_CELL_BYTES``; every worker holds one chunk.

Vertex counts come from the exact curves' curvature: a chord of length
``l`` on a circle of radius ``R`` misses it by ``l^2 / (8 R)``, so a polyline
within ``tol`` needs ``integral of sqrt(kappa / (8 tol)) ds`` segments.
Pure numpy.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SceneError

__all__ = [
    "MEMORY_BUDGET",
    "MAX_PROFILE_VERTICES",
    "MAX_MESH_TRIANGLES",
    "MAX_CSV_BYTES",
    "Estimate",
    "polyline_segments",
    "estimate",
    "check_scene",
    "default_workers",
]

#: Largest memory (bytes) a run may plan to use.
MEMORY_BUDGET = 2 * 1024**3
#: Interpreter, numpy, scipy, the exporters: what a run holds before its arrays.
BASE_BYTES = 250 * 1024**2
SOLVER_CELL_BYTES = 600
BATCH_CELL_BYTES = 700
#: Samples per Monte Carlo task (``tolerance.monte_carlo``'s ``chunk``).
MC_CHUNK = 50
#: Most vertices (polyline/arcs) or control points (spline) of one DXF profile:
#: the approximator's own budget (``sampling._MAX_VERTICES``, a test keeps the
#: two equal), beyond which it cannot reach the tolerance.
MAX_PROFILE_VERTICES = 200_000
#: Most triangles of one mesh file (an STL of 5e6 triangles is 250 MB).
MAX_MESH_TRIANGLES = 5_000_000
#: Largest CSV a run may write (forces.csv rows are about 110 bytes).
MAX_CSV_BYTES = 1024**3
FORCES_ROW_BYTES = 110
#: The prototype's assembly_000deg.stl at chord_tolerance 1e-3 has 174 364
#: triangles, the extruded-polygon count below gives 119 787: scale by 1.5.
MESH_CALIBRATION = 1.5
MC_ROW_BYTES = 200


def default_workers() -> int:
    """Processes a default pool starts (the usable cores)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _locus(design, per_tooth: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Roller-centre locus and the working profile (outer offset by r), (n, 2) each."""
    z, e, r = design.tooth_count, design.eccentricity, design.roller_radius
    L = design.cam_radius + r
    t = np.linspace(0.0, 2.0 * np.pi, per_tooth * z, endpoint=False)
    psi = z * t
    s = e * np.cos(psi) + np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    p = np.stack([s * np.sin(t), s * np.cos(t)], axis=1)
    d = np.roll(p, -1, axis=0) - np.roll(p, 1, axis=0)
    tang = d / np.linalg.norm(d, axis=1)[:, None]
    # The curve runs clockwise (x = s sin t, y = s cos t): outward is the tangent turned left.
    normal = np.stack([-tang[:, 1], tang[:, 0]], axis=1)
    if np.sum(normal * p) < 0:
        normal = -normal
    return p, p + r * normal


def polyline_segments(points: np.ndarray, tol: float) -> float:
    """Segments a polyline within ``tol`` needs along the closed curve ``points`` (n, 2)."""
    a = np.roll(points, 1, axis=0)
    c = np.roll(points, -1, axis=0)
    ab = np.linalg.norm(points - a, axis=1)
    bc = np.linalg.norm(c - points, axis=1)
    ac = np.linalg.norm(c - a, axis=1)
    cross = np.abs((points - a)[:, 0] * (c - a)[:, 1] - (points - a)[:, 1] * (c - a)[:, 0])
    kappa = 2.0 * cross / np.maximum(ab * bc * ac, 1e-300)  # circumscribed circle
    ds = 0.5 * (ab + bc)
    return float(np.sum(np.sqrt(kappa / (8.0 * tol)) * ds)) + 1.0


def _circle(radius: float, tol: float) -> float:
    if tol >= radius:
        return 8.0
    return max(8.0, math.pi / math.acos(1.0 - tol / radius))


@dataclass(frozen=True)
class Estimate:
    """What a scene's run is expected to need."""

    memory_bytes: dict[str, float]
    profile_vertices: float
    mesh_triangles: float
    csv_bytes: dict[str, float]
    seconds: dict[str, float]
    #: key -> (value, fixed bytes, bytes per unit): how memory grows with each key
    linear: dict[str, tuple[float, float, float]]

    def as_dict(self) -> dict:
        return self.__dict__.copy()


#: Representation -> exponent of 1/tol in the vertex count and the count at
#: tol = 1e-3 as a multiple of the curvature integral there. Measured on the
#: prototype, working and theoretical profiles, tol = 1e-2, 1e-3, 1e-4
#: (``approximate``): polyline 1300/4500/13650 vertices against an integral
#: of 768/2430/7685 (ratio <= 1.85, exponent 1/2); arcs 800/1400/2800; spline
#: 451/701/1251 control points. The ratios round the worst case up; the
#: node-budget sampler (polyline 800/2525/7775) stays below the estimate.
_REPR = {"polyline": (0.5, 1.9), "arcs": (1.0 / 3.0, 0.6), "spline": (0.25, 0.3)}


def estimate(scene, workers: int | None = None) -> Estimate:
    """Memory, vertex, triangle, CSV and time estimates of ``scene``'s run."""
    d = scene.design
    R = d.roller_count
    f = set(scene.formats)
    workers = workers or default_workers()
    locus, work = _locus(d)
    # key -> (value, fixed bytes, bytes per unit of value): need = fixed + slope * value
    lin: dict[str, tuple[float, float, float]] = {}
    csv: dict[str, float] = {}
    secs: dict[str, float] = {}
    forces = "forces" in f or bool(scene.checks.active())
    if forces:
        angles = scene.solver.crank_angles_deg
        key = "[solver] crank_angles_deg" if angles is not None else "[solver] positions"
        P = len(angles) if angles is not None else scene.solver.positions
        lin[key] = (P, BASE_BYTES, SOLVER_CELL_BYTES * R)
        csv[key] = FORCES_ROW_BYTES * P * R
        secs["forces"] = 1.1e-6 * P * R
    if "datasheet" in f or scene.checks.datasheet_active():
        _datasheet_estimate(scene, lin, csv, secs)
    elif "inspection" in f and scene.measured_profile is not None:
        # inspection.json predicted: windup solves at every transmission-error
        # position of the measured ring (mechanics.datasheet.play_figures).
        turn = scene.datasheet["transmission_error_positions_per_turn"]
        lin["[datasheet] transmission_error_positions_per_turn"] = (
            turn,
            BASE_BYTES,
            R * SOLVER_CELL_BYTES * R + 40 * R,
        )
        secs["inspection"] = 1.1e-6 * R * 5 * R * turn
    mc = scene.montecarlo
    if {"montecarlo", "allocation"} & f:
        n = max(mc["samples"] if "montecarlo" in f else 0, mc["allocation_samples"])
        per_sample = 8 * (6 + 4 * R) + 8 * 8  # standard draws of every kind, metrics
        pos = mc["positions"] if "montecarlo" in f else min(mc["positions"], 72)
        per_pos = workers * BATCH_CELL_BYTES * min(MC_CHUNK, n) * R  # one chunk per worker
        lin["[montecarlo] positions"] = (pos, BASE_BYTES + per_sample * n, per_pos)
        lin["[montecarlo] samples"] = (n, BASE_BYTES + per_pos * pos, per_sample)
        if "montecarlo" in f:
            csv["[montecarlo] samples"] = MC_ROW_BYTES * mc["samples"]
            from corr_cad.tolerance.montecarlo import KERNEL_MIN_WORK

            # numpy ~3e-6 s per sample-position-roller; the compiled kernel
            # (used from KERNEL_MIN_WORK on) ~1.1e-7 plus ~1 s to load it.
            kernel = mc["samples"] * pos >= KERNEL_MIN_WORK
            per_cell = 1.1e-7 if kernel else 3.0e-6
            secs["montecarlo"] = per_cell * mc["samples"] * pos * R / workers + kernel * 1.0
    if "sweeps" in f:
        lin["[sweeps] positions"] = (
            scene.sweeps["positions"],
            BASE_BYTES,
            workers * SOLVER_CELL_BYTES * R,
        )
    mem = {k: fixed + slope * v for k, (v, fixed, slope) in lin.items()}
    exponent, ratio = _REPR[scene.representation]
    base = max(polyline_segments(work, 1e-3), polyline_segments(locus, 1e-3))
    verts = ratio * base * (1e-3 / scene.tolerance) ** exponent if "dxf" in f else 0.0
    tri = 0.0
    if {
        "stl",
        "3mf",
        "glb",
        "ply",
        "interference",
        "step",
    } & f:  # the solids are meshed for all of these
        c = scene.chord_tolerance
        ring = polyline_segments(work, c) + _circle(d.ring_outer_radius, c)
        cam = _circle(d.cam_radius, c) + _circle(d.cam_bore_radius, c)
        roller = _circle(d.roller_radius, c)
        frame = _circle(d.frame_inner_radius, c) + _circle(d.frame_outer_radius, c) + R * roller
        # An extruded polygon of V vertices: 2 caps of V - 2 triangles, 2V on the side.
        tri = MESH_CALIBRATION * 4.0 * (ring + 2 * cam + 2 * R * roller + 2 * frame)
    return Estimate(mem, verts, tri, csv, secs, lin)


#: windup.csv: bytes per row (torque, angle, windup at 9 and 12 digits).
WINDUP_ROW_BYTES = 45


def _datasheet_estimate(scene, lin: dict, csv: dict, secs: dict) -> None:
    """The datasheet's memory, windup.csv size and time (the geometry of every position is kept).

    Positions: ``positions_per_mesh`` per mesh period over the span after
    which the windup repeats (one mesh period, a tooth pitch of z + 1 mesh
    periods, or z (z + 1) for a ring deviation, a measured one included);
    the transmission error solves at most ``per_turn`` classes for alike
    parts, else every one of its ``per_turn (z + 1)`` positions.
    """
    from corr_cad.mechanics.datasheet import TORQUE_LEVELS
    from corr_cad.mechanics.windup import mesh_period_rad, result_period_rad

    d = scene.design
    z, R = d.tooth_count, d.roller_count
    ds = scene.datasheet
    mult = round(result_period_rad(d, scene.errors, scene.solver.variants) / mesh_period_rad(d))
    if scene.measured_profile is not None:
        mult = z * R
    ppm, turn = ds["positions_per_mesh"], ds["transmission_error_positions_per_turn"]
    levels = TORQUE_LEVELS + 3  # the grid, 0- and 0+, the band rows
    lin["[datasheet] positions_per_mesh"] = (
        ppm,
        BASE_BYTES,
        mult * (SOLVER_CELL_BYTES * R + 16 * levels),
    )
    solved_per_turn = 1 if mult == 1 else R
    lin["[datasheet] transmission_error_positions_per_turn"] = (
        turn,
        BASE_BYTES,
        solved_per_turn * SOLVER_CELL_BYTES * R + 40 * R,
    )
    csv["[datasheet] positions_per_mesh"] = WINDUP_ROW_BYTES * levels * mult * ppm
    secs["datasheet"] = 1.1e-6 * R * (levels * mult * ppm + 2 * solved_per_turn * turn)


def check_scene(scene, workers: int | None = None) -> Estimate:
    """Refuse a scene whose run would pass the memory budget or write an exploding file."""
    est = estimate(scene, workers)
    budget = MEMORY_BUDGET
    # Blame the key whose own share is largest (samples for 1e7 samples, ...).
    for key, (value, fixed, slope) in sorted(
        est.linear.items(), key=lambda kv: -kv[1][2] * kv[1][0]
    ):
        need = fixed + slope * value
        if need > budget:
            ok = int((budget - fixed) / slope) if budget > fixed else 0
            fit = f"{ok} would fit" if ok >= 1 else "reduce the other sizes first"
            raise SceneError(
                f"{key} = {value}: needs about {need / 1024**3:.3g} GB of memory; at most "
                f"{budget / 1024**3:.3g} GB is allowed; {fit}"
            )
    for key, size in est.csv_bytes.items():
        if size > MAX_CSV_BYTES:
            value = est.linear[key][0]
            ok = max(1, int(value * MAX_CSV_BYTES / size))
            raise SceneError(
                f"{key} = {value}: the CSV would take about {size / 1024**3:.3g} GB; "
                f"at most {MAX_CSV_BYTES / 1024**3:.3g} GB; {ok} would fit"
            )
    if est.profile_vertices > MAX_PROFILE_VERTICES:
        exponent, _ = _REPR[scene.representation]
        ok = scene.tolerance * (est.profile_vertices / MAX_PROFILE_VERTICES) ** (1 / exponent)
        raise SceneError(
            f"[export] tolerance = {scene.tolerance:g}: a {scene.representation} DXF profile "
            f"would need about {est.profile_vertices:.3g} vertices; at most "
            f"{MAX_PROFILE_VERTICES:g}; tolerance = {_round_up(ok):g} would work"
        )
    if est.mesh_triangles > MAX_MESH_TRIANGLES:
        ok = scene.chord_tolerance * (est.mesh_triangles / MAX_MESH_TRIANGLES) ** 2
        raise SceneError(
            f"[export] chord_tolerance = {scene.chord_tolerance:g}: the assembly mesh would "
            f"have about {est.mesh_triangles:.3g} triangles; at most {MAX_MESH_TRIANGLES:g}; "
            f"chord_tolerance = {_round_up(ok):g} would work"
        )
    return est


def _round_up(x: float) -> float:
    """``x`` rounded up to two significant digits (a value to suggest)."""
    if x <= 0:
        return x
    q = 10 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / q) * q
