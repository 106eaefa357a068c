"""Compiled rigid start of the drive under Palmgren's law, one position at a time.

:meth:`DriveSolver.solve_contacts <corr_cad.mechanics.drive.drive.DriveSolver>` solves
the rigid drive (cams fixed) first: the crank rotation ``tau`` at which the
rollers of both rows carry the crank moment, ``sum_k a_k F_k(a_k tau + g_k) =
M``, by :func:`corr_cad.mechanics.row.solver_numerics._nested` (numpy, every
position in step): the exact linear-contact ``tau`` (the secant compliance's
piecewise-linear moment, :func:`~corr_cad.mechanics.row.solver_numerics._linear_tau`),
a bracket widened by four times its step until the moment changes sign, then
Newton safeguarded by bisection until the moment's residual falls below
``rtol`` of its terms. Under Palmgren's law each roller's force is closed
form (``F = (h / K)^(1 / 0.9)``), so the start of the drive's bearing Newton
is this loop alone; here it runs compiled, position by position, with the
same steps and the same stops (a position stops when it has settled, as it
does in numpy once its ``tau`` no longer moves). The sums are taken in
another order than numpy's, so ``tau`` agrees with the numpy solve to
round-off (``tests/test_drive_rigid.py``), and the drive's solution, which
the bearing Newton takes to its own tolerance from there, to that tolerance.

:class:`ForcePassDriveSolver` is the drive Monte Carlo's force pass
(:func:`corr_cad.tolerance.montecarlo_drive.drive_chunk`): the compiled drive solver
with this start, the block's rollers' directions given (the nominal ones, tiled) and
the force metrics' arrays alone (:meth:`ForcePassDriveSolver.force_metrics_result`).
A block's solver is made from its parts (:meth:`ForcePassDriveSolver.on_block`),
keeps the kernels' inputs it makes once (:attr:`~ForcePassDriveSolver.block_arrays`,
:meth:`~ForcePassDriveSolver.kernel_geometry`) and finds the free interval on them
(:meth:`~ForcePassDriveSolver.free_interval`), the same bits as the compiled solver's.
The breakpoints' sort of the linear start begins at the last position's order (equal
breakpoints kept in roller order, so the order, and the sums, are unique), a few
moves a position instead of a few hundred.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from corr_cad.mechanics import contact
from corr_cad.mechanics.drive.drive import DRIVE_RTOL
from corr_cad.mechanics.drive.drive_centre import row_centres
from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver, loadable_arrays
from corr_cad.mechanics.drive.drive_numerics import row_errors
from corr_cad.mechanics.drive.free_play import free_rows
from corr_cad.mechanics.row.mc_kernel import _jit, _jit_inner
from corr_cad.mechanics.row.solver_numerics import _RTOL

__all__ = ["ForcePassDriveSolver", "rigid_palmgren"]

_EXP = 0.9  # palmgren.PALMGREN_FORCE_EXPONENT


@_jit_inner
def _moment(p, tau, a_c, a_m, h0, K, F):
    """Forces ``F`` (N,) at ``tau`` of position ``p``; ``(moment, dmoment/dtau, scale)``."""
    mom, dmom, scale = 0.0, 0.0, 0.0
    for i in range(a_c.shape[1]):
        h = tau * a_c[p, i] + h0[p, i]
        f = (h / K[p, i]) ** (1.0 / _EXP) if h > 0.0 else 0.0
        F[i] = f
        if f > 0.0:
            # G'(F) = 0.9 K F^-0.1 = 0.9 h / F (one power a roller, not two).
            dmom += a_m[p, i] * a_c[p, i] / (_EXP * h / f)
        mom += a_m[p, i] * f
        scale += abs(a_m[p, i] * f)
    return mom, dmom, scale


@_jit_inner
def _linear_tau(p, a_c, a_m, h0, k0, target, bp, order, key):
    """``solver_numerics._linear_tau`` of position ``p`` (``bp``, ``order``, ``key``: scratch;
    ``order`` the last position's order of the breakpoints, a start)."""
    N = a_c.shape[1]
    const, s_left, i_down = 0.0, 0.0, 0.0
    for i in range(N):
        a = a_c[p, i]
        if a != 0.0:
            bp[i] = -h0[p, i] / a
        else:
            bp[i] = np.inf
            if h0[p, i] > 0.0:
                const += a_m[p, i] * h0[p, i] / k0[p, i]
        if a < 0.0:
            s_left += a_m[p, i] * a / k0[p, i]
            i_down += a_m[p, i] * h0[p, i] / k0[p, i]
    i_left = i_down + const
    # The breakpoints' order, by insertion (a few dozen rollers; numba's argsort costs
    # seconds of compile time): by breakpoint, equal ones by roller (a stable sort's
    # order), from ``order`` as the last position left it (``order[0] < 0``: none), which
    # the next position's differs from in a few places only. The order is unique, so
    # whatever the start, the sums below run in the same order.
    if N > 0 and order[0] < 0:
        for j in range(N):
            order[j] = j
    for j in range(N):
        key[j] = bp[order[j]]
    for j in range(1, N):
        i, t = order[j], key[j]
        m = j - 1
        while m >= 0 and (key[m] > t or (key[m] == t and order[m] > i)):
            order[m + 1] = order[m]
            key[m + 1] = key[m]
            m -= 1
        order[m + 1] = i
        key[m + 1] = t
    # The sums of the "down" rollers after each breakpoint: totals less the running sums.
    sd_tot, id_tot = s_left, i_down
    su, iu, sd_cum, id_cum = 0.0, 0.0, 0.0, 0.0
    n_f = 0
    k, reached = 0, False
    seg_k_s, seg_k_i = 0.0, 0.0  # segment of breakpoint k - 1 (the one before the root)
    prev_s, prev_i = 0.0, 0.0
    last_s, last_i, last_t = 0.0, 0.0, 0.0
    for j in range(N):
        i = order[j]
        a = a_c[p, i]
        slope = a_m[p, i] * a / k0[p, i]
        icpt = a_m[p, i] * h0[p, i] / k0[p, i]
        if a > 0.0:
            su += slope
            iu += icpt
        elif a < 0.0:
            sd_cum += slope
            id_cum += icpt
        t = bp[i]
        if not math.isfinite(t):
            continue
        n_f += 1
        seg_s = su + (sd_tot - sd_cum)
        seg_i = iu + (id_tot - id_cum) + const
        if not reached and seg_s * t + seg_i >= target:
            reached, k = True, j
            seg_k_s, seg_k_i = prev_s, prev_i
        prev_s, prev_i = seg_s, seg_i
        last_s, last_i, last_t = seg_s, seg_i, t
    use_left = (reached and k == 0) or n_f == 0
    if use_left:
        s_seg, i_seg, t_seg = s_left, i_left, 0.0
    elif reached:
        s_seg, i_seg = seg_k_s, seg_k_i
        t_seg = bp[order[k - 1]]
    else:
        s_seg, i_seg, t_seg = last_s, last_i, last_t
    tau = (target - i_seg) / s_seg
    if not math.isfinite(tau):
        tau = t_seg
    return tau


@_jit_inner
def _walk(p, side, tau0, k, stepk, cut, xpos, xneg, target, a_c, a_m, h0, K, Ft):
    """The bracket's trials ``tau0 + side step0 4^k`` from trial ``k`` on (``stepk`` its step),
    as ``_nested`` tries them, each only where needed: ``(0, ...)`` at the first trial
    beyond ``cut`` (the bracket's end lies at or beyond it), ``(1, ..., end)`` at the end
    (the first trial whose moment reaches the target's other side), ``(-1, ...)`` none
    within 200 trials. A trial the known moments already place on the start side
    (at or before ``xneg`` going up, at or after ``xpos`` going down: the moment is
    monotone in the rotation) is passed without an evaluation."""
    while k < 200:
        t = tau0 + stepk if side > 0 else tau0 - stepk
        if (side > 0 and t > cut) or (side < 0 and t < cut):
            return 0, k, stepk, t
        if not ((side > 0 and t <= xneg) or (side < 0 and t >= xpos)):
            r = _moment(p, t, a_c, a_m, h0, K, Ft)[0] - target
            if (side > 0 and r >= 0) or (side < 0 and r <= 0):
                return 1, k, stepk, t
        k += 1
        stepk *= 4.0
    return -1, k, stepk, 0.0


@_jit
def _rigid(a_c, a_m, h0, K, k0, target, rtol, max_iter, tau_out, F_out):
    """Every position's rigid solve (``solver_numerics._nested`` under Palmgren's law);
    returns the iterations the slowest position took, -1 where a position has no
    bracket (no roller can carry the moment).

    The bracket's far end matters only where a Newton step would leave it or a
    bisection needs it: each step is first evaluated (as an accepted one is), and a
    step whose moment stays clearly on the start side (1e-9 of its terms) lies inside
    the bracket (the moment is monotone: the far end's is across the target); the
    trials are walked (:func:`_walk`) only as far as a step's decision needs them, so
    the steps, bisections and stops are ``_nested``'s with its bracket."""
    P, N = a_c.shape
    F, Ft, Fc = np.empty(N), np.empty(N), np.empty(N)  # at tau, at a trial, at a step
    bp, key, order = np.empty(N), np.empty(N), np.full(N, -1, dtype=np.int64)
    most = 0
    for p in range(P):
        tau = _linear_tau(p, a_c, a_m, h0, k0, target, bp, order, key)
        mom, dmom, scale = _moment(p, tau, a_c, a_m, h0, K, F)
        res = mom - target
        if math.isnan(res):
            return -1
        lo = tau if res <= 0 else -np.inf
        hi = tau if res >= 0 else np.inf
        side = 1 if not math.isfinite(hi) else (-1 if not math.isfinite(lo) else 0)
        found = side == 0  # the bracket's far end known (or replaced by an iterate)
        amax, gmax, mono = 0.0, 0.0, True
        for i in range(N):
            amax = max(amax, abs(a_c[p, i]))
            gmax = max(gmax, abs(h0[p, i]))
            mono = mono and a_c[p, i] * a_m[p, i] >= 0.0  # each roller's moment monotone
        # Where the moment is not monotone, no evaluation places a trial: all are walked.
        big = 1e-9 if mono else np.inf
        gap_scale = gmax / max(amax, 1e-300)
        tau0, k = tau, 0
        stepk = max(max(1e-3 * abs(tau), 1e-3 * gap_scale), 1e-15)
        xpos, xneg = np.inf, -np.inf  # evaluated points clearly above / below the target
        it = 0
        for it in range(1, max_iter + 1):
            res = mom - target
            margin = big * (abs(target) + scale)
            if res > margin:
                xpos = min(xpos, tau)
            if res < -margin:
                xneg = max(xneg, tau)
            if abs(res) <= rtol * (abs(target) + scale) + 1e-300:
                break
            if res < 0:
                lo = tau
                found = found or side < 0
            if res > 0:
                hi = tau
                found = found or side > 0
            newton = tau - res / dmom
            ok, tried = False, False
            if found:
                ok = dmom > 0 and newton > lo and newton < hi
            else:  # the far end: how far out a step's decision or a bisection needs it
                cut = side * np.inf
                if dmom > 0 and ((side < 0 and newton < hi) or (side > 0 and newton > lo)):
                    momc, dmomc, scalec = _moment(p, newton, a_c, a_m, h0, K, Fc)
                    tried, cut = True, newton
                    resc = momc - target
                    if side < 0 and resc > big * (abs(target) + scalec):
                        xpos = min(xpos, newton)
                    if side > 0 and resc < -big * (abs(target) + scalec):
                        xneg = max(xneg, newton)
                status, k, stepk, end = _walk(
                    p, side, tau0, k, stepk, cut, xpos, xneg, target, a_c, a_m, h0, K, Ft
                )
                if status < 0:
                    return -1
                if status == 0:  # a trial short of the far end lies beyond the step
                    ok = True
                else:
                    found = True
                    if side < 0:
                        lo = end
                    else:
                        hi = end
                    ok = tried and newton > lo and newton < hi
            tau_new = newton if ok else 0.5 * (lo + hi)
            if tau_new == tau:
                break
            if ok and tried:
                mom, dmom, scale = momc, dmomc, scalec
                for i in range(N):
                    F[i] = Fc[i]
            else:
                mom, dmom, scale = _moment(p, tau_new, a_c, a_m, h0, K, F)
            tau = tau_new
        if not found and abs(mom - target) > rtol * (abs(target) + scale) + 1e-300:
            return -1  # unsettled with the far end unknown: the numpy solver decides
        most = max(most, it)
        tau_out[p] = tau
        for i in range(N):
            F_out[p, i] = F[i]
    return most


def rigid_palmgren(geo, comp, target: float, rtol: float, arrays=None):
    """``(tau, F, iterations)`` of the rigid drive under Palmgren's law (``comp``: a
    :class:`~corr_cad.mechanics.palmgren.PalmgrenCompliance`), as
    ``solver_numerics._solve_positions`` gives them; None where a position has no
    bracket (that solver raises the error). ``arrays``: :func:`loadable_arrays` of
    ``geo`` where the caller has them."""
    P, N = geo.gap.shape
    a_c, a_m, h0 = loadable_arrays(geo) if arrays is None else arrays
    K = np.ascontiguousarray(np.broadcast_to(comp.K, (P, N)), dtype=float)
    k0 = np.ascontiguousarray(np.broadcast_to(comp.slope0, (P, N)), dtype=float)
    tau, F = np.empty(P), np.empty((P, N))
    it = _rigid(a_c, a_m, h0, K, k0, float(target), float(rtol), 200, tau, F)
    return None if it < 0 else (tau, F, int(it))


class ForcePassDriveSolver(CompiledDriveSolver):
    """:class:`CompiledDriveSolver` whose rigid start is compiled too under Palmgren's law
    (:func:`corr_cad.mechanics.drive.drive_rigid.rigid_palmgren`): the Monte Carlo's force pass.
    The rigid start agrees with the numpy one to round-off, not bit for bit; the Monte
    Carlo's datasheet pass starts its largest torques from it too
    (:mod:`corr_cad.tolerance.mc_drive_datasheet`).

    ``directions``: the rollers' ``n_k`` (P, 2R, 2) when the caller has them (the samples
    of a block share the nominal ones: the same bits as computed from the stacked rows)."""

    def __init__(self, *args, directions: np.ndarray | None = None, **kwargs):
        self._given_directions = directions
        self._arrays = None
        self._rows = None
        self._template = None
        super().__init__(*args, **kwargs)
        self._of = (self.geo_joined, self.n)

    @classmethod
    def on_block(
        cls, design, crank_angles, geometry, comp, bearings, directions, rows=None, template=None
    ):
        """The solver of a Monte Carlo block from its parts, as the constructor would make
        them (the same attributes, the same bits) without building what a block shares
        again: ``geometry`` both rows joined (P, 2R) (``drive_numerics.joined``), ``comp``
        its compliance, ``directions`` (P, 2R, 2); ``rows``: each row's ``(n, K)``
        contiguous (P, R, 2) and (P, R) where the caller keeps them; ``template``: the
        bearing Newton's geometry (5, P, 2R) (:meth:`kernel_geometry`) but the gaps,
        where the caller keeps it (read, never written). The eccentrics fixed, the bodies
        rigid, the default tolerance."""
        self = cls.__new__(cls)
        self._given_directions = directions
        self._arrays, self._rows, self._template = None, rows, template
        self.design = design
        self.crank_angles = crank_angles
        self.errors = row_errors(None, None)
        self.geo = None  # the rows apart: only DriveSolver.result reads them
        self.geo_joined = geometry
        self.comp = comp
        self.bearings = tuple(bearings)
        self.rtol = _RTOL
        self.R = design.roller_count
        self.n = directions
        self.crank = None
        self.bodies = None
        self._of = (geometry, directions)
        return self

    def _own_parts(self) -> bool:
        """Whether the solver still holds the geometry and directions it was made with, which
        its kept arrays are of: the elastic bodies' coupling and the restarts swap in other
        positions' (or a subset's), whose arrays are then made afresh and not kept."""
        return self._of[0] is self.geo_joined and self._of[1] is self.n

    @property
    def block_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`~corr_cad.mechanics.drive.drive_kernel.loadable_arrays` of the joined
        geometry, made once for the rigid start, the bearing Newton and the free interval."""
        if not self._own_parts():
            return loadable_arrays(self.geo_joined)
        if self._arrays is None:
            t, geo = self._template, self.geo_joined
            if t is None:
                self._arrays = loadable_arrays(geo)
            else:  # the advance and arm are the template's (the nominal's, tiled)
                self._arrays = (t[0], t[1], np.where(geo.loadable, geo.gap, -1e300))
        return self._arrays

    def kernel_geometry(self) -> np.ndarray:
        """The bearing Newton's geometry (5, P, 2R): advance, arm, gap (as
        :func:`~corr_cad.mechanics.drive.drive_kernel.loadable_arrays`), ``n_x``, ``n_y``."""
        a_c, a_m, h0 = self.block_arrays
        if self._template is None or not self._own_parts():
            return np.ascontiguousarray(np.stack([a_c, a_m, h0, self.n[..., 0], self.n[..., 1]]))
        g = self._template.copy()
        g[2] = h0
        return g

    def _row_arrays(self, c: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``c``'s directions (P, R, 2) and Palmgren factors (P, R), contiguous."""
        rows = self._rows if self._own_parts() else None
        if rows is None:
            P, N = self.geo_joined.gap.shape
            K = np.broadcast_to(self.comp.K, (P, N))
            rows = [
                (np.ascontiguousarray(self.n[:, sl]), np.ascontiguousarray(K[:, sl], dtype=float))
                for sl in (slice(0, self.R), slice(self.R, 2 * self.R))
            ]
            if self._own_parts():
                self._rows = rows
        return rows[c]

    def free_interval(self, solve: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`DriveSolver.free_interval` (the same steps, the same bits) on the arrays the
        solver keeps, under Palmgren's law with a clearance on both cams; else the
        compiled solver's own."""
        bearings = self.bearings
        if (
            solve
            or not getattr(self.comp, "explicit", False)
            or any(b is None or not b.diametral_clearance > 0.0 for b in bearings)
        ):
            return super().free_interval(solve)
        R, geo, e = self.R, self.geo_joined, self.design.eccentricity
        h0 = self.block_arrays[2]
        revs, fwds = [], []
        for c, sl in enumerate((slice(0, R), slice(R, 2 * R))):
            half = 0.5 * bearings[c].diametral_clearance
            n_row, K_row = self._row_arrays(c)
            g = np.where(geo.loadable[:, sl], geo.gap[:, sl], -np.inf)
            rev, fwd, v0 = free_rows(g, n_row, half, e, True)
            locked = ~(fwd > rev)
            if np.any(locked):  # as DriveSolver.free_interval: the cam's own centre
                idx = np.flatnonzero(locked)
                rows = (h0[:, sl], n_row, K_row)
                v = row_centres(self, c, idx, v0[idx], DRIVE_RTOL, None, rows)
                arc = np.sqrt(np.maximum(half * half - v[:, 1] ** 2, 0.0))
                reach = np.abs(v[:, 1]) <= half
                fwd[idx] = np.where(reach, (v[:, 0] + arc) / e, -np.inf)
                rev[idx] = np.where(reach, (v[:, 0] - arc) / e, np.inf)
            revs.append(rev)
            fwds.append(fwd)
        return np.maximum(*revs), np.minimum(*fwds)

    def _directions(self, geometry):
        if self._given_directions is not None:
            return self._given_directions
        return super()._directions(geometry)

    def solve_contacts(self, target: float):
        """:meth:`DriveSolver.solve_contacts` with the rigid start compiled under Palmgren's
        law (:func:`corr_cad.mechanics.drive.drive_rigid.rigid_palmgren`)."""
        if not getattr(self.comp, "explicit", False):
            return super().solve_contacts(target)
        rigid = rigid_palmgren(self.geo_joined, self.comp, target, self.rtol, self.block_arrays)
        if rigid is None:  # no bracket somewhere: the numpy solver says where
            return super().solve_contacts(target)
        tau, F, iterations = rigid
        if self.bearings[0] is not None:
            return self._with_bearings(target, tau, F, iterations)
        geo = self.geo_joined
        a_c = np.where(geo.loadable, geo.advance, 0.0)
        a_m = np.where(geo.loadable, geo.arm, 0.0)
        # The residual's scale as solver_numerics._solve_positions takes it.
        gross = np.where(geo.loadable, np.abs(tau[:, None] * a_c) + np.abs(geo.gap), 0.0)
        scale = np.sum(np.abs(a_m) * (np.abs(F) + gross / self.comp.slope0), axis=1)
        rel = np.abs(np.sum(a_m * F, axis=1) - target) / (abs(target) + scale + 1e-300)
        return tau, F, np.zeros((2, len(tau), 2)), None, rel, iterations

    def force_metrics_result(self, target: float) -> SimpleNamespace:
        """What the Monte Carlo's force metrics read of :meth:`result`, and only that:
        ``success``, ``F_n`` (2, P, R) and ``rows`` (each row's ``F_j``, ``p_cam``,
        ``p_slot``, ``p_gear``), the same arrays bit for bit (the same elementwise
        expressions, on both rows at once; the contacts' half-width factors the
        compliance's own), without the rest of the result (shear forces, validity,
        bearing loads, the share)."""
        tau, F, u, Qs, rel, it = self.solve(target)
        geo, comp, R = self.geo_joined, self.comp, self.R
        length = self.design.roller_length
        Fn = geo.rho_n * F
        p_cam = contact.max_pressure(F, comp.cj, length)
        p_slot = contact.max_pressure(np.abs(geo.rho_s * F), comp.cs, length)
        p_gear = contact.max_pressure(Fn, comp.cn, length)
        rows = tuple(
            SimpleNamespace(
                F_j=F[:, sl], p_cam=p_cam[:, sl], p_slot=p_slot[:, sl], p_gear=p_gear[:, sl]
            )
            for sl in (slice(0, R), slice(R, 2 * R))
        )
        ok = bool(np.all(rel <= max(self.rtol, 1e-9)))
        return SimpleNamespace(success=ok, F_n=np.stack([Fn[:, :R], Fn[:, R:]]), rows=rows)
