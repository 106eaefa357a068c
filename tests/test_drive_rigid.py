"""The compiled rigid start of the drive under Palmgren's law
(:mod:`corr_cad.mechanics.drive.drive_rigid`) gives the numpy solver's
(``solver_numerics._solve_positions``) crank rotation and forces to round-off, with
the same iterations, on seeded drives (per-roller radii, phase error, slot fit, row B's
own errors; driving, reversed, zero and small moments); the Monte Carlo's force pass
that runs it solves each drive as the numpy start does, with and without bearings."""

from __future__ import annotations

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.mechanics.row.solver_geometry import cycle_angles
from corr_cad.mechanics.row.solver_numerics import _solve_positions

DESIGN = GearDesign()


def _errors(seed: int) -> tuple[ManufacturingErrors, ManufacturingErrors]:
    rng = np.random.default_rng(seed)
    z = DESIGN.roller_count
    a = ManufacturingErrors(
        roller_radius_errors=tuple(rng.normal(0.0, 0.002, z)),
        cam_phase_error=float(rng.normal(0.0, 2e-4)),
        slot_clearance=0.002 if seed % 2 else None,
        cam_radius_error=float(rng.normal(0.0, 0.002)),
    )
    b = ManufacturingErrors(roller_radius_error=float(rng.normal(0.0, 0.002)))
    return a, b


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("moment", [1.1e5, -3e4, 0.0, 1e3])
def test_the_compiled_rigid_start_is_the_numpy_solver_s(seed, moment):
    from corr_cad.mechanics.drive.drive_rigid import rigid_palmgren

    ea, eb = _errors(seed)
    solver = DriveSolver(
        DESIGN, cycle_angles(180), errors=ea, errors_b=eb, contact_model="palmgren"
    )
    geo, comp = solver.geo_joined, solver.comp
    tau0, F0, it0, _, _ = _solve_positions(geo, comp, moment, solver.rtol)
    tau, F, it = rigid_palmgren(geo, comp, moment, solver.rtol)
    assert it == it0
    # tau to round-off of the largest rotation, each force to round-off of the largest.
    assert np.max(np.abs(tau - tau0)) <= 1e-12 * np.max(np.abs(tau0))
    assert np.max(np.abs(F - F0)) <= 1e-13 * np.max(F0)
    mom = np.sum(np.where(geo.loadable, geo.arm, 0.0) * F, axis=1)
    assert np.allclose(mom, moment, rtol=0, atol=1e-12 * (abs(moment) + np.max(F) * 10))


@pytest.mark.parametrize("clearance", [None, 0.0, 0.005])
def test_the_force_pass_solves_each_drive_as_the_numpy_start_does(clearance):
    """The force pass's solver (compiled rigid start) against the drive kernel's with the
    numpy start: every field to 1e-12 of its largest value, cams fixed or on needles."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver

    bearing = None if clearance is None else EccentricBearing(40, 6.0, 12.0, clearance)
    for seed in range(3):
        ea, eb = _errors(seed)
        kw = {"errors": ea, "errors_b": eb, "bearing": bearing, "contact_model": "palmgren"}
        ref = CompiledDriveSolver(DESIGN, cycle_angles(72), **kw).result(1.1e5)
        got = ForcePassDriveSolver(DESIGN, cycle_angles(72), **kw).result(1.1e5)
        assert got.success and ref.success
        for name in ("F_j", "F_n", "cam_rotation", "cam_displacement", "row_a_share"):
            a, b = getattr(got, name), getattr(ref, name)
            assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b)), name
        assert got.moment_residual <= 1e-12


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_position_no_roller_can_carry_is_refused_as_the_numpy_solver_refuses():
    """No bracket (every loadable roller masked): the compiled start hands over to the numpy
    solver, whose error names the positions."""
    from corr_cad.errors import SolverError
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver

    solver = ForcePassDriveSolver(DESIGN, cycle_angles(4), contact_model="palmgren")
    solver.geo_joined.loadable[:] = False
    with pytest.raises(SolverError, match="no roller can carry"):
        solver.solve(1.1e5)


def test_the_rigid_kernel_holds_one_specialisation():
    """The warm-up's drive runs leave the rigid start's kernel with one compiled type
    signature (a second would double its compile time)."""
    from corr_cad.mechanics.drive import drive_rigid
    from corr_cad.run import warmup

    warmup._drive_kernels()
    assert len(drive_rigid._rigid.signatures) == 1, drive_rigid._rigid.signatures


@pytest.mark.parametrize("law", ["nonlinear", "palmgren"])
@pytest.mark.parametrize("clearance", [None, 0.005])
def test_the_force_pass_s_lean_result_is_the_result_s_metrics_bit_for_bit(law, clearance):
    """The force pass reads its metrics off ``force_metrics_result``: the same bits as off
    the full :meth:`result` (samples stacked as the Monte Carlo stacks them)."""
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver
    from corr_cad.tolerance.montecarlo_drive import _block_metrics, stacked_geometry

    bearing = None if clearance is None else EccentricBearing(40, 6.0, 12.0, clearance)
    angles = cycle_angles(36)
    pairs = [_errors(seed) for seed in range(3)]
    solver = ForcePassDriveSolver(
        DESIGN,
        np.tile(angles, len(pairs)),
        geometry=stacked_geometry(DESIGN, angles, pairs, np.pi),
        bearing=bearing,
        contact_model=law,
    )
    interval = solver.free_interval(solve=False)
    full = _block_metrics(solver.result(1.1e5), interval, 26.0, len(pairs), len(angles))
    lean = _block_metrics(
        solver.force_metrics_result(1.1e5), interval, 26.0, len(pairs), len(angles)
    )
    assert solver.force_metrics_result(1.1e5).success == solver.result(1.1e5).success
    for name, value in full.items():
        assert np.array_equal(lean[name], value), name


def test_the_block_s_shared_directions_are_the_stacked_rows_own_bit_for_bit():
    """The force pass gives each block the nominal rollers' directions, tiled: the same
    bits as computed from the block's stacked rows."""
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver
    from corr_cad.tolerance.montecarlo_drive import _nominal_rows, stacked_geometry

    angles = cycle_angles(36)
    pairs = [_errors(seed) for seed in range(3)]
    geometry = stacked_geometry(DESIGN, angles, pairs, np.pi)
    tiled = np.tile(_nominal_rows(DESIGN, angles, np.pi)[1], (len(pairs), 1, 1))
    own = ForcePassDriveSolver(DESIGN, np.tile(angles, len(pairs)), geometry=geometry).n
    assert np.array_equal(tiled, own)
    assert not _nominal_rows(DESIGN, angles, np.pi)[1].flags.writeable


def test_the_shared_nominal_rows_are_each_caller_s_own_from_threads():
    """Threads (a Dask worker's) asking for the nominal rows of different angles, in turn,
    each get their own angles' rows: the cache is read and replaced as one entry."""
    from concurrent.futures import ThreadPoolExecutor

    from corr_cad.mechanics.row.solver_geometry import roller_geometry
    from corr_cad.tolerance.montecarlo_drive import _nominal_rows

    sets = [cycle_angles(36), cycle_angles(36) + 0.01, cycle_angles(8)]
    want = [roller_geometry(DESIGN, a, None, (), np.pi).psi for a in sets]

    def ask(k: int) -> bool:
        return np.array_equal(_nominal_rows(DESIGN, sets[k % 3], np.pi)[0][0].psi, want[k % 3])

    with ThreadPoolExecutor(3) as pool:
        assert all(pool.map(ask, range(300)))


@pytest.mark.parametrize("law", ["nonlinear", "palmgren"])
@pytest.mark.parametrize("clearance", [None, 0.005])
def test_the_block_solver_from_shared_parts_is_the_constructor_s_bit_for_bit(law, clearance):
    """The Monte Carlo's block solver (``montecarlo_drive._block_solver``: the nominal rows
    joined and tiled once a run, each sample's gaps and curvatures written in) holds the
    constructor's geometry, compliance, directions and kernel inputs, and gives the same
    bits: the solution, the free interval and the metrics (``_lean_metrics`` against
    ``_block_metrics`` of the full solver's result)."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver, loadable_arrays
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver
    from corr_cad.mechanics.row.solver_geometry import RollerGeometry
    from corr_cad.tolerance.montecarlo_drive import (
        _block_metrics,
        _block_solver,
        _lean_metrics,
        stacked_geometry,
    )

    bearing = None if clearance is None else EccentricBearing(40, 6.0, 12.0, clearance)
    angles = cycle_angles(36)
    z = DESIGN.roller_count
    odd = ManufacturingErrors(  # the frame's slot angles and an eccentricity error too
        eccentricity_error=0.001,
        slot_angle_errors=tuple(np.linspace(-1e-4, 1e-4, z)),
        cam_phase_error=3e-4,
    )
    pairs = [_errors(seed) for seed in range(3)] + [(odd, None), (None, None)]
    n, P = len(pairs), len(angles)
    block = _block_solver(DESIGN, angles, pairs, np.pi, {"bearing": bearing, "contact_model": law})
    ref = ForcePassDriveSolver(
        DESIGN,
        np.tile(angles, n),
        geometry=stacked_geometry(DESIGN, angles, pairs, np.pi),
        bearing=bearing,
        contact_model=law,
    )
    for name in RollerGeometry.__dataclass_fields__:
        assert np.array_equal(getattr(block.geo_joined, name), getattr(ref.geo_joined, name)), name
    if law == "palmgren":
        for name in ("K", "slope0", "cj", "cn", "cs"):
            assert np.array_equal(getattr(block.comp, name), getattr(ref.comp, name)), name
    assert np.array_equal(block.n, ref.n)
    for got, want in zip(block.block_arrays, loadable_arrays(ref.geo_joined), strict=True):
        assert np.array_equal(got, want)
    stacked = np.stack([*loadable_arrays(ref.geo_joined), ref.n[..., 0], ref.n[..., 1]])
    assert np.array_equal(block.kernel_geometry(), stacked)
    got, want = block.solve(1.1e5), ref.solve(1.1e5)
    for k in (0, 1, 2, 4):
        assert np.array_equal(got[k], want[k]), k
    interval = block.free_interval(solve=False)
    own = CompiledDriveSolver.free_interval(ref, solve=False)  # the compiled solver's steps
    for x, y in zip(interval, own, strict=True):
        assert np.array_equal(x, y)
    lean = _lean_metrics(block, got[1], interval, 26.0, n, P)
    full = _block_metrics(ref.result(1.1e5), own, 26.0, n, P)
    for name, value in full.items():
        assert np.array_equal(lean[name], value), name


def test_a_position_s_rigid_start_is_its_own_whatever_came_before_it():
    """The breakpoints' sort starts from the last position's order; equal breakpoints (a
    nominal drive's: every gap 0, every roller's breakpoint at 0) keep the rollers' order,
    so each position's rigid start has the same bits alone as after any other's."""
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver, rigid_palmgren
    from corr_cad.tolerance.montecarlo_drive import stacked_geometry

    angles = cycle_angles(12)
    pairs = [_errors(1), (None, None), _errors(2), (None, None)]

    def rigid(which):
        geometry = stacked_geometry(DESIGN, angles, which, np.pi)
        solver = ForcePassDriveSolver(
            DESIGN, np.tile(angles, len(which)), geometry=geometry, contact_model="palmgren"
        )
        return rigid_palmgren(solver.geo_joined, solver.comp, 1.1e5, solver.rtol)[:2]

    tau, F = rigid(pairs)
    for k, pair in enumerate(pairs):
        own = slice(k * len(angles), (k + 1) * len(angles))
        alone = rigid([pair])
        assert np.array_equal(alone[0], tau[own]) and np.array_equal(alone[1], F[own]), k
