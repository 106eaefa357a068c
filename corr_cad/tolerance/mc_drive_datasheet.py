"""Datasheet metrics of the drive's Monte Carlo samples (``[solver] model = "drive"``).

The same columns, with the same meanings, as the paper's row
(:mod:`corr_cad.tolerance.mc_datasheet`), read off the windup ``theta(T, x)``
of the two-row drive (:class:`~corr_cad.mechanics.drive.drive_windup.DriveWindup`'s
definition: the output torque ``T`` is the crank moment ``-T / (z + 1)``
carried by both rows together, ``theta = -tau / (z + 1)``; at ``T = +-0``
an end of the drive's free rotation). Each sample's rows are those the
drive's force pass solves (:mod:`corr_cad.tolerance.montecarlo_drive`: row A
from the seed's draws, row B from its own stream, the frame's slots shared,
the cams on their bearings when the scene gives them).

Evaluation grid: ``[montecarlo] datasheet_positions_per_mesh`` per mesh
period, over one mesh period when both rows' parts are alike, one tooth
pitch when rollers or slots differ in either row or a tolerance makes them
differ, one output revolution once either ring has a profile deviation: the
paper's rules (:func:`~corr_cad.tolerance.mc_datasheet.grid_positions`)
applied to the row that repeats last, as the drive's datasheet does
(:func:`~corr_cad.mechanics.datasheet.span_errors`).

Binding under the drive (:data:`BINDING_DEFINITION`): at zero crank moment
the crank settles where the two rows' moments balance (the drive's
equilibrium, cams on their bearings); what the gaps of both rows, their
interference and the slot fit leave as preload then loads the rollers. The
sample's ``binding_pressure_MPa`` is the largest Hertz pressure of any
roller contact (cam, ring, slot) of either row at any grid position there;
it binds above ``[montecarlo] binding_pressure_MPa``. Rollers whose forces stay
below the solver's idle force there (``drive._IDLE_FORCE``, 1e-9 N: round-off of
rows that just touch) press nothing: 0, not the 1e-118 MPa their round-off gives.

Samples are solved in blocks: their geometries stacked sample-major
(:func:`~corr_cad.tolerance.montecarlo_drive.stacked_geometry`), the rollers'
directions the nominal ones tiled, one
:class:`~corr_cad.mechanics.drive.drive_kernel.CompiledDriveSolver` per block for
the six windup torques and the zero moment. With bearings (:func:`_solve_all`), each
sign's largest torque's bearing Newton starts from the rigid solve (compiled under
Palmgren's law, :func:`~corr_cad.mechanics.drive.drive_rigid.rigid_palmgren`; the
exact linear-contact solution under the paper's law), its smallest from the largest's
solution scaled, the torques between and the zero moment from the solutions on
either side interpolated in the moment; positions the Newton misses from there
start again from the rigid solve, and those it misses then are restarted from other
moments' solutions (:mod:`corr_cad.mechanics.drive.drive_restart`). Every
position's solve is its own, so a sample's metrics are those of solving it
alone (``tests/test_mc_drive_datasheet.py``).
"""

from __future__ import annotations

import functools

import numpy as np

from corr_cad.mechanics import contact
from corr_cad.mechanics.datasheet import span_errors
from corr_cad.mechanics.drive.drive import _IDLE_FORCE
from corr_cad.mechanics.row.windup import crank_angles_of
from corr_cad.tolerance.mc_datasheet import DatasheetMC, grid_positions, windup_metrics
from corr_cad.tolerance.montecarlo_drive import (
    _nominal_rows,
    chain_solver,
    drive_chunk,
    row_b_tolerances,
    stacked_geometry,
)

__all__ = [
    "BINDING_DEFINITION",
    "BLOCK_POSITIONS",
    "drive_grid",
    "drive_task",
    "drive_datasheet_samples",
]

#: ``montecarlo_summary.json``'s statement of binding under the drive.
BINDING_DEFINITION = (
    "largest Hertz pressure of any roller contact (cam, ring, slot) of either row at zero "
    "crank moment: the drive's equilibrium with the preload that both rows' gaps, "
    "interference and slot fit leave (cams on their bearings when given), over the "
    "sample's grid; a sample binds above binding_pressure_MPa"
)

#: Positions (samples x grid positions) solved together: small enough to stay in the CPU
#: cache (500 measured 1.3x faster than 2,000 without bearings, 1.1x with them).
BLOCK_POSITIONS = 500

#: The rigid solve's relative residual where it stops as the bearing Newton's start
#: (:func:`_from_rigid`): on the prototype the Newton then takes the steps it takes from
#: the converged rigid solve (4.0 a position at the rated torque), for 30 % less CPU in
#: the rigid solve.
_RIGID_START_RTOL = 1e-3


def drive_grid(design, base, base_b, tolerance_kinds, positions_per_mesh: int) -> np.ndarray:
    """The samples' evaluation grid (output angles, rad) under the drive; see the module
    docstring. ``base_b``: row B's errors (None: ``[errors]`` describes both rows)."""
    periodic = span_errors(design, base, {"errors_b": base_b})
    return grid_positions(design, periodic, tolerance_kinds, positions_per_mesh)


def drive_datasheet_samples(
    design, pairs: list, cfg: DatasheetMC, grid: np.ndarray, psi_limit: float, drive: dict
) -> tuple[dict[str, np.ndarray], bool]:
    """The datasheet metrics of the samples ``pairs`` (``(errors, errors_b)`` each) at the
    output angles ``grid``; ``drive``: bearings and contact law. Returns ``(metrics, ok)``,
    ``ok`` False where some position's equilibrium was not reached."""
    solver_class = _linear_start_solver()  # numba: only when run
    phi = crank_angles_of(np.asarray(grid, dtype=float).reshape(-1), design)
    P = len(phi)
    torques, zero, _ = cfg.torques()
    ratio = float(design.roller_count)
    theta = np.empty((len(pairs), P, len(torques)))
    pressure = np.empty(len(pairs))
    ok = True
    block = max(1, BLOCK_POSITIONS // P)
    for lo in range(0, len(pairs), block):
        part = pairs[lo : lo + block]
        n = len(part)
        solver = _block_solver(solver_class, design, phi, part, psi_limit, drive)
        ends = None
        moments = {}
        for j, T in enumerate(torques):
            if zero[j] != 0:  # theta(0-) or theta(0+): an end of the free rotation
                if ends is None:
                    rev, fwd = solver.free_interval()
                    ends = (-fwd / ratio, -rev / ratio)
                theta[lo : lo + n, :, j] = ends[0 if zero[j] < 0 else 1].reshape(n, P)
            else:
                moments[j] = -float(T) / ratio
        sols, good = _solve_all(solver, moments)
        for j, sol in sols.items():
            theta[lo : lo + n, :, j] = (-sol[0] / ratio).reshape(n, P)
        at, good_zero = _preload_pressure(solver, sols, moments)
        ok &= good and good_zero
        pressure[lo : lo + n] = at.reshape(n, P).max(axis=1)
    return windup_metrics(theta, cfg, pressure), ok


def _block_solver(solver_class, design, phi: np.ndarray, pairs: list, psi_limit: float, drive):
    """The stacked drive solver of a block (:func:`chain_solver`); the eccentrics fixed and
    the bodies rigid, the rollers' directions the nominal ones tiled (the same bits as
    computed from the stacked rows, as the force pass takes them)."""
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver

    chain = drive.get("crank") is not None or drive.get("bodies") is not None
    if chain or not issubclass(solver_class, ForcePassDriveSolver):
        return chain_solver(solver_class, design, phi, pairs, psi_limit, drive)
    return solver_class(
        design,
        np.tile(phi, len(pairs)),
        geometry=stacked_geometry(design, phi, pairs, psi_limit),
        directions=np.tile(_nominal_rows(design, phi, psi_limit)[1], (len(pairs), 1, 1)),
        bearing=drive.get("bearing"),
        bearing_b=drive.get("bearing_b"),
        contact_model=drive.get("contact_model", "nonlinear"),
    )


@functools.cache
def _linear_start_solver():
    """The compiled drive solver whose bearing Newton starts from the exact linear-contact
    solution (``solver_numerics._linear_tau``) instead of the rigid one, with the rigid
    start where a position misses from there (the paper's law on bearings; otherwise the
    rigid start, compiled under Palmgren's law:
    :class:`~corr_cad.mechanics.drive.drive_rigid.ForcePassDriveSolver`)."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver  # numba: only when run
    from corr_cad.mechanics.drive.drive_restart import replace_positions, subset_solver
    from corr_cad.mechanics.drive.drive_rigid import ForcePassDriveSolver
    from corr_cad.mechanics.row.solver_numerics import _linear_tau

    class LinearStartDriveSolver(ForcePassDriveSolver):
        def solve(self, target):
            comp = self.comp
            if (
                self.bearings[0] is None
                or self.crank is not None  # the chain's own solve (drive_crank, bodies)
                or self.bodies is not None
                or getattr(comp, "explicit", False)
                or getattr(comp, "linear", False)
            ):
                return super().solve(target)
            geo = self.geo_joined
            a_c = np.where(geo.loadable, geo.advance, 0.0)
            h0 = np.where(geo.loadable, geo.gap, -1e300)
            a_m = np.where(geo.loadable, geo.arm, 0.0)
            tau = _linear_tau(a_c, a_m, h0, comp.slope0, target)
            h = tau[:, None] * a_c + h0
            F = np.where(h > 0, h / comp.slope0, 0.0)
            sol = list(self._with_bearings(target, tau, F, 0))
            idx = np.flatnonzero(~(sol[4] <= max(self.rtol, 1e-9)))
            if idx.size:
                rigid = CompiledDriveSolver.solve(subset_solver(self, idx), target)
                replace_positions(sol, rigid, idx, idx >= 0)
            return tuple(sol)

    return LinearStartDriveSolver


def _preload_pressure(solver, sols: dict, moments: dict) -> tuple[np.ndarray, bool]:
    """The largest contact pressure at zero crank moment at each position, MPa, and whether
    every position settled. Where the rows' gaps leave the crank free play (the rigid
    rows' free intervals intersect) nothing presses: 0 without a solve (the zero-moment
    equilibrium is then force-free, with or without bearings); elsewhere the drive's
    equilibrium at zero moment (with bearings, from the smallest moments' solutions of
    either sign interpolated to zero moment), restarted where missed from the torques'
    solutions. Positions whose rollers stay below the solver's idle force touch: 0."""
    from corr_cad.mechanics.drive.drive_restart import restart_missed, subset_solver

    geo = solver.geo_joined
    a = np.where(geo.loadable, geo.advance, 0.0)
    g = np.where(geo.loadable, geo.gap, -np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -g / a
    fwd = np.min(np.where(a > 0, t, np.inf), axis=1)
    rev = np.max(np.where(a < 0, t, -np.inf), axis=1)
    out = np.zeros(len(fwd))
    idx = np.flatnonzero(~(fwd > rev))
    if idx.size == 0:
        return out, True
    # Every position on the eccentrics: the block's own solver (the same positions, no copy).
    every = idx.size == len(fwd) and solver.crank is None and solver.bodies is None
    sub = solver if every else subset_solver(solver, idx, chain=True)
    near = sorted(sols, key=lambda k: abs(moments[k]))
    neg = [k for k in near if moments[k] < 0]
    pos = [k for k in near if moments[k] > 0]
    if neg and pos and _warm_starts(sub):
        # Between the smallest moments of either sign, linear in the moment.
        lo, hi = (sols[k] if every else _take(sols[k], idx) for k in (neg[0], pos[0]))
        w = -moments[neg[0]] / (moments[pos[0]] - moments[neg[0]])
        first = _warm(sub, 0.0, lo[0] + w * (hi[0] - lo[0]), lo[1] + w * (hi[1] - lo[1]))
    else:
        first = sub.solve(0.0)
    limit = max(solver.rtol, 1e-9)
    zero = first
    if not np.all(first[4] <= limit):
        starts = [sols[k] if every else _take(sols[k], idx) for k in near]
        zero = restart_missed(sub, 0.0, first, starts)
    # The cam, slot and ring pressures of both rows as DriveSolver._build gives them (the
    # same elementwise expressions; the half-width factors the compliance's own).
    F, geo, comp = zero[1], sub.geo_joined, sub.comp
    length = solver.design.roller_length
    p_cam = contact.max_pressure(F, comp.cj, length)
    p_slot = contact.max_pressure(np.abs(geo.rho_s * F), comp.cs, length)
    p_gear = contact.max_pressure(geo.rho_n * F, comp.cn, length)
    peak = np.maximum(np.maximum(p_cam, p_slot), p_gear).max(axis=1)
    # Rollers below the solver's idle force touch without load (drive._IDLE_FORCE: round-off
    # of rows that just touch): no pressure.
    out[idx] = np.where(np.max(F, axis=1) <= _IDLE_FORCE, 0.0, peak)
    return out, bool(np.all(zero[4] <= limit))


def _take(sol, idx: np.ndarray) -> tuple:
    """The positions ``idx`` of a solution ``(tau, F, u, Qs, rel, it)``."""
    tau, F, u, Qs, rel, it = sol
    return tau[idx], F[idx], u[:, idx], None if Qs is None else [q[idx] for q in Qs], rel[idx], it


def _solve_all(solver, moments: dict) -> tuple[dict, bool]:
    """Each crank moment's solution ``{key: (tau, F, u, Qs, rel, it)}`` and whether every
    position reached equilibrium.

    With bearings (:func:`_warm_starts`), each sign's largest moment is solved from the
    rigid start (:func:`_from_rigid`), its smallest from the largest's solution scaled by the
    moments' ratio, and the moments between from the solutions of the nearest moments
    solved on either side, interpolated linearly in the moment (the bearing Newton's
    ``(tau, F)`` start; its positions that miss from there from the rigid start). On the
    prototype this takes 12 % fewer Newton steps a position than solving from the smallest
    moment up, and one rigid start a sign at the moment it converges fastest; the same
    equilibrium to the solver's tolerance. Positions still unsettled are solved again
    from their own solution at the other moments, nearest first
    (:func:`~corr_cad.mechanics.drive.drive_restart.restart_missed`). Every step is per
    position: a sample in a block equals the sample alone.
    """
    from corr_cad.mechanics.drive.drive_restart import restart_missed

    limit = max(solver.rtol, 1e-9)
    first: dict = {}
    for sign in (-1.0, 0.0, 1.0):
        keys = sorted(
            (k for k in moments if np.sign(moments[k]) == sign), key=lambda k: abs(moments[k])
        )
        if not keys:
            continue
        if sign == 0.0 or not _warm_starts(solver):
            first.update((k, solver.solve(moments[k])) for k in keys)
            continue
        top = keys[-1]
        first[top] = _from_rigid(solver, moments[top])
        for j, k in enumerate(keys[:-1]):
            m = moments[k]
            above = moments[top]
            if j == 0:  # the smallest: the largest's solution scaled
                r = m / above
                tau, F = first[top][0] * r, first[top][1] * r
            else:  # between the largest solved below and the largest: linear in the moment
                below = keys[j - 1]
                w = (m - moments[below]) / (above - moments[below])
                lo, hi = first[below], first[top]
                tau, F = lo[0] + w * (hi[0] - lo[0]), lo[1] + w * (hi[1] - lo[1])
            first[k] = _warm(solver, m, tau, F)
    sols = {}
    for k, m in moments.items():
        others = sorted((o for o in moments if o != k), key=lambda o: abs(moments[o] - m))
        sols[k] = restart_missed(solver, m, first[k], [first[o] for o in others])
    return sols, all(bool(np.all(s[4] <= limit)) for s in sols.values())


def _warm_starts(solver) -> bool:
    """Whether the bearing Newton may start from other moments' solutions (:func:`_warm`):
    bearings under a law the compiled Newton solves, without the chain's own solve."""
    if solver.bearings[0] is None or getattr(solver.comp, "linear", False):
        return False
    return solver.crank is None and solver.bodies is None


def _from_rigid(solver, m: float) -> tuple:
    """The solution at crank moment ``m`` from the rigid start; under Palmgren's law the
    compiled rigid solve stopped at :data:`_RIGID_START_RTOL` of its terms (the bearing
    Newton takes as many steps from there as from the converged rigid solve)."""
    from corr_cad.mechanics.drive.drive_rigid import rigid_palmgren

    if not getattr(solver.comp, "explicit", False):
        return solver.solve(m)
    rigid = rigid_palmgren(solver.geo_joined, solver.comp, m, _RIGID_START_RTOL)
    if rigid is None:  # no bracket somewhere: the solver's own solve says where
        return solver.solve(m)
    return _warm(solver, m, rigid[0], rigid[1])


def _warm(solver, m: float, tau: np.ndarray, F: np.ndarray) -> tuple:
    """The bearing Newton at crank moment ``m`` from the start ``(tau, F)``; the positions
    that miss from there from the solver's own (rigid) start."""
    from corr_cad.mechanics.drive.drive_restart import replace_positions, subset_solver

    sol = list(solver._with_bearings(m, tau, F, 0))
    idx = np.flatnonzero(~(sol[4] <= max(solver.rtol, 1e-9)))
    if idx.size:
        replace_positions(sol, subset_solver(solver, idx).solve(m), idx, idx >= 0)
    return tuple(sol)


def drive_task(
    design,
    input_torque,
    angles,
    base,
    base_b,
    tolerances,
    draws,
    draws_b,
    n,
    psi_limit,
    drive,
    errors_for,
    datasheet: DatasheetMC | None = None,
    grid: np.ndarray | None = None,
):
    """One chunk of the drive's Monte Carlo (runs in a worker): the force metrics
    (:func:`~corr_cad.tolerance.montecarlo_drive.drive_chunk`, same arguments) and, with
    ``datasheet``, the same samples' datasheet metrics on ``grid``. Returns ``(metrics, ok)``."""
    metrics, ok = drive_chunk(
        design,
        input_torque,
        angles,
        base,
        base_b,
        tolerances,
        draws,
        draws_b,
        n,
        psi_limit,
        drive,
        errors_for,
    )
    if datasheet is None:
        return metrics, ok
    tol_b = row_b_tolerances(tolerances)
    pairs = [
        (errors_for(base, tolerances, draws, k), errors_for(base_b, tol_b, draws_b, k))
        for k in range(n)
    ]
    extra, ok_ds = drive_datasheet_samples(design, pairs, datasheet, grid, psi_limit, drive)
    return {**metrics, **extra}, ok and ok_ds
