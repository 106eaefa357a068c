"""Numerics of the force solve: contact compliance, linear start, joint Newton, nested solver.

Split out of :mod:`corr_cad.mechanics.row.solver` (the model and the numerics are described
there); the names are re-exported from it. Monte Carlo (``BatchSolver``) runs
through these functions: their arithmetic is pinned bit for bit by
``tests/test_montecarlo_golden.py``.
"""

from __future__ import annotations

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics import contact
from corr_cad.mechanics.palmgren import PalmgrenCompliance
from corr_cad.mechanics.row.solver_geometry import RollerGeometry

_RTOL = 1e-13


class _Contact:
    """One contact of every roller, with weight ``w`` (force = w F_j).

    The knee of the validity continuation is located once; Newton then
    calls :func:`contact.approach_and_slope` with it (the continuation
    itself is evaluated only where a force passes the knee).
    """

    def __init__(self, w, c, k1, k2):
        self.w = w  # None: unit weight
        self.cw = c if w is None else c * w  # b^2 per unit F_j
        self.wcw = self.cw if w is None else w * self.cw
        self.k1 = k1
        self.k2 = k2
        self.uk = contact.knee_point(k1, k2)

    def take(self, sel):
        out = object.__new__(_Contact)
        out.w = None if self.w is None else self.w[sel]
        out.cw, out.wcw, out.k1, out.uk = (
            x if np.ndim(x) == 0 else x[sel] for x in (self.cw, self.wcw, self.k1, self.uk)
        )
        out.k2 = self.k2 if np.ndim(self.k2) == 0 else self.k2[sel]
        return out

    def value_and_slope(self, F):
        knee = (self.uk, None, None)
        val, slope = contact.approach_and_slope(self.cw * F, self.k1, self.k2, knee)
        if self.w is None:
            return val, self.wcw * slope
        return self.w * val, self.wcw * slope


class _Compliance:
    """``G(F) = delta_j(F) + rho_n delta_n(rho_n F) + |rho_s| delta_s(|rho_s| F)``."""

    def __init__(self, geo: RollerGeometry, design: GearDesign, model: str):
        length = design.roller_length
        modulus = design.material.contact_modulus
        self.linear = model == "linear"
        wn = geo.rho_n
        ws = np.abs(geo.rho_s)
        k1 = geo.k_roller
        one = np.ones_like(wn)
        self.cj = contact.half_width_sq_per_force(k1, geo.k_cam, length, modulus)
        self.cn = contact.half_width_sq_per_force(k1, geo.k_gear, length, modulus)
        self.cs = contact.half_width_sq_per_force(k1, 0.0, length, modulus)
        lam = contact.linear_compliance(length, modulus)
        #: G'(0), the linear-contact slope; G(F) >= slope0 F (convexity).
        self.slope0 = lam * (1.0 + wn**2 + ws**2)
        if not self.linear:
            self.contacts = [
                _Contact(None, self.cj, k1, geo.k_cam * one),
                _Contact(wn, self.cn, k1, geo.k_gear),
                _Contact(ws, self.cs, k1, 0.0),
            ]

    def take(self, rows: np.ndarray) -> _Compliance:
        """The compliance of a subset of positions."""
        sub = _Compliance.__new__(_Compliance)
        sub.linear = self.linear
        sub.slope0 = self.slope0[rows]
        if not self.linear:
            sub.contacts = [c.take(rows) for c in self.contacts]
        return sub

    def value_and_slope(self, F: np.ndarray, sel=None):
        if self.linear:
            k = self.slope0 if sel is None else self.slope0[sel]
            return k * F, k
        g = dg = 0.0
        for c in self.contacts:
            cc = c if sel is None else c.take(sel)
            v, d = cc.value_and_slope(F)
            g = g + v
            dg = dg + d
        return g, dg

    def invert(self, h: np.ndarray, start: np.ndarray, sel=None) -> tuple[np.ndarray, np.ndarray]:
        """Solve ``G(F) = h`` for ``h > 0`` (0 elsewhere); returns ``(F, G'(F))``.

        Newton converges monotonically from any start: ``G`` is convex and
        increasing with ``G'(F) >= G'(0) > 0``.
        """
        pos = h > 0
        k0 = self.slope0 if sel is None else self.slope0[sel]
        if self.linear:
            return np.where(pos, h / k0, 0.0), k0 + 0.0 * h
        F = np.where(pos, start, 0.0)
        for _ in range(100):
            g, dg = self.value_and_slope(F, sel)
            step = np.where(pos, (g - h) / dg, 0.0)
            F_new = np.maximum(F - step, 0.0)
            if np.all(np.abs(F_new - F) <= 4e-16 * F):
                F = F_new
                break
            F = F_new
        _, dg = self.value_and_slope(F, sel)
        return np.where(pos, F, 0.0), dg


def make_compliance(geo: RollerGeometry, design: GearDesign, model: str):
    """The rollers' compliance for a contact model: the paper's law
    (``"nonlinear"``, ``"linear"``) or Palmgren's (``"palmgren"``,
    :mod:`corr_cad.mechanics.palmgren`)."""
    if model == "palmgren":
        return PalmgrenCompliance(geo, design)
    return _Compliance(geo, design, model)


def _linear_tau(a_c, a_m, h0, k0, target):
    """Exact ``tau`` for the linear-contact model: the moment is piecewise linear.

    Per position, ``M(tau) = sum a_m max(tau a_c + h0, 0) / k0`` is continuous
    and non-decreasing with a kink at each roller's breakpoint
    ``-h0 / a_c``. Sorting the breakpoints and accumulating each roller's
    slope and intercept gives ``M`` at every breakpoint in O(R log R); the
    root is interpolated in the segment that holds ``target``.
    """
    P, R = a_c.shape
    ar = np.arange(P)[:, None]
    slope = a_m * a_c / k0
    icpt = a_m * h0 / k0
    up = a_c > 0
    down = a_c < 0
    const = np.sum(np.where(~up & ~down & (h0 > 0), icpt, 0.0), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        bp = np.where(up | down, -h0 / a_c, np.inf)
    order = np.argsort(bp, axis=1)
    bp_s = bp[ar, order]
    su = np.where(up, slope, 0.0)[ar, order].cumsum(axis=1)
    iu = np.where(up, icpt, 0.0)[ar, order].cumsum(axis=1)
    sd = np.where(down, slope, 0.0)[ar, order]
    idn = np.where(down, icpt, 0.0)[ar, order]
    sd_after = sd.sum(axis=1, keepdims=True) - sd.cumsum(axis=1)
    id_after = idn.sum(axis=1, keepdims=True) - idn.cumsum(axis=1)
    finite = np.isfinite(bp_s)
    tb = np.where(finite, bp_s, 0.0)
    # Segment k is (bp_k, bp_{k+1}); slope/intercept valid on it.
    seg_s = su + sd_after
    seg_i = iu + id_after + const[:, None]
    M_at = np.where(finite, seg_s * tb + seg_i, np.inf)
    # Left of the first breakpoint: only "down" rollers (all of them) act.
    s_left = np.sum(np.where(down, slope, 0.0), axis=1)
    i_left = np.sum(np.where(down, icpt, 0.0), axis=1) + const
    k = np.argmax(M_at >= target, axis=1)  # first breakpoint reaching the target
    reached = M_at[np.arange(P), k] >= target
    # Segment holding the root: (bp_{k-1}, bp_k), or left of bp_0 when k = 0,
    # or right of the last finite breakpoint when never reached.
    n_f = finite.sum(axis=1)
    last = np.maximum(n_f - 1, 0)
    kk = np.where(reached, k - 1, last)
    use_left = reached & (k == 0) | (n_f == 0)
    kk = np.maximum(kk, 0)
    s_seg = np.where(use_left, s_left, seg_s[np.arange(P), kk])
    i_seg = np.where(use_left, i_left, seg_i[np.arange(P), kk])
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = (target - i_seg) / s_seg
    # Flat segment exactly at the target: any tau in it solves; take its start.
    flat = ~np.isfinite(tau)
    tau = np.where(flat, np.where(use_left, 0.0, tb[np.arange(P), kk]), tau)
    return tau


def _newton(a_c, a_m, h0, comp: _Compliance, target, tau, max_iter=30, rtol=_RTOL):
    """Joint Newton on (tau, F) per position, from the linear-contact solution.

    Works only on the positions not yet converged. Returns
    ``tau, F, iterations, converged (P,)``.
    """
    P = len(tau)
    tau = tau.copy()
    h = tau[:, None] * a_c + h0
    F = np.where(h > 0, h / comp.slope0, 0.0)
    converged = np.zeros(P, dtype=bool)
    todo = np.arange(P)
    it = 0
    for it in range(1, max_iter + 1):
        ac, am, hz = a_c[todo], a_m[todo], h0[todo]
        sub = comp.take(todo) if len(todo) < P else comp
        t, f = tau[todo], F[todo]
        h = t[:, None] * ac + hz
        active = h > 0
        f = np.where(active, np.where(f > 0, f, h / sub.slope0), 0.0)
        g, dg = sub.value_and_slope(f)
        r = np.where(active, g - h, 0.0)
        r_m = np.sum(am * f, axis=1) - target
        inv = np.where(active, 1.0 / dg, 0.0)
        den = np.sum(am * ac * inv, axis=1)
        scale_m = np.sum(np.abs(am * f), axis=1)
        scale_h = np.max(np.where(active, h, 0.0), axis=1)
        done = (np.abs(r_m) <= rtol * (abs(target) + scale_m) + 1e-300) & np.all(
            np.abs(r) <= rtol * scale_h[:, None] + 1e-300, axis=1
        )
        with np.errstate(divide="ignore", invalid="ignore"):
            dtau = np.where(den > 0, (np.sum(am * r * inv, axis=1) - r_m) / den, 0.0)
        df = np.where(active, (ac * dtau[:, None] - r) * inv, 0.0)
        F[todo] = np.where(done[:, None], f, np.maximum(f + df, 0.0))
        tau[todo] = np.where(done, t, t + dtau)
        converged[todo[done]] = True
        todo = todo[~done]
        if todo.size == 0:
            break
    return tau, F, it, converged


def _nested(geo_a_c, a_m, h0, comp: _Compliance, target, max_iter: int = 200, rtol=_RTOL):
    """Robust path: safeguarded Newton-bisection on ``tau``, exact inner inversion."""
    a_c = geo_a_c
    P = a_c.shape[0]

    def evaluate(tau: np.ndarray, F_prev=None, h_prev=None, dg_prev=None):
        h = tau[:, None] * a_c + h0
        start = h / comp.slope0
        if F_prev is not None:
            # Tangent predictor: to the right of the root because G is convex.
            pred = F_prev + (h - h_prev) / dg_prev
            start = np.where(F_prev > 0, np.maximum(pred, 0.0), start)
        F, dg = comp.invert(h, start)
        moment = np.sum(a_m * F, axis=1)
        dmom = np.sum(np.where(F > 0, a_m * a_c / dg, 0.0), axis=1)
        scale = np.sum(np.abs(a_m * F), axis=1)
        return F, h, dg, moment, dmom, scale

    tau = _linear_tau(a_c, a_m, h0, comp.slope0, target)
    F, h, dg, mom, dmom, scale = evaluate(tau)
    res = mom - target
    lo = np.where(res <= 0, tau, -np.inf)
    hi = np.where(res >= 0, tau, np.inf)
    amax = np.maximum(np.max(np.abs(a_c), axis=1), 1e-300)
    gap_scale = np.max(np.abs(h0), axis=1) / amax
    step = np.maximum(np.maximum(1e-3 * np.abs(tau), 1e-3 * gap_scale), 1e-15)
    for _ in range(200):
        need_hi = ~np.isfinite(hi)
        need_lo = ~np.isfinite(lo)
        if not (np.any(need_hi) or np.any(need_lo)):
            break
        trial = np.where(need_hi, tau + step, np.where(need_lo, tau - step, tau))
        _, _, _, momt, _, _ = evaluate(trial)
        r_t = momt - target
        hi = np.where(need_hi & (r_t >= 0), trial, hi)
        lo = np.where(need_hi & (r_t < 0), trial, lo)
        lo = np.where(need_lo & (r_t <= 0), trial, lo)
        hi = np.where(need_lo & (r_t > 0), trial, hi)
        step = np.where(need_hi | need_lo, 4.0 * step, step)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        bad = np.flatnonzero(~(np.isfinite(lo) & np.isfinite(hi)))
        raise SolverError(
            f"no roller can carry the moment {target:g} N*mm at {len(bad)} of {P} positions "
            "(all loadable rollers face the wrong way or are masked)"
        )
    it = 0
    for it in range(1, max_iter + 1):
        res = mom - target
        tol = rtol * (abs(target) + scale) + 1e-300
        done = np.abs(res) <= tol
        if np.all(done):
            break
        lo = np.where(res < 0, tau, lo)
        hi = np.where(res > 0, tau, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = tau - res / dmom
        ok = (dmom > 0) & (newton > lo) & (newton < hi)
        tau_new = np.where(done, tau, np.where(ok, newton, 0.5 * (lo + hi)))
        if np.array_equal(tau_new, tau):
            break
        F, h, dg, mom, dmom, scale = evaluate(tau_new, F, h, dg)
        tau = tau_new
    return tau, F, it


def _solve_positions(geo: RollerGeometry, comp: _Compliance, target: float, rtol: float = _RTOL):
    """``tau`` and ``F_j`` per position so that ``sum a_m F_j = target``.

    Fast path: exact linear-contact solution, then joint Newton. Positions it
    does not settle go through the bracketed nested solver.
    """
    a_c = np.where(geo.loadable, geo.advance, 0.0)
    a_m = np.where(geo.loadable, geo.arm, 0.0)
    h0 = np.where(geo.loadable, geo.gap, -1e300)
    if getattr(comp, "explicit", False):
        # A law with a closed-form inverse (Palmgren's): Newton-bisection on tau alone.
        tau, F, iterations = _nested(a_c, a_m, h0, comp, target, rtol=rtol)
        ok = np.ones(len(tau), dtype=bool)
    else:
        tau = _linear_tau(a_c, a_m, h0, comp.slope0, target)
        tau, F, iterations, ok = _newton(a_c, a_m, h0, comp, target, tau, rtol=rtol)
    if not np.all(ok):
        bad = np.flatnonzero(~ok)
        sub = comp.take(bad)
        t2, F2, it2 = _nested(a_c[bad], a_m[bad], h0[bad], sub, target, rtol=rtol)
        tau[bad] = t2
        F[bad] = F2
        iterations += it2
    mom = np.sum(a_m * F, axis=1)
    # Scale of the residual: the forces, and the forces the gross terms of
    # h = tau a + gap would give before they cancel (a gap closed by a large
    # cam rotation leaves only round-off of those terms).
    gross = np.where(geo.loadable, np.abs(tau[:, None] * a_c) + np.abs(geo.gap), 0.0)
    scale = np.sum(np.abs(a_m) * (np.abs(F) + gross / comp.slope0), axis=1)
    res = mom - target
    rel = np.abs(res) / (abs(target) + scale + 1e-300)
    return tau, F, iterations, res, rel
