"""The drive: both rows of rollers and both cams solved together (``[solver] model = "drive"``).

The paper's model (:mod:`corr_cad.mechanics.row.solver`) solves one row carrying
a fixed ``load_share`` of the crank moment. A CORR drive has two cams on one
crank, 180 degrees apart, each driving its own row of rollers in the same
slotted frame against its own ring. Here both rows are solved together.

Both rows together
------------------
At crank angle ``phi`` (relative to the frame, as in the one-row solver):

* cam A at ``phi``, row A in slots ``k`` at ``psi_k = phi - theta_k``;
* cam B at ``phi + pi + dphi`` (``dphi`` = ``cam_phase_error_deg``: cam B's
  eccentric leads cam A's by ``dphi`` in the sense of positive crank
  rotation); roller ``k`` of row B sits in the same slot ``k`` with
  ``psi_k + pi``; ring B is ring A turned by ``pi / z``, so row B's geometry
  is the one-row geometry at ``phi + pi``. The phase error enters row B's
  initial interference exactly as a rotation of its eccentric
  (:func:`corr_cad.mechanics.row.solver_geometry._error_gaps`); to first order it
  adds ``dphi a_k``, i.e. it pre-turns cam B by ``dphi``.
* one crank rotation ``tau`` shared by both cams, and the whole crank moment
  ``M0`` carried by both rows together:

      sum over both rows of a_k F_k = M0      (no load_share);

* each roller: the compliance of its three contacts in series, as in the
  one-row solver, with the overlap ``a_k tau + h_k + u_c . n_k``; ``n_k`` is the
  unit vector from the cam centre to the roller centre, ``u_c`` the
  displacement of its cam's centre on the eccentric bearing
  (:mod:`corr_cad.mechanics.crank.bearing`; zero without bearings: rigid cams), less
  the elastic ring's and frame's approach (``bodies``, :mod:`corr_cad.mechanics.bodies`);
* each cam with a bearing: ``sum_k F_k n_k = sum_j Q_j e_j`` (the needles
  carry the rollers' resultant). The row A share is ``sum_A a_k F_k / M0``.
  The roller forces pass through the cam centre: a cam's displacement moves no arm.

Numerics: rigid cams are the one-row problem with ``2 (z + 1)`` rollers
(the one-row solver's Newton-bisection on ``tau``). With bearings, a joint
Newton on ``(tau, u_A, u_B)`` per position, started from the rigid solution
with each cam displaced along its load by the Stribeck estimate, with a
backtracking line search on the scaled residual; the Jacobian is exact
(the potential energy of the contacts is convex, so it is symmetric and
positive semi-definite). Where that line search finds no decrease (both cams
adrift in their clearances: the slide of the crank against both cams is
free, the Jacobian singular along it), an exact line search on the energy
(:func:`~corr_cad.mechanics.drive.drive_numerics.energy_search`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.coupling import BodyTables, Influence, coupled_solve
from corr_cad.mechanics.drive.drive_crank import CrankSupport, solve_with_crank
from corr_cad.mechanics.drive.drive_numerics import (
    _forces_of,
    _invert_convex,
    cam_start,
    energy_step,
    expand_drive,
    free_row,
    joined,
    merge_state,
    moved_state,
    rest_idle_cams,
    roller_directions,
    row_errors,
)
from corr_cad.mechanics.row.solver import CONTACT_MODELS, ForceResult, _result
from corr_cad.mechanics.row.solver_geometry import RollerGeometry, cycle_angles, roller_geometry
from corr_cad.mechanics.row.solver_numerics import _RTOL, _solve_positions, make_compliance

__all__ = ["DriveResult", "row_errors", "drive_geometry", "solve_drive", "DriveSolver"]

#: At zero moment, rollers below this force (N) are touching, not loaded (round-off of
#: the rigid solve of rows that just touch): the cams then stay centred.
_IDLE_FORCE = 1e-9

#: Largest Newton step of the crank rotation (rad) and of a cam centre (mm) with bearings.
_MAX_TAU_STEP, _MAX_U_STEP = 1e-2, 1e-2

#: Relative residual of the moment and of each cam's force balance the bearing solve reaches.
DRIVE_RTOL = 1e-12


def drive_geometry(
    design: GearDesign,
    crank_angles: np.ndarray,
    errors_a: ManufacturingErrors,
    errors_b: ManufacturingErrors,
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
) -> tuple[RollerGeometry, RollerGeometry]:
    """Row A's and row B's geometry at crank angles (P,) (row B at ``phi + pi``)."""
    phi = np.asarray(crank_angles, dtype=float).reshape(-1)
    ga = roller_geometry(design, phi, errors_a, variants, psi_contact_limit)
    gb = roller_geometry(design, phi + np.pi, errors_b, variants, psi_contact_limit)
    return ga, gb


@dataclass
class DriveResult:
    """Both rows' forces over crank positions (arrays: row 0 = A, row 1 = B).

    ``F_j``, ``F_n``, ``F_s`` (2, P, R) N with the one-row solver's signs;
    ``row_a_share`` (P,); ``bearing_load`` (2, P) N: each cam's radial
    bearing load ``|sum_k F_k n_k|``; ``needle_load_max`` (2, P) N (NaN for
    rigid cams); ``needle_loads``: each cam's (P, Z) needle loads, N (None for
    rigid cams; needle ``j`` at the eccentric's direction ``+ 2 pi j / Z``); ``cam_displacement``
    (2, P, 2) mm in each eccentric's frame; ``cam_rotation`` (P,) rad: the
    crank rotation ``tau``; ``rows``: each row as a :class:`ForceResult`
    (row B's ``crank_angles`` and ``psi`` are its own, ``phi + pi``).
    """

    success: bool
    message: str
    iterations: int
    moment_residual: float
    crank_angles: np.ndarray
    F_j: np.ndarray
    F_n: np.ndarray
    F_s: np.ndarray
    row_a_share: np.ndarray
    bearing_load: np.ndarray
    needle_load_max: np.ndarray
    needle_loads: tuple[np.ndarray, np.ndarray] | None
    cam_displacement: np.ndarray
    cam_rotation: np.ndarray
    input_torque: float
    rows: tuple[ForceResult, ForceResult] = field(repr=False)
    bearings: tuple[EccentricBearing | None, EccentricBearing | None] = (None, None)
    #: The drive's free output rotation at no load (P,), rad (:func:`solve_drive` fills it).
    backlash: np.ndarray | None = None

    @property
    def force(self) -> np.ndarray:
        """The cam forces ``F_j`` (2, P, R), N."""
        return self.F_j

    @property
    def row(self) -> tuple[ForceResult, ForceResult]:
        """Alias of :attr:`rows`."""
        return self.rows


class DriveSolver:
    """Both rows at fixed crank angles; solve for any crank moment (geometry built once)."""

    def __init__(
        self,
        design: GearDesign,
        crank_angles: np.ndarray,
        *,
        errors: ManufacturingErrors | None = None,
        errors_b: ManufacturingErrors | None = None,
        bearing: EccentricBearing | None = None,
        bearing_b: EccentricBearing | None = None,
        contact_model: str = "nonlinear",
        variants: tuple[str, ...] = (),
        psi_contact_limit: float = math.pi,
        geometry: tuple[RollerGeometry, RollerGeometry] | None = None,
        rtol: float = _RTOL,
        crank: CrankSupport | None = None,
        bodies: BodyTables | None = None,
    ):
        if contact_model not in CONTACT_MODELS:
            raise SolverError(
                f"contact_model = {contact_model!r}: must be one of {', '.join(CONTACT_MODELS)}"
            )
        self.design = design
        self.crank_angles = np.asarray(crank_angles, dtype=float).reshape(-1)
        self.errors = row_errors(errors, errors_b)
        if geometry is None:
            geometry = drive_geometry(
                design, self.crank_angles, *self.errors, variants, psi_contact_limit
            )
        self.geo = geometry
        self.geo_joined = joined(*geometry)
        self.comp = make_compliance(self.geo_joined, design, contact_model)
        self.bearings = (bearing, bearing if bearing_b is None else bearing_b)
        if (bearing is None) != (self.bearings[1] is None):
            raise SolverError("eccentric bearings: give both cams a bearing or neither")
        self.rtol = rtol
        self.R = design.roller_count
        self.n = self._directions(geometry)
        self.crank = crank  # the crankshaft on its supports (None: the eccentrics fixed)
        # With a crank too, its fixed point (drive_crank) solves the bodies' at each iterate.
        self.bodies = bodies and Influence(bodies, design, self.crank_angles, geometry)

    def _directions(self, geometry) -> np.ndarray:  # both rows' n_k (P, 2R, 2)
        return np.concatenate([roller_directions(self.design, g) for g in geometry], axis=1)

    def solve(self, target: float):
        """``(tau, F (P, 2R), u (2, P, 2), Q list, rel, iterations)`` at crank moment ``target``
        (with a crankshaft, ``tau`` is the crank gear's rotation: :mod:`~.drive_crank`)."""
        if self.crank is not None:
            return solve_with_crank(self, target, self._solve_on_eccentrics)
        return self._solve_on_eccentrics(target)

    def _solve_on_eccentrics(self, target: float):
        """:meth:`solve` with the eccentrics where the geometry puts them."""
        if self.bodies is not None:
            # Within the crank's fixed point: from the bodies' approaches of its last iterate.
            return coupled_solve(
                self, target, self.bodies, start=getattr(self, "_bodies_start", None)
            )
        return self.solve_contacts(target)

    def solve_contacts(self, target: float):
        """:meth:`solve` with rigid bodies and the eccentrics where the geometry puts them."""
        geo, comp = self.geo_joined, self.comp
        tau, F, iterations, _, rel = _solve_positions(geo, comp, target, self.rtol)
        P = len(tau)
        u = np.zeros((2, P, 2))
        if self.bearings[0] is None:
            return tau, F, u, None, rel, iterations
        return self._with_bearings(target, tau, F, iterations)

    def _forces(self, h, F_prev, h_prev, k_prev):
        """Roller forces and ``dF/dh`` at overlaps ``h`` (P, 2R)."""
        comp = self.comp
        if getattr(comp, "explicit", False):
            return comp.force_and_stiffness(h)
        start = h / comp.slope0
        if F_prev is not None:
            pred = F_prev + (h - h_prev) * k_prev
            start = np.where(F_prev > 0, np.maximum(pred, 0.0), start)
        return _invert_convex(comp, h, start)

    def _with_bearings(self, target, tau, F, iterations, max_iter: int = 100):
        geo, R = self.geo_joined, self.R
        a_c = np.where(geo.loadable, geo.advance, 0.0)
        a_m = np.where(geo.loadable, geo.arm, 0.0)
        h0 = np.where(geo.loadable, geo.gap, -1e300)
        n = self.n
        P = len(tau)
        dirs = [b.directions() for b in self.bearings]
        rows = (slice(0, R), slice(R, 2 * R))
        # Start: each cam displaced along its load by the clearance and Stribeck's approach,
        # or where the caller's last solution put it (``_u_start``: the bodies' Newton).
        u = cam_start(self.bearings, F, n, R, getattr(self, "_u_start", None))
        # Fixed residual scales (zero moment with preload: the forces; on e too, as _scales).
        e = self.design.eccentricity
        scale_m = abs(target) + np.sum((np.abs(a_m) + e) * np.abs(F), axis=1) + 1e-300
        scale_f = (scale_m / self.design.eccentricity)[:, None]

        def state(tau, u, F_prev=None, h_prev=None, k_prev=None):
            uu = np.concatenate(
                [np.repeat(u[0][:, None, :], R, 1), np.repeat(u[1][:, None, :], R, 1)], 1
            )
            nu = np.sum(n * uu, axis=-1)
            h = a_c * tau[:, None] + h0 + nu
            Fx, kf = self._forces(h, F_prev, h_prev, k_prev)
            gf = np.where(
                h0 > -1e300, (np.abs(a_c * tau[:, None]) + np.abs(h0) + np.abs(nu)) * kf, 0.0
            )
            r = np.empty((P, 5))
            r[:, 0] = np.sum(a_m * Fx, axis=1) - target
            Qs, kqs = [], []
            gq = []
            for c, (b, sl) in enumerate(zip(self.bearings, rows, strict=True)):
                Q, kq = b.loads(u[c])
                r[:, 1 + 2 * c : 3 + 2 * c] = (
                    np.einsum("pk,pkx->px", Fx[:, sl], n[:, sl]) - Q @ dirs[c]
                )
                Qs.append(Q)
                kqs.append(kq)
                gq.append(kq * (np.linalg.norm(u[c], axis=1) + b.diametral_clearance)[:, None])
            return h, Fx, kf, Qs, kqs, r, (gf, gq)

        def merit(r):
            return (r[:, 0] / scale_m) ** 2 + np.sum((r[:, 1:] / scale_f) ** 2, axis=1)

        h, F, kf, Qs, kqs, r, gross = state(tau, u)
        # No moment and no preload (rows just touching): the cams stay centred, nothing to solve.
        idle = np.zeros(P, dtype=bool)
        if target == 0.0:
            idle = np.max(F, axis=1) <= _IDLE_FORCE
        it = 0
        for it in range(1, max_iter + 1):
            done = self._converged(r, F, a_m, Qs, target, gross) | idle
            if not np.all(done):
                rest = rest_idle_cams(
                    (~done, target, tau, u, F, kf, Qs, kqs, r, gross, a_m),
                    scale_f[:, 0] * DRIVE_RTOL,
                    state,
                    lambda *a: self._converged(*a),
                )
                if rest is not None:
                    settled, (u, F, kf, Qs, kqs, r, gross) = rest
                    done |= settled
            if np.all(done):
                break
            J = np.zeros((P, 5, 5))
            J[:, 0, 0] = np.sum(a_m * a_c * kf, axis=1)
            for c, sl in enumerate(rows):
                i = slice(1 + 2 * c, 3 + 2 * c)
                kn = kf[:, sl, None] * n[:, sl]
                J[:, 0, i] = np.sum(a_m[:, sl, None] * kn, axis=1)
                J[:, i, 0] = np.sum(a_c[:, sl, None] * kn, axis=1)
                kuu = np.einsum("pkx,pky->pxy", kn, n[:, sl])
                kuu += np.einsum("pj,jx,jy->pxy", kqs[c], dirs[c], dirs[c])
                tr = np.trace(kuu, axis1=1, axis2=2)
                kuu += (1e-12 * tr + 1e-9)[:, None, None] * np.eye(2)
                J[:, i, i] = kuu
            # The crank's floor, as the cams' (tau e is a displacement): a loaded roller at
            # zero arm at zero moment leaves tau free; unfloored, its pivot asks 1e12 rad.
            J[:, 0, 0] += e * e * (1e-12 * np.trace(J[:, 1:, 1:], axis1=1, axis2=2) + 1e-9)
            with np.errstate(invalid="ignore", over="ignore"):
                step = -np.linalg.solve(J, r[:, :, None])[:, :, 0]
            step = np.where(np.isfinite(step), step, 0.0)
            step[done] = 0.0
            # The fallback's direction: the whole step scaled by one factor (a descent
            # direction of the energy, which separate caps need not be).
            whole = np.maximum.reduce(
                [np.abs(step[:, 0]) / _MAX_TAU_STEP, np.ones(P)]
                + [
                    np.linalg.norm(step[:, i], axis=1) / _MAX_U_STEP
                    for i in (slice(1, 3), slice(3, 5))
                ]
            )
            d = step / whole[:, None]
            # No step beyond 0.01 rad of crank or 0.01 mm of a cam (far outside the small-
            # displacement model, where a near-singular Jacobian, needles in their clearance,
            # would throw it), each capped on its own: a crank in its free play asks a huge
            # rotation, which must not shrink the cams'.
            step[:, 0] /= np.maximum(np.abs(step[:, 0]) / _MAX_TAU_STEP, 1.0)
            for i in (slice(1, 3), slice(3, 5)):
                big = np.linalg.norm(step[:, i], axis=1) / _MAX_U_STEP
                step[:, i] /= np.maximum(big, 1.0)[:, None]
            m0 = merit(r)
            alpha = np.ones(P)
            ok = done.copy()
            for _ in range(50):
                t_tau, t_u = moved_state(tau, u, alpha, step)
                with np.errstate(all="ignore"):
                    trial = state(t_tau, t_u, F, h, kf)
                    ok = merit(trial[5]) <= (1.0 - 1e-4 * alpha) * m0
                if np.all(ok | done):
                    break
                alpha = np.where(ok | done, alpha, 0.5 * alpha)
            # A position whose step found no decrease of the merit takes the fallback: an
            # exact line search on the energy along d (drive_numerics.energy_search).
            stuck = ~ok & ~done
            tau, u, h, F, kf, Qs, kqs, r, gross = merge_state(
                ok & ~done, (tau, u, h, F, kf, Qs, kqs, r, gross), (t_tau, t_u) + trial
            )
            if np.any(stuck):
                x = (tau, u, h, F, kf, Qs, kqs, r, gross)
                tau, u, h, F, kf, Qs, kqs, r, gross = energy_step(stuck, d, x, state)
        done = self._converged(r, F, a_m, Qs, target, gross) | idle
        rel = np.where(idle, 0.0, self._relative(r, F, a_m, Qs, target, gross))
        if not np.all(done):
            rel = np.maximum(rel, np.where(done, 0.0, np.inf))
        return tau, F, u, Qs, rel, iterations + it

    @staticmethod
    def _scales(F, a_m, Qs, target, R, gross, e):
        """Scales of the residuals: the forces, and the forces the gross terms of each
        overlap (``|a tau| + |gap| + |n . u|``, which cancel to leave it) and of each needle's
        approach (``|u|``) would give, and each force on the eccentricity ``e`` (the arm
        ``-e s sin(psi) / L`` keeps ``e s / L`` times sin's round-off at zero arm): their
        round-off is all a residual can reach."""
        gf, gq = gross
        sm = abs(target) + np.sum((np.abs(a_m) + e) * np.abs(F) + np.abs(a_m) * gf, axis=1)
        sf = [
            np.sum(F[:, c * R : (c + 1) * R] + gf[:, c * R : (c + 1) * R], axis=1)
            + np.sum(Qs[c] + gq[c], axis=1)
            for c in (0, 1)
        ]
        # Both cams against the larger scale: an unloading cam nears u = 0 only linearly.
        return sm, [np.maximum(sf[0], sf[1])] * 2

    def _relative(self, r, F, a_m, Qs, target, gross):
        sm, sf = self._scales(F, a_m, Qs, target, self.R, gross, self.design.eccentricity)
        rel = np.abs(r[:, 0]) / (sm + 1e-300)
        for c in (0, 1):
            rel = np.maximum(
                rel, np.linalg.norm(r[:, 1 + 2 * c : 3 + 2 * c], axis=1) / (sf[c] + 1e-300)
            )
        return rel

    def _converged(self, r, F, a_m, Qs, target, gross):
        return self._relative(r, F, a_m, Qs, target, gross) <= DRIVE_RTOL

    def free_interval(self, solve: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The crank rotations ``(rev, fwd)`` (P,) each, rad, the drive turns freely between.

        The intersection of both rows' free intervals (the crank is one). A row
        without a bearing clearance closes a roller at ``tau = -g_k / a_k``
        (a cam on needles without clearance stays centred at no load). With a
        clearance ``Pd`` the cam may shift anywhere within ``Pd / 2``
        (:func:`free_row`). Where no free rotation is left (a preload) both ends
        are the equilibrium at zero moment (``solve=False``: left as found, ``rev >= fwd``).
        """
        R = self.R
        geo = self.geo_joined
        a = np.where(geo.loadable, geo.advance, 0.0)
        g = np.where(geo.loadable, geo.gap, -np.inf)
        e = self.design.eccentricity
        revs, fwds = [], []
        for c, sl in enumerate((slice(0, R), slice(R, 2 * R))):
            b = self.bearings[c]
            half = 0.5 * b.diametral_clearance if b is not None else 0.0
            rev, fwd, v0 = free_row(a[:, sl], g[:, sl], self.n[:, sl], half, e, True)
            locked = ~(fwd > rev)
            if half > 0 and np.any(locked):
                # A preloaded row holds its cam centre at v*, where its rollers' forces
                # balance; the crank turns freely while the eccentric stays within
                # Pd/2 of it: |v* - e tau x| <= Pd/2.
                idx = np.flatnonzero(locked)
                v = self._row_centre(c, idx, v0[idx])
                arc = np.sqrt(np.maximum(half * half - v[:, 1] ** 2, 0.0))
                reach = np.abs(v[:, 1]) <= half
                fwd[idx] = np.where(reach, (v[:, 0] + arc) / e, -np.inf)
                rev[idx] = np.where(reach, (v[:, 0] - arc) / e, np.inf)
            revs.append(rev)
            fwds.append(fwd)
        rev, fwd = np.maximum(*revs), np.minimum(*fwds)
        tight = ~(fwd > rev)
        if solve and np.any(tight):
            zero = self._checked(0.0)[0]
            fwd = np.where(tight, zero, fwd)
            rev = np.where(tight, zero, rev)
        return rev, fwd

    def _row_centre(self, c: int, idx: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Where row ``c``'s rollers hold its cam centre (``v``, (len(idx), 2)) at positions
        ``idx`` with no bearing load: ``sum_k F_k(g_k + n_k . v) n_k = 0``, by Newton with
        backtracking from ``v``, each position until it settles (``DRIVE_RTOL``)."""
        R, geo = self.R, self.geo_joined
        sl, v = slice(c * R, (c + 1) * R), np.array(v, dtype=float)

        def residual(at, u):  # the other row's rollers carry nothing: -1e300 of overlap
            h = np.full((len(at), 2 * R), -1e300)
            h[:, sl] = gap[at] + np.einsum("pkx,px->pk", n[at], u)
            F, k = _forces_of(comp.take(at), h)
            return np.einsum("pk,pkx->px", F[:, sl], n[at]), F[:, sl], k[:, sl]

        comp = self.comp.take(idx)
        gap = np.where(geo.loadable, geo.gap, -1e300)[idx][:, sl]
        n = self.n[idx][:, sl]
        going = np.arange(len(idx))  # the positions not yet settled
        r, F, k = residual(going, v)
        for _ in range(100):
            unsettled = np.linalg.norm(r, axis=1) > DRIVE_RTOL * (np.sum(F, axis=1) + 1e-300)
            if not np.any(unsettled):
                break
            going, r, k = going[unsettled], r[unsettled], k[unsettled]
            nn = n[going]
            J = np.einsum("pk,pkx,pky->pxy", k, nn, nn)
            J += (1e-12 * np.trace(J, axis1=1, axis2=2) + 1e-9)[:, None, None] * np.eye(2)
            step = -np.linalg.solve(J, r[:, :, None])[:, :, 0]
            alpha = np.ones(len(going))
            m0 = np.linalg.norm(r, axis=1)
            rt, Ft, kt = r.copy(), np.empty((len(going), R)), np.empty((len(going), R))
            look = np.arange(len(going))  # those still halving their step
            for _ in range(40):
                at = going[look]
                rl, Fl, kl = residual(at, v[at] + alpha[look, None] * step[look])
                rt[look], Ft[look], kt[look] = rl, Fl, kl
                ok = np.linalg.norm(rl, axis=1) <= (1.0 - 1e-4 * alpha[look]) * m0[look]
                if np.all(ok):
                    break
                look = look[~ok]
                alpha[look] *= 0.5
            v[going] += alpha[:, None] * step
            r, F, k = rt, Ft, kt
        return v

    def _checked(self, target: float):
        """:meth:`solve`, raising where equilibrium is not reached."""
        sol = self.solve(target)
        rel = sol[4]
        limit = max(self.rtol, 1e-9)
        if not np.all(rel <= limit):
            raise SolverError(
                f"drive at crank moment {target:g} N*mm: equilibrium not reached to {limit:g} "
                f"(worst relative residual {float(rel.max()):.3g})"
            )
        return sol

    def share(self, F: np.ndarray) -> np.ndarray:
        """Row A's share of the moment from both rows' cam forces (P, 2R); 0.5 where no moment."""
        a_m = np.where(self.geo_joined.loadable, self.geo_joined.arm, 0.0)
        mom_a = np.sum(a_m[:, : self.R] * F[:, : self.R], axis=1)
        mom = np.sum(a_m * F, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(mom != 0, mom_a / mom, 0.5)

    # ------------------------------------------------------------------ result

    def result(self, target: float) -> DriveResult:
        """The :class:`DriveResult` at crank moment ``target`` (N*mm)."""
        tau, F, u, Qs, rel, iterations = self.solve(target)
        return self._build(target, tau, F, u, Qs, rel, iterations)

    def _build(self, target, tau, F, u, Qs, rel, iterations) -> DriveResult:
        R, P = self.R, len(tau)
        ga, gb = self.geo
        angles = self.crank_angles
        parts = []
        for g, sl, ang in ((ga, slice(0, R), angles), (gb, slice(R, 2 * R), angles + np.pi)):
            parts.append(_result(self.design, g, F[:, sl], tau, rel, iterations, ang, target, P))
        share = self.share(F)
        push = np.stack(
            [
                np.linalg.norm(np.einsum("pk,pkx->px", F[:, sl], self.n[:, sl]), axis=1)
                for sl in (slice(0, R), slice(R, 2 * R))
            ]
        )
        if Qs is None:
            needle_max = np.full((2, P), np.nan)
            needles = None
        else:
            needle_max = np.stack([q.max(axis=1) for q in Qs])
            needles = (Qs[0], Qs[1])
        limit = max(self.rtol, 1e-9)
        worst = float(rel.max()) if rel.size else 0.0
        ok = bool(np.all(rel <= limit))
        return DriveResult(
            success=ok,
            message="converged"
            if ok
            else f"equilibrium not reached to {limit:g} (worst relative residual {worst:.3g})",
            iterations=int(iterations),
            moment_residual=worst,
            crank_angles=angles,
            F_j=np.stack([p.F_j for p in parts]),
            F_n=np.stack([p.F_n for p in parts]),
            F_s=np.stack([p.F_s for p in parts]),
            row_a_share=share,
            bearing_load=push,
            needle_load_max=needle_max,
            needle_loads=needles,
            cam_displacement=u,
            cam_rotation=tau,
            input_torque=float(target),
            rows=(parts[0], parts[1]),
            bearings=self.bearings,
        )


def solve_drive(
    design: GearDesign,
    input_torque: float,
    crank_angles: np.ndarray | None = None,
    *,
    positions: int = 3600,
    errors: ManufacturingErrors | None = None,
    errors_b: ManufacturingErrors | None = None,
    bearing: EccentricBearing | None = None,
    bearing_b: EccentricBearing | None = None,
    contact_model: str = "nonlinear",
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
    crank: CrankSupport | None = None,
    bodies: BodyTables | None = None,
) -> DriveResult:
    """Both rows' forces at each crank angle under the crank moment ``input_torque`` (N*mm).

    ``errors`` describes both rows unless ``errors_b`` is given (then row B);
    the slot errors are ``errors``'s, ``errors.cam_phase_error`` is cam B's
    phase against cam A. ``bearing`` floats both cams on needle bearings
    (``bearing_b`` overrides cam B's); without it the cams are fixed; ``bodies``: elastic.

    >>> import numpy as np
    >>> from corr_cad import GearDesign
    >>> from corr_cad.mechanics.drive.drive import solve_drive
    >>> res = solve_drive(GearDesign(), 1.1e5, np.radians([0.0, 5.0]))
    >>> np.round(res.row_a_share, 12)          # identical rows, z + 1 even: exactly half
    array([0.5, 0.5])
    """
    if type(v := input_torque) is bool or not isinstance(v, int | float) or not math.isfinite(v):
        raise SolverError(f"input_torque = {v!r}: must be a finite number")
    inverse = None
    if crank_angles is None:
        angles = cycle_angles(positions)
        ea, eb = row_errors(errors, errors_b)
        if not (ea.per_roller or eb.per_roller):
            # Each class of the 2 pi / (z + 1) periodicity solved once, as for one row.
            N, R = len(angles), design.roller_count
            cls = (np.arange(N) * R) % N
            _, first, inverse = np.unique(cls, return_index=True, return_inverse=True)
            inverse = inverse.reshape(-1)
            shift = ((np.arange(N) - first[inverse]) * R // N) % R
            full, angles = angles, angles[first]
    else:
        angles = np.asarray(crank_angles, dtype=float).reshape(-1)
        if angles.size == 0 or not np.all(np.isfinite(angles)):
            raise SolverError("crank_angles must be a non-empty array of finite angles (rad)")
    solver = DriveSolver(
        design,
        angles,
        errors=errors,
        errors_b=errors_b,
        bearing=bearing,
        bearing_b=bearing_b,
        contact_model=contact_model,
        variants=variants,
        psi_contact_limit=psi_contact_limit,
        crank=crank,
        bodies=bodies,
    )
    res = solver.result(float(input_torque))
    rev, fwd = solver.free_interval(solve=False)  # its width needs no solve: 0 where tight
    res.backlash = np.where(fwd > rev, fwd - rev, 0.0) / design.roller_count
    if inverse is not None:
        res = expand_drive(res, full, inverse, shift, design.slot_pitch_rad)
    return res
