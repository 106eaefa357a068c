"""Positions the drive's bearing Newton misses from its rigid start, solved again from
another moment's solution.

With eccentric bearings, :class:`~corr_cad.mechanics.drive.drive.DriveSolver` runs
a Newton on ``(tau, u_A, u_B)`` from the rigid solution, each cam displaced
along its load by Stribeck's estimate. The residual has kinks (a roller or a
needle entering contact, a cam within its clearance, where its stiffness is
zero), and at a small moment or with clearances the line search can find no
descent from that start: the position is then reported unsettled.

Here such a position is solved again with the same Newton, started from its
own solution at another crank moment (nearest first). The equilibrium is
unique (the contacts' and needles' energy is convex; with the moment given,
the crank rotation is fixed), so any start that converges gives the same
state to the solver's tolerance. A position's restart uses its own data
only: a position solved in a block equals the position solved alone.
"""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np

__all__ = ["restart_from", "restart_missed", "subset_solver", "replace_positions"]


def restart_missed(solver, target: float, sol, starts: list) -> tuple:
    """``sol`` (``solver.solve(target)``'s ``(tau, F, u, Qs, rel, iterations)``) with its
    unsettled positions solved again from ``starts`` (solutions of the same solver at other
    moments, nearest first), where they settle from one."""
    # With a crankshaft the coupling restarts its own misses (drive_crank: the geometry
    # moves); with elastic bodies the restart would solve the rigid bodies' drive.
    if solver.bearings[0] is None or solver.crank is not None or solver.bodies is not None:
        return sol
    return restart_from(solver, target, sol, starts)


def restart_from(solver, target: float, sol, starts: list) -> tuple:
    """``sol`` with each unsettled position solved again by the bearing Newton from the
    first of ``starts`` (``None`` skipped) that settled there, where it settles."""
    limit = max(solver.rtol, 1e-9)
    out = list(sol)
    for start in starts:
        if start is None:
            continue
        idx = np.flatnonzero(~(out[4] <= limit) & (start[4] <= limit))
        if idx.size == 0:
            continue
        sub = subset_solver(solver, idx)
        got = sub._with_bearings(target, start[0][idx], start[1][idx], 0)
        replace_positions(out, got, idx, got[4] <= limit)
    return tuple(out)


def replace_positions(sol: list, got, idx: np.ndarray, fixed: np.ndarray) -> None:
    """Positions ``idx[fixed]`` of ``sol`` (``tau, F, u, Qs, rel, it``) from ``got``."""
    pick = idx[fixed]
    for i in (0, 1, 4):
        sol[i] = sol[i].copy()
        sol[i][pick] = got[i][fixed]
    sol[2] = sol[2].copy()
    sol[2][:, pick] = got[2][:, fixed]
    sol[3] = [q.copy() for q in sol[3]]
    for c in (0, 1):
        sol[3][c][pick] = got[3][c][fixed]


def _contact_model(comp) -> str:
    if getattr(comp, "explicit", False):
        return "palmgren"
    return "linear" if getattr(comp, "linear", False) else "nonlinear"


def subset_solver(solver, idx: np.ndarray, chain: bool = False):
    """The drive solver (same class) of the positions ``idx``: its geometry's rows;
    ``chain``: with the solver's crankshaft and elastic bodies (their influence at
    those positions), else the contacts and bearings only."""
    P = len(solver.crank_angles)

    def take(g):
        kw = {}
        for f in fields(g):
            v = getattr(g, f.name)
            if isinstance(v, np.ndarray) and v.ndim >= 1 and v.shape[0] == P:
                kw[f.name] = v[idx]
        return replace(g, **kw)

    sub = type(solver)(
        solver.design,
        solver.crank_angles[idx],
        geometry=tuple(take(g) for g in solver.geo),
        bearing=solver.bearings[0],
        bearing_b=solver.bearings[1],
        contact_model=_contact_model(solver.comp),
        rtol=solver.rtol,
        crank=solver.crank if chain else None,
        bodies=solver.bodies.tables if chain and solver.bodies is not None else None,
    )
    phases = getattr(solver, "cam_phases", None)
    if chain and phases is not None:  # stacked samples' own cam B phases (drive_crank)
        sub.cam_phases = phases[idx]
    return sub
