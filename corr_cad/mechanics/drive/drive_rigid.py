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
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from corr_cad.mechanics import contact
from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver
from corr_cad.mechanics.row.mc_kernel import _jit, _jit_inner

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
def _linear_tau(p, a_c, a_m, h0, k0, target, bp, order):
    """``solver_numerics._linear_tau`` of position ``p`` (``bp``, ``order``: scratch)."""
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
    # seconds of compile time).
    for j in range(N):
        order[j] = j
    for j in range(1, N):
        i, t = order[j], bp[order[j]]
        m = j - 1
        while m >= 0 and bp[order[m]] > t:
            order[m + 1] = order[m]
            m -= 1
        order[m + 1] = i
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
    bp, order = np.empty(N), np.empty(N, dtype=np.int64)
    most = 0
    for p in range(P):
        tau = _linear_tau(p, a_c, a_m, h0, k0, target, bp, order)
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


def rigid_palmgren(geo, comp, target: float, rtol: float):
    """``(tau, F, iterations)`` of the rigid drive under Palmgren's law (``comp``: a
    :class:`~corr_cad.mechanics.palmgren.PalmgrenCompliance`), as
    ``solver_numerics._solve_positions`` gives them; None where a position has no
    bracket (that solver raises the error)."""
    P, N = geo.gap.shape
    a_c = np.ascontiguousarray(np.where(geo.loadable, geo.advance, 0.0))
    a_m = np.ascontiguousarray(np.where(geo.loadable, geo.arm, 0.0))
    h0 = np.ascontiguousarray(np.where(geo.loadable, geo.gap, -1e300))
    K = np.ascontiguousarray(np.broadcast_to(comp.K, (P, N)), dtype=float)
    k0 = np.ascontiguousarray(np.broadcast_to(comp.slope0, (P, N)), dtype=float)
    tau, F = np.empty(P), np.empty((P, N))
    it = _rigid(a_c, a_m, h0, K, k0, float(target), float(rtol), 200, tau, F)
    return None if it < 0 else (tau, F, int(it))


class ForcePassDriveSolver(CompiledDriveSolver):
    """:class:`CompiledDriveSolver` whose rigid start is compiled too under Palmgren's law
    (:func:`corr_cad.mechanics.drive.drive_rigid.rigid_palmgren`): the Monte Carlo's force pass.
    The rigid start agrees with the numpy one to round-off, not bit for bit; the datasheet
    pass keeps the numpy start, whose zero-moment preload of a nominal drive is round-off
    itself (a pressure of 1e-118 MPa that the summary prints to 12 digits).

    ``directions``: the rollers' ``n_k`` (P, 2R, 2) when the caller has them (the samples
    of a block share the nominal ones: the same bits as computed from the stacked rows)."""

    def __init__(self, *args, directions: np.ndarray | None = None, **kwargs):
        self._given_directions = directions
        super().__init__(*args, **kwargs)

    def _directions(self, geometry):
        if self._given_directions is not None:
            return self._given_directions
        return super()._directions(geometry)

    def solve_contacts(self, target: float):
        """:meth:`DriveSolver.solve_contacts` with the rigid start compiled under Palmgren's
        law (:func:`corr_cad.mechanics.drive.drive_rigid.rigid_palmgren`)."""
        if not getattr(self.comp, "explicit", False):
            return super().solve_contacts(target)
        rigid = rigid_palmgren(self.geo_joined, self.comp, target, self.rtol)
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
