"""The drive's windup ``theta(T, x)``: both rows together, crank locked (``model = "drive"``).

The bench view of :mod:`corr_cad.mechanics.row.windup`, with the drive model of
:mod:`corr_cad.mechanics.drive.drive`: an output torque ``T`` is the crank moment
``-T / (z + 1)`` carried by both rows together (no load share), and

    theta(T, x) = -tau / (z + 1)

with ``tau`` the crank rotation shared by both cams.

Free rotation (backlash). The crank rotations each row allows without load
form an interval; the drive's is the intersection of both rows' intervals,
since the crank is one. The ends come from the gaps alone
(:meth:`~corr_cad.mechanics.drive.drive.DriveSolver.free_interval`): with a bearing
clearance each cam may also shift within it, which widens its row's interval
where that lets the cam move.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.mechanics.drive.drive_crank import CrankSupport
from corr_cad.mechanics.drive.drive_numerics import free_row
from corr_cad.mechanics.drive.drive_restart import restart_missed
from corr_cad.mechanics.row.solver_numerics import _RTOL
from corr_cad.mechanics.row.windup import WindupCurve

__all__ = ["DriveWindup"]

_BLOCK_ELEMENTS = 6000
#: Solutions kept per block as starts of a restart (drive_restart).
_RESTARTS = 2


class DriveWindup(WindupCurve):
    """:class:`~corr_cad.mechanics.row.windup.Windup` of the two-row drive (same methods)."""

    def __init__(
        self,
        design: GearDesign,
        output_angles: np.ndarray,
        *,
        errors: ManufacturingErrors | None = None,
        errors_b: ManufacturingErrors | None = None,
        bearing: EccentricBearing | None = None,
        bearing_b: EccentricBearing | None = None,
        contact_model: str = "nonlinear",
        variants: tuple[str, ...] = (),
        psi_contact_limit: float = math.pi,
        series_rigidity_Nm_per_arcmin: float | None = None,
        rtol: float = _RTOL,
        crank: CrankSupport | None = None,
        bodies=None,
    ):
        if "working_half_only" in variants:
            raise SolverError(
                "variant 'working_half_only' is the paper's one-row form; the drive model "
                "loads both halves of both rows"
            )
        self._place(design, output_angles)
        self.series_rigidity_Nm_per_arcmin = series_rigidity_Nm_per_arcmin
        self.bearings = (bearing, bearing_b if bearing_b is not None else bearing)
        solver_options = dict(
            errors=errors,
            errors_b=errors_b,
            bearing=bearing,
            bearing_b=bearing_b,
            contact_model=contact_model,
            variants=variants,
            psi_contact_limit=psi_contact_limit,
            rtol=rtol,
            crank=crank,
            bodies=bodies,
        )
        #: The keyword arguments of this windup (:meth:`at`).
        self._options = dict(
            solver_options, series_rigidity_Nm_per_arcmin=series_rigidity_Nm_per_arcmin
        )
        self._ratio = float(design.roller_count)
        step = max(1, _BLOCK_ELEMENTS // (2 * design.roller_count))
        self._blocks = []
        for a in range(0, len(self.output_angles), step):
            sl = slice(a, a + step)
            self._blocks.append((sl, DriveSolver(design, self.crank_angles[sl], **solver_options)))
        self._cache: dict[float, tuple] = {}
        #: Each block's last solutions ``(crank moment, solution)``: restarts' starts.
        self._history: list[list] = [[] for _ in self._blocks]

    def cam_moment(self, output_torque: float) -> float:
        """The crank moment (solver sign) of an output torque, N*mm: ``-T / (z + 1)``."""
        return -float(output_torque) / self._ratio

    def _solve(self, output_torque: float):
        """``(theta (P,), row_a_share (P,), [(slice, solver, solution)])`` at ``T``."""
        T = float(output_torque)
        if T in self._cache and math.copysign(1.0, T) == self._cache[T][0]:
            return self._cache[T][1]
        target = self.cam_moment(T)
        theta = np.empty(len(self.crank_angles))
        share = np.empty_like(theta)
        pieces = []
        for b, (sl, solver) in enumerate(self._blocks):
            sol = solver.solve(target)
            # Positions the bearing Newton misses from its rigid start: from the solutions
            # at the torques solved before, nearest first (drive_restart).
            near = sorted(self._history[b], key=lambda h: abs(h[0] - target))
            sol = restart_missed(solver, target, sol, [h[1] for h in near])
            tau, F, u, Qs, rel, it = sol
            what = f"drive windup at output torque {T:g} N*mm: equilibrium"
            self._settled(rel, solver.rtol, what)
            theta[sl] = -tau / self._ratio
            share[sl] = solver.share(F)
            pieces.append((sl, solver, sol))
            self._history[b] = [(target, sol), *self._history[b]][:_RESTARTS]
        out = (theta, share, pieces)
        self._cache = {T: (math.copysign(1.0, T), out)}
        return out

    def free_ends(self) -> tuple[np.ndarray, np.ndarray]:
        """``theta(0-)`` and ``theta(0+)`` of the drive, rad (P,) each
        (:meth:`~corr_cad.mechanics.drive.drive.DriveSolver.free_interval`)."""
        lo = np.empty(len(self.crank_angles))
        hi = np.empty_like(lo)
        for sl, solver in self._blocks:
            rev, fwd = solver.free_interval()
            # T > 0 turns the crank backwards (tau < 0): theta(0-) is the forward end.
            lo[sl], hi[sl] = -fwd / self._ratio, -rev / self._ratio
        return lo, hi

    def slack(self) -> np.ndarray:
        """Positions where no contact carries a force at zero torque, bool (P,).

        Every row's rollers clear of its cam somewhere in its bearing
        clearance (no row preloaded, :func:`free_row`) and the crank free
        between the rows (``theta(0+) > theta(0-)``): no force solve.
        """
        out = np.empty(len(self.crank_angles), dtype=bool)
        for sl, solver in self._blocks:
            geo, R = solver.geo_joined, solver.R
            a = np.where(geo.loadable, geo.advance, 0.0)
            g = np.where(geo.loadable, geo.gap, -np.inf)
            rev, fwd = solver.free_interval(solve=False)
            free = fwd > rev
            for c, part in enumerate((slice(0, R), slice(R, 2 * R))):
                b = solver.bearings[c]
                half = 0.5 * b.diametral_clearance if b is not None else 0.0
                e = self.design.eccentricity
                r, f = free_row(a[:, part], g[:, part], solver.n[:, part], half, e)
                free &= f > r
            out[sl] = free
        return out

    def at(self, mask: np.ndarray) -> DriveWindup:
        """The same drive at the positions ``mask`` (bool (P,)) selects."""
        x = self.output_angles[np.asarray(mask, dtype=bool)]
        return DriveWindup(self.design, x, **self._options)

    def _loaded_theta(self, output_torque: float) -> np.ndarray:
        return self._solve(output_torque)[0]

    def row_a_share(self, output_torque: float) -> np.ndarray:
        """Share of the moment row A carries at each position (P,); 0.5 at zero torque."""
        T = float(output_torque)
        if T == 0.0:
            return np.full(len(self.crank_angles), 0.5)
        return self._solve(T)[1]

    def forces(self, output_torque: float):
        """The :class:`~corr_cad.mechanics.drive.drive.DriveResult` at ``T`` (nonzero), all
        positions."""
        T = self._forces_torque(output_torque)
        _, _, pieces = self._solve(T)
        target = self.cam_moment(T)
        parts = [solver._build(target, *sol) for _, solver, sol in pieces]
        if len(parts) == 1:
            return parts[0]
        return _concatenate(parts)

    def peak_pressure(self, output_torque: float) -> np.ndarray:
        """Largest Hertz pressure of any contact, roller and row at each position, MPa (P,)."""
        res = self.forces(output_torque)
        peak = [
            np.max(np.maximum(np.maximum(r.p_cam, r.p_slot), r.p_gear), axis=1) for r in res.rows
        ]
        return np.maximum(*peak)


def _concatenate(parts):
    """Drive results of consecutive position blocks as one (the per-row results too)."""
    from dataclasses import replace

    from corr_cad.mechanics.row.windup import _concatenate as concat_rows

    first = parts[0]
    fields = {}
    for name in ("F_j", "F_n", "F_s", "bearing_load", "needle_load_max", "cam_displacement"):
        fields[name] = np.concatenate([getattr(p, name) for p in parts], axis=1)
    for name in ("crank_angles", "row_a_share", "cam_rotation"):
        fields[name] = np.concatenate([getattr(p, name) for p in parts])
    if first.needle_loads is not None:
        fields["needle_loads"] = tuple(
            np.concatenate([p.needle_loads[c] for p in parts]) for c in (0, 1)
        )
    rows = tuple(concat_rows([p.rows[i] for p in parts]) for i in (0, 1))
    return replace(
        first,
        **fields,
        rows=rows,
        success=all(p.success for p in parts),
        moment_residual=max(p.moment_residual for p in parts),
        iterations=max(p.iterations for p in parts),
    )
