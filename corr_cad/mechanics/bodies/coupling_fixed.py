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
the same tolerances) are left to that solve. The loop over positions is compiled
(numba): each position's Newton on its own loaded block, the contact laws of the drive
kernels (:mod:`corr_cad.mechanics.drive_laws`).

Only the columns of the rollers that can carry load are needed (``C F`` with ``F``
zero elsewhere): the caller builds ``C`` for a candidate set, and a position whose
solution loads a roller outside it is left to the full solve too (its rows are
exact, so the test is).
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.drive_laws import _invert_one, _palmgren
from corr_cad.mechanics.mc_kernel import _jit

__all__ = ["fixed_cams_newton"]


def fixed_cams_newton(
    comp,
    geo,
    C: np.ndarray,
    target: float,
    tau: np.ndarray,
    d: np.ndarray,
    candidates: np.ndarray,
    rtol: float,
    body_rtol: float,
    max_iter: int = 40,
    tight: float = 1.0,
):
    """``(tau, F, d, rel, ok, iterations)`` of the positions of ``geo`` (P, N) from the
    start ``tau`` (P,) with the bodies' approaches ``d`` (P, N); ``comp`` the positions'
    contact law; ``C`` (P, N, N) made for the loads ``candidates`` (P, N). ``ok``:
    settled, the moment to ``rtol`` and the bodies to ``body_rtol``, loading candidates
    only; ``rel`` the moment's relative residual. ``tight``: iterate on to ``tight`` times
    those tolerances where round-off allows."""
    loadable = np.ascontiguousarray(geo.loadable)
    a_c = np.ascontiguousarray(np.where(loadable, geo.advance, 0.0))
    a_m = np.ascontiguousarray(np.where(loadable, geo.arm, 0.0))
    g = np.ascontiguousarray(np.where(loadable, geo.gap, 0.0))
    P, N = a_c.shape
    if getattr(comp, "explicit", False):
        law, T = 1, np.zeros((11, 1))
        K = np.array(np.broadcast_to(comp.K, (P, N)), dtype=float, order="C")
    else:
        law, T = 0, _contact_table(comp, (P, N))
        K = np.array(np.broadcast_to(comp.slope0, (P, N)), dtype=float, order="C")
    y = np.ascontiguousarray(np.where(loadable, a_c * tau[:, None] + g - d, -1.0))
    tau = np.array(tau, dtype=float)
    F, cf = np.zeros((P, N)), np.zeros((P, N))
    rel, ok, its = np.zeros(P), np.zeros(P, dtype=bool), np.zeros(1, dtype=np.int64)
    _newton(
        a_c, a_m, g, loadable, np.ascontiguousarray(C), np.ascontiguousarray(candidates),
        law, T, K, float(target), float(rtol), float(body_rtol), int(max_iter), float(tight),
        tau, y, F, cf, rel, ok, its,
    )  # fmt: skip
    return tau, F, np.where(loadable, cf, 0.0), rel, ok, int(its[0])


def _contact_table(comp, shape: tuple[int, int]) -> np.ndarray:
    """The paper's law's per-roller table of :func:`~corr_cad.mechanics.drive_laws.
    _invert_one` (11, P N): the drive kernel's ``CompiledInverse.table``."""
    cam, gear, slot = comp.contacts
    rows = (cam.cw, cam.k1, cam.k2, cam.uk, gear.cw, gear.w, gear.k2, gear.uk)
    rows += (slot.cw, slot.w, slot.uk)
    return np.ascontiguousarray(
        np.stack([np.broadcast_to(np.asarray(x, dtype=float), shape).reshape(-1) for x in rows])
    )


@_jit
def _law(h, law, T, K, p, i, N):
    """``(F, dF/dh)`` of roller ``i`` of position ``p`` at overlap ``h``."""
    if not h > 0.0:
        return 0.0, 0.0
    if law == 1:
        return _palmgren(h, K[p, i])
    return _invert_one(h, h / K[p, i], T, p * N + i)


@_jit
def _evaluate(p, y, tau, a_c, a_m, g, on, C, law, T, K, target, F, k, cf, r):
    """Forces, stiffnesses, ``C F`` and the residuals at ``(y, tau)``: ``(r_M, scale_M,
    max |C F|)``, ``r`` (N,) filled."""
    N = y.shape[0]
    mom, scale = -target, abs(target)
    for i in range(N):
        F[i], k[i] = _law(y[i], law, T, K, p, i, N) if on[p, i] else (0.0, 0.0)
        mom += a_m[p, i] * F[i]
        scale += abs(a_m[p, i]) * F[i]
        cf[i] = 0.0
    for j in range(N):
        if F[j] != 0.0:
            for i in range(N):
                cf[i] += C[p, i, j] * F[j]
    top = 0.0
    for i in range(N):
        top = max(top, abs(cf[i]))
        r[i] = y[i] - a_c[p, i] * tau - g[p, i] + cf[i] if on[p, i] else 0.0
    return mom, scale + 1e-300, top


@_jit
def _merit(r, rm, sm, top):
    s = 0.0
    for i in range(r.shape[0]):
        s += r[i] * r[i]
    return s / (top * top + 1e-300) + (rm / sm) ** 2


@_jit
def _gauss(J, b, n):
    """Solve ``J x = b`` (the leading ``n``) in place by partial pivoting; False if
    singular."""
    for c in range(n):
        piv, best = c, abs(J[c, c])
        for i in range(c + 1, n):
            if abs(J[i, c]) > best:
                piv, best = i, abs(J[i, c])
        if not best > 0.0:
            return False
        if piv != c:
            for j in range(n):
                J[c, j], J[piv, j] = J[piv, j], J[c, j]
            b[c], b[piv] = b[piv], b[c]
        for i in range(c + 1, n):
            f = J[i, c] / J[c, c]
            if f != 0.0:
                for j in range(c, n):
                    J[i, j] -= f * J[c, j]
                b[i] -= f * b[c]
    for c in range(n - 1, -1, -1):
        s = b[c]
        for j in range(c + 1, n):
            s -= J[c, j] * b[j]
        b[c] = s / J[c, c]
    return math.isfinite(b[0])


@_jit
def _newton(
    a_c, a_m, g, on, C, cand, law, T, K, target, rtol, body_rtol, max_iter, tight,
    tau, y, F, cf, rel, ok, its,
):  # fmt: skip
    P, N = a_c.shape
    k, r, dy, v = np.empty(N), np.empty(N), np.empty(N), np.empty(N)
    yt, Ft, kt, cft, rt = np.empty(N), np.empty(N), np.empty(N), np.empty(N), np.empty(N)
    act = np.empty(N, dtype=np.int64)
    J, b = np.empty((N + 1, N + 1)), np.empty(N + 1)
    for p in range(P):
        t = tau[p]
        rm, sm, top = _evaluate(
            p, y[p], t, a_c, a_m, g, on, C, law, T, K, target, F[p], k, cf[p], r
        )
        for it in range(max_iter + 1):
            body = 0.0
            for i in range(N):
                body = max(body, abs(r[i]))
            # Tighter than asked where round-off allows (a caller that iterates on these
            # forces, the crankshaft's fixed point, then sees no noise).
            if abs(rm) <= tight * rtol * sm and body <= tight * body_rtol * top and top > 0.0:
                break
            if it == max_iter:
                break
            m = 0
            for i in range(N):
                if on[p, i] and k[i] > 0.0:
                    act[m] = i
                    m += 1
            if m == 0:
                break
            # [I + C_AA K_A, -a_A; m_A K_A, 0] [dy_A; dtau] = -[r_A; r_M]
            for x in range(m):
                i = act[x]
                for z in range(m):
                    J[x, z] = C[p, i, act[z]] * k[act[z]]
                J[x, x] += 1.0
                J[x, m] = -a_c[p, i]
                J[m, x] = a_m[p, i] * k[i]
                b[x] = -r[i]
            J[m, m] = 0.0
            b[m] = -rm
            if not _gauss(J, b, m + 1):
                break
            dt = b[m]
            size, big = 0.0, 0.0
            for x in range(m):
                size = max(size, abs(b[x]))
                big = max(big, abs(y[p, act[x]]))
            if size <= 1e-15 * big and abs(dt) <= 1e-15 * abs(t):
                break  # the step is round-off: as settled as it gets
            for i in range(N):
                v[i] = 0.0
            for x in range(m):
                v[act[x]] = k[act[x]] * b[x]
            for i in range(N):
                if on[p, i]:
                    s = -r[i] + a_c[p, i] * dt
                    for x in range(m):
                        s -= C[p, i, act[x]] * v[act[x]]
                    dy[i] = s
                else:
                    dy[i] = 0.0
            m0 = _merit(r, rm, sm, top)
            alpha, moved = 1.0, False
            for _ in range(12):
                for i in range(N):
                    yt[i] = y[p, i] + alpha * dy[i] if on[p, i] else y[p, i]
                tt = t + alpha * dt
                rmt, smt, topt = _evaluate(
                    p, yt, tt, a_c, a_m, g, on, C, law, T, K, target, Ft, kt, cft, rt
                )
                if _merit(rt, rmt, smt, topt) <= (1.0 - 1e-4 * alpha) * m0:
                    moved = True
                    break
                alpha *= 0.5
            if not moved:
                break
            t, rm, sm, top = tt, rmt, smt, topt
            for i in range(N):
                y[p, i], F[p, i], k[i], cf[p, i], r[i] = yt[i], Ft[i], kt[i], cft[i], rt[i]
            its[0] = max(its[0], it + 1)
        tau[p] = t
        rel[p] = abs(rm) / sm
        body = 0.0
        for i in range(N):
            body = max(body, abs(r[i]))
        good = abs(rm) <= rtol * sm and body <= body_rtol * top and top > 0.0
        if good:
            for i in range(N):
                if F[p, i] > 0.0 and not cand[p, i]:
                    good = False
        ok[p] = good
