"""The bodies' coupled equilibrium with the cams fixed: one Newton on the overlaps.

With the cams fixed on their eccentrics (no ``[bearings.eccentric]``) a position's
unknowns are the crank rotation ``tau`` and the rollers' overlaps ``y``:

    y_k = a_k tau + g_k - sum_j C_kj f(y_j),      sum_k m_k f(y_k) = M0,

``f`` the contact law's force at an overlap (0 where ``y <= 0``; continuously
differentiable), ``a`` and ``m`` the overlaps' and the moment's arms, ``C`` the
bodies' influence matrix (:mod:`corr_cad.mechanics.bodies.coupling`). Newton on
``(y, tau)``: a roller out of contact has ``f' = 0``, so its column drops out and
only the loaded rollers' block is solved,

    [I + C_AA K_A   -a_A] [dy_A]     [r_A]
    [m_A K_A          0 ] [dtau] = - [r_M],

the others' ``dy`` following from their own rows (``dy = -r + a dtau - C K dy``).
A backtracking line search on the scaled residual keeps each step a descent.
It solves the equations :func:`~corr_cad.mechanics.bodies.coupling.coupled_solve`
solves by its Newton on the approaches ``d`` around the drive's own solve, without
that inner solve, and on the loaded block alone; positions it does not settle (to
the same tolerances) are left to that solve.

Only the columns of the rollers that can carry load are needed (``C F`` with ``F``
zero elsewhere): the caller builds ``C`` for a candidate set, and a position whose
solution loads a roller outside it is left to the full solve too (its rows are
exact, so the test is).
"""

from __future__ import annotations

import numpy as np

__all__ = ["fixed_cams_newton"]


def fixed_cams_newton(
    forces,
    geo,
    C: np.ndarray,
    target: float,
    tau: np.ndarray,
    d: np.ndarray,
    candidates: np.ndarray,
    rtol: float,
    body_rtol: float,
    max_iter: int = 40,
):
    """``(tau, F, d, rel, ok, iterations)`` of the positions of ``geo`` (P, N) from the
    start ``tau`` (P,) with the bodies' approaches ``d`` (P, N); ``forces(h, idx)`` the
    contact law's ``(F, dF/dh)`` at overlaps ``h`` of the positions ``idx`` (None: all);
    ``C`` (P, N, N) made for the loads ``candidates`` (P, N). ``ok``: settled, moment
    to ``rtol`` and bodies to ``body_rtol``, loading candidates only; ``rel`` the
    moment's relative residual."""
    loadable = geo.loadable
    a_c = np.where(loadable, geo.advance, 0.0)
    a_m = np.where(loadable, geo.arm, 0.0)
    g = np.where(loadable, geo.gap, 0.0)
    P, N = a_c.shape
    y = np.where(loadable, a_c * tau[:, None] + g - d, -1e300)
    tau = tau.copy()

    def evaluate(y, tau):
        F, k = forces(y, None)
        cf = np.einsum("pkj,pj->pk", C, F)
        r = np.where(loadable, y - a_c * tau[:, None] - g + cf, 0.0)
        rm = np.sum(a_m * F, axis=1) - target
        scale_m = abs(target) + np.sum(np.abs(a_m) * F, axis=1) + 1e-300
        top = np.max(np.abs(cf), axis=1)
        return F, k, cf, r, rm, scale_m, top

    def merit(r, rm, scale_m, top):
        return np.sum(r * r, axis=1) / (top * top + 1e-300) + (rm / scale_m) ** 2

    F, k, cf, r, rm, scale_m, top = evaluate(y, tau)
    ok = np.zeros(P, dtype=bool)
    failed = np.zeros(P, dtype=bool)
    it = 0
    for it in range(1, max_iter + 1):
        body = np.max(np.abs(r), axis=1)
        ok = (np.abs(rm) <= rtol * scale_m) & (body <= body_rtol * top) & (top > 0)
        go = np.flatnonzero(~ok & ~failed)
        if go.size == 0:
            break
        kk = np.where(loadable[go] & (k[go] > 0), k[go], 0.0)
        active = kk > 0
        m = int(np.max(np.sum(active, axis=1)))
        if m == 0:
            failed[go] = True
            break
        order = np.argsort(~active, axis=1, kind="stable")[:, :m]
        on = np.take_along_axis(active, order, axis=1)
        Ka = np.take_along_axis(kk, order, axis=1)
        Caa = C[go[:, None, None], order[:, :, None], order[:, None, :]]
        J = np.zeros((go.size, m + 1, m + 1))
        J[:, :m, :m] = Caa * Ka[:, None, :]
        J[:, :m, :m] += np.eye(m)
        J[:, :m, m] = -np.take_along_axis(a_c[go], order, axis=1)
        J[:, m, :m] = np.take_along_axis(a_m[go], order, axis=1) * Ka
        # Padding (positions with fewer loaded rollers): identity rows, no coupling.
        J[:, :m, :m] *= on[:, :, None] & on[:, None, :] | np.eye(m, dtype=bool)
        J[:, :m, m] *= on
        J[:, m, :m] *= on
        rhs = np.zeros((go.size, m + 1))
        rhs[:, :m] = -np.where(on, np.take_along_axis(r[go], order, axis=1), 0.0)
        rhs[:, m] = -rm[go]
        with np.errstate(all="ignore"):
            sol = np.linalg.solve(J, rhs[:, :, None])[:, :, 0]
        bad = ~np.all(np.isfinite(sol), axis=1)
        sol[bad] = 0.0
        v = np.zeros((go.size, N))
        np.put_along_axis(v, order, np.where(on, Ka * sol[:, :m], 0.0), axis=1)
        dtau = sol[:, m]
        dy = np.where(
            loadable[go],
            -r[go] + a_c[go] * dtau[:, None] - np.einsum("pkj,pj->pk", C[go], v),
            0.0,
        )
        m0 = merit(r[go], rm[go], scale_m[go], top[go])
        alpha = np.ones(go.size)
        accept = np.zeros(go.size, dtype=bool)
        yg, tg = y[go], tau[go]
        for _ in range(12):
            look = np.flatnonzero(~accept)
            yt = yg[look] + alpha[look, None] * dy[look]
            tt = tg[look] + alpha[look] * dtau[look]
            Ft, kt = forces(yt, go[look])
            cft = np.einsum("pkj,pj->pk", C[go[look]], Ft)
            lt = loadable[go[look]]
            rt = np.where(lt, yt - a_c[go[look]] * tt[:, None] - g[go[look]] + cft, 0.0)
            rmt = np.sum(a_m[go[look]] * Ft, axis=1) - target
            smt = abs(target) + np.sum(np.abs(a_m[go[look]]) * Ft, axis=1) + 1e-300
            topt = np.max(np.abs(cft), axis=1)
            good = merit(rt, rmt, smt, topt) <= (1.0 - 1e-4 * alpha[look]) * m0[look]
            sel = go[look[good]]
            y[sel], tau[sel] = yt[good], tt[good]
            F[sel], k[sel], cf[sel], r[sel] = Ft[good], kt[good], cft[good], rt[good]
            rm[sel], scale_m[sel], top[sel] = rmt[good], smt[good], topt[good]
            accept[look[good]] = True
            if np.all(accept):
                break
            alpha[look[~good]] *= 0.5
        failed[go[~accept | bad]] = True
    body = np.max(np.abs(r), axis=1)
    ok = (np.abs(rm) <= rtol * scale_m) & (body <= body_rtol * top) & (top > 0)
    ok &= ~np.any((F > 0) & ~candidates, axis=1)
    rel = np.abs(rm) / scale_m
    return tau, F, np.where(loadable, cf, 0.0), rel, ok, it
