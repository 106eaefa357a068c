"""The bodies' coupled equilibrium by one Newton on the overlaps (compiled).

A position's unknowns are the crank rotation ``tau``, the rollers' overlaps ``y``
and, with needle bearings, each cam's centre ``u_c``:

    y_k = a_k tau + g_k + n_k . u_c - sum_j C_kj f(y_j),      sum_k m_k f(y_k) = M0,
    sum_{k in row c} f(y_k) n_k = sum_j Q_j(u_c) e_j          (each cam on its needles),

``f`` the contact law's force at an overlap (0 where ``y <= 0``; continuously
differentiable), ``a`` and ``m`` the overlaps' and the moment's arms, ``C`` the
bodies' influence matrix (:mod:`corr_cad.mechanics.drive.coupling`), ``Q_j`` the
needles' Palmgren loads at their approach ``-u_c . e_j - Pd / 2``
(:mod:`corr_cad.mechanics.crank.bearing`). Newton on ``(y, tau, u)``: a roller out of
contact has ``f' = 0``, so its column drops out and only the loaded rollers' block
is solved,

    [I + C_AA K_A   -a_A   -N_A ] [dy_A]     [r_A]
    [m_A K_A          0      0  ] [dtau] = - [r_M]
    [N_A^T K_A        0     K_Q ] [du  ]     [r_c]

(``N`` the rollers' directions ``n_k`` in their cam's columns, ``K_Q = sum_j dQ_j/d
delta e_j e_j^T``), the others' ``dy`` following from their own rows. A
backtracking line search on the scaled residual keeps each step a descent. It
solves the equations :func:`~corr_cad.mechanics.drive.coupling.coupled_solve`
solves by its Newton on the approaches ``d`` around the drive's own solve, without
that inner solve, and on the loaded block alone; positions it does not settle (to
the same tolerances: a cam adrift in its clearance leaves the block singular) are
left to that solve. The loop over positions is compiled (numba), with the contact
laws of the drive kernels (:mod:`corr_cad.mechanics.drive.drive_laws`).

Only the columns of the rollers that carry load are needed (``C F`` with ``F`` zero
elsewhere): a position's columns are read from the bodies' tables as its rollers
take load (:mod:`~corr_cad.mechanics.drive.coupling_kernel`, the same arithmetic as
the whole matrix). Positions next to each other (in the phase of the drive's
period) have nearly the same solution: solved in that order, each starts from its
neighbour's, its rollers renumbered by the slots between them, and settles in a
step or two; the first, and any whose neighbour did not settle, from the drive's
own solve.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.drive.coupling_kernel import column, prepare
from corr_cad.mechanics.drive.drive_laws import (
    CJ,
    CN,
    CS,
    K1,
    KC,
    KG,
    UKJ,
    UKN,
    UKS,
    WN,
    WS,
    _invert_one,
    _palmgren,
)
from corr_cad.mechanics.row.mc_kernel import _approach, _jit, _jit_inner

__all__ = ["overlap_newton"]


def overlap_newton(
    comp,
    geo,
    tb: tuple,
    target: float,
    tau: np.ndarray,
    d: np.ndarray,
    rtol: float,
    body_rtol: float,
    max_iter: int = 40,
    tight: float = 1.0,
    cams=None,
    chain=None,
):
    """``(tau, F, d, rel, ok, iterations, u, Q)`` of the positions of ``geo`` (P, N) from
    the start ``tau`` (P,) with the bodies' approaches ``d`` (P, N); ``comp`` the
    positions' contact law; ``tb`` the bodies' tables as read at the positions
    (:func:`~corr_cad.mechanics.drive.coupling.influence_inputs`): a position's columns of
    ``C`` are made as its rollers take load (``C F`` needs no others).
    ``cams``: None (cams fixed; ``u``, ``Q`` None) or ``(n (P, N, 2), u (2, P, 2),
    bearings)``, the rollers' directions, the cams' start and their needle bearings (of
    one needle count). ``chain``: None (every position from its start) or ``(order, src,
    shift, given)`` (P,) each: the positions solved in ``order``, position ``p`` from
    position ``src[p]``'s solution (settled before it; -1: none) with its rollers' indices
    moved by ``shift[p]`` within each row, else from its start where ``given[p]``, else
    left unsettled. ``ok``: settled, the moment to ``rtol``, the bodies to ``body_rtol`` and
    the cams' balance to ``rtol``; ``rel`` the moment's and the cams' relative residual.
    ``tight``: iterate on to ``tight`` times those tolerances where round-off allows."""
    loadable = np.ascontiguousarray(geo.loadable)
    a_c = np.ascontiguousarray(np.where(loadable, geo.advance, 0.0))
    a_m = np.ascontiguousarray(np.where(loadable, geo.arm, 0.0))
    g = np.ascontiguousarray(np.where(loadable, geo.gap, 0.0))
    P, N = a_c.shape
    if getattr(comp, "explicit", False):
        law, T = 1, np.zeros((11, 1, 1))
        K = np.array(np.broadcast_to(comp.K, (P, N)), dtype=float, order="C")
    else:
        law, T = 0, _contact_table(comp, (P, N))
        K = np.array(np.broadcast_to(comp.slope0, (P, N)), dtype=float, order="C")
    if cams is None:
        n, u = np.zeros((P, N, 2)), np.zeros((2, P, 2))
        dirs, bear = np.zeros((2, 1, 2)), np.zeros((2, 3))
    else:
        n, u, bearings = cams
        n, u = np.ascontiguousarray(n, dtype=float), np.array(u, dtype=float)
        dirs = np.ascontiguousarray(np.stack([b.directions() for b in bearings]))
        bear = np.array(
            [[0.5 * b.diametral_clearance, b.needle_coefficient, 0.0] for b in bearings]
        )
    if chain is None:
        order, src = np.arange(P), np.full(P, -1)
        shift, given = np.zeros(P, dtype=np.int64), np.ones(P, dtype=bool)
    else:
        order, src, shift, given = chain
    y = a_c * tau[:, None] + g - d
    if cams is not None:  # the cams' start displacements along each roller's direction
        R = N // 2
        y[:, :R] += np.einsum("pkx,px->pk", n[:, :R], u[0])
        y[:, R:] += np.einsum("pkx,px->pk", n[:, R:], u[1])
    y = np.ascontiguousarray(np.where(loadable, y, -1.0))
    tau = np.array(tau, dtype=float)
    U = np.ascontiguousarray(np.transpose(u, (1, 0, 2)))  # (P, 2, 2)
    F, cf = np.zeros((P, N)), np.zeros((P, N))
    Q = np.zeros((P, 2, dirs.shape[1]))
    rel, ok, its = np.zeros(P), np.zeros(P, dtype=bool), np.zeros(1, dtype=np.int64)
    seq = np.ascontiguousarray(np.stack([order, src, shift]).astype(np.int64))
    _newton(
        a_c, a_m, g, loadable, tb, law, T, K, float(target), float(rtol), float(body_rtol),
        int(max_iter), float(tight), cams is not None, n, dirs, bear, seq,
        np.ascontiguousarray(given, dtype=bool), tau, y, U, F, cf, Q, rel, ok, its,
    )  # fmt: skip
    out_u = np.transpose(U, (1, 0, 2)).copy() if cams is not None else None
    out_q = [Q[:, 0].copy(), Q[:, 1].copy()] if cams is not None else None
    d_out = np.where(loadable, cf, 0.0)
    return tau, F, d_out, rel, ok, int(its[0]), out_u, out_q


def _contact_table(comp, shape: tuple[int, int]) -> np.ndarray:
    """The paper's law's per-roller table of ``drive_laws._invert_one`` (11, P, N): the
    drive kernel's ``CompiledInverse.table``."""
    cam, gear, slot = comp.contacts
    rows = (cam.cw, cam.k1, cam.k2, cam.uk, gear.cw, gear.w, gear.k2, gear.uk)
    rows += (slot.cw, slot.w, slot.uk)
    T = np.empty((len(rows), *shape))
    for i, x in enumerate(rows):
        T[i] = x
    return T


@_jit_inner
def _law(h, law, T, K, p, i, f0):
    """``(F, dF/dh)`` of roller ``i`` of position ``p`` at overlap ``h`` (the paper's law
    inverted by Newton from the force ``f0``, where positive)."""
    if not h > 0.0:
        return 0.0, 0.0
    if law == 1:
        return _palmgren(h, K[p, i])
    return _invert_one(h, f0 if f0 > 0.0 else h / K[p, i], T, p, i)


@_jit_inner
def _forward(f, T, p, i):
    """``(h, dh/dF)`` of roller ``i`` of position ``p`` under the paper's law at the force
    ``f``: the overlap ``G(f)`` the inversion (``drive_laws._invert_one``) solves for."""
    vj, sj = _approach(T[CJ, p, i] * f, T[UKJ, p, i], T[K1, p, i], T[KC, p, i])
    vn, sn = _approach(T[CN, p, i] * f, T[UKN, p, i], T[K1, p, i], T[KG, p, i])
    vs, ss = _approach(T[CS, p, i] * f, T[UKS, p, i], T[K1, p, i], 0.0)
    wn, ws = T[WN, p, i], T[WS, p, i]
    return vj + wn * vn + ws * vs, T[CJ, p, i] * sj + wn * T[CN, p, i] * sn + ws * T[CS, p, i] * ss


@_jit_inner
def _evaluate(p, y, tau, u, st, lz, F0, F, k, cf, r, rc, Q, kq, mode):
    """Forces, stiffnesses, ``C F``, the needles and the residuals at ``(y, tau, u)``:
    ``(r_M, scale_M, max |C F|, scale of the cams' balance)``; ``r`` (N,), ``rc`` (4,)
    filled (``F0``: the forces the paper's law's inversion starts from, where positive;
    ``mode[0] == 1``: under the paper's law a roller of positive ``F0`` is put at that
    force, its overlap ``y`` the law's, with no inversion);
    ``lz = (tb, xf, D0, FD, Cp, have)``: position ``p``'s columns of ``C``
    (``Ct`` (N, N), transposed: a column a row), each made when its roller first takes
    load (``have``)."""
    a_c, a_m, g, on, law, T, K, target, floating, n, dirs, bear = st
    tb, xf, D0, FD, Ct, have = lz
    N = y.shape[0]
    R = N // 2
    mom, scale = -target, abs(target)
    for i in range(N):
        if on[p, i] and mode[0] == 1 and law == 0 and F0[i] > 0.0:
            y[i], dg = _forward(F0[i], T, p, i)
            F[i], k[i] = F0[i], 1.0 / dg
        else:
            F[i], k[i] = _law(y[i], law, T, K, p, i, F0[i]) if on[p, i] else (0.0, 0.0)
        mom += a_m[p, i] * F[i]
        scale += abs(a_m[p, i]) * F[i]
        cf[i] = 0.0
    for j in range(N):
        if F[j] != 0.0:
            if not have[j]:
                column(p, j, tb, xf, D0, FD, Ct)
                have[j] = True
            for i in range(N):
                cf[i] += Ct[j, i] * F[j]
    top = 0.0
    for i in range(N):
        top = max(top, abs(cf[i]))
        if on[p, i]:
            c = 0 if i < R else 1
            nu = n[p, i, 0] * u[c, 0] + n[p, i, 1] * u[c, 1] if floating else 0.0
            r[i] = y[i] - a_c[p, i] * tau - g[p, i] - nu + cf[i]
        else:
            r[i] = 0.0
    sf = 1e-300
    for c in range(2):
        rc[2 * c] = 0.0
        rc[2 * c + 1] = 0.0
        if not floating:
            continue
        tot = 0.0
        for i in range(c * R, (c + 1) * R):
            rc[2 * c] += F[i] * n[p, i, 0]
            rc[2 * c + 1] += F[i] * n[p, i, 1]
            tot += F[i]
        for j in range(dirs.shape[1]):
            ex, ey = dirs[c, j, 0], dirs[c, j, 1]
            q, kk = _palmgren(-(u[c, 0] * ex + u[c, 1] * ey) - bear[c, 0], bear[c, 1])
            Q[c, j], kq[c, j] = q, kk
            rc[2 * c] -= q * ex
            rc[2 * c + 1] -= q * ey
            tot += q
        sf = max(sf, tot)
    return mom, scale + 1e-300, top, sf


@_jit_inner
def _merit(r, rm, sm, top, rc, sf):
    s = 0.0
    for i in range(r.shape[0]):
        s += r[i] * r[i]
    c = 0.0
    for i in range(4):
        c += rc[i] * rc[i]
    return s / (top * top + 1e-300) + (rm / sm) ** 2 + (c / (sf * sf) if c > 0.0 else 0.0)


@_jit_inner
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
    for c in range(n):
        if not math.isfinite(b[c]):
            return False
    return True


@_jit_inner
def _settled(r, rm, sm, top, rc, sf, rtol, body_rtol):
    body = 0.0
    for i in range(r.shape[0]):
        body = max(body, abs(r[i]))
    cams = 0.0
    for c in range(2):
        cams = max(cams, math.sqrt(rc[2 * c] ** 2 + rc[2 * c + 1] ** 2))
    return abs(rm) <= rtol * sm and body <= body_rtol * top and top > 0.0 and cams <= rtol * sf


@_jit_inner
def _seed(p, q, b, seq, a_c, g, on, n, tau, y, U, F):
    """Position ``p``'s start from position ``q``'s solution, its rollers' indices moved by
    ``seq[2, p]`` within each row; extrapolated linearly from ``b``'s before it where
    ``b >= 0`` (a roller not loadable in either: its overlap without the bodies)."""
    N = y.shape[1]
    R = N // 2
    w = 1.0 if b >= 0 else 0.0
    bq = b if b >= 0 else q
    tau[p] = tau[q] + w * (tau[q] - tau[bq])
    for c in range(2):
        for x in range(2):
            U[p, c, x] = U[q, c, x] + w * (U[q, c, x] - U[bq, c, x])
    for i in range(N):
        if not on[p, i]:
            continue
        c = 0 if i < R else 1
        j = c * R + (i - c * R - seq[2, p]) % R
        k = c * R + (j - c * R - seq[2, q]) % R if b >= 0 else j
        F[p, i] = F[q, j]  # where the paper's law's inversion starts
        if on[q, j] and on[bq, k]:
            y[p, i] = y[q, j] + w * (y[q, j] - y[bq, k])
            if F[q, j] > 0.0 and F[bq, k] > 0.0:
                F[p, i] = max(F[q, j] + w * (F[q, j] - F[bq, k]), 0.0)
        else:
            nu = n[p, i, 0] * U[p, c, 0] + n[p, i, 1] * U[p, c, 1]
            y[p, i] = a_c[p, i] * tau[p] + g[p, i] + nu


@_jit
def _newton(
    a_c, a_m, g, on, tb, law, T, K, target, rtol, body_rtol, max_iter, tight,
    floating, n, dirs, bear, seq, given, tau, y, U, F, cf, Q, rel, ok, its,
):  # fmt: skip
    P, N = a_c.shape
    R = N // 2
    Z = dirs.shape[1]
    st = (a_c, a_m, g, on, law, T, K, target, floating, n, dirs, bear)
    xf, D0, FD = np.empty(N), np.empty(N - 1, dtype=np.int64), np.empty(N - 1)
    Ct, have = np.empty((N, N)), np.empty(N, dtype=np.bool_)
    lz = (tb, xf, D0, FD, Ct, have)
    nc = 4 if floating else 0
    k, r, dy, v = np.empty(N), np.empty(N), np.empty(N), np.empty(N)
    yt, Ft, kt, cft, rt = np.empty(N), np.empty(N), np.empty(N), np.empty(N), np.empty(N)
    Fg, mode = np.empty(N), np.zeros(1, dtype=np.int64)
    rc, rct, ut, du = np.empty(4), np.empty(4), np.empty((2, 2)), np.empty((2, 2))
    kq, kqt, Qt = np.empty((2, Z)), np.empty((2, Z)), np.empty((2, Z))
    act = np.empty(N, dtype=np.int64)
    J, b = np.empty((N + 5, N + 5)), np.empty(N + 5)
    for o in range(P):
        p, q = seq[0, o], seq[1, seq[0, o]]
        if q >= 0 and ok[q]:
            q2 = seq[1, q]  # the one before it: a linear extrapolation where it settled too
            _seed(p, q, q2 if q2 >= 0 and ok[q2] else -1, seq, a_c, g, on, n, tau, y, U, F)
        elif not given[p]:
            continue  # no start: left to the caller (ok False)
        prepare(p, tb, xf, D0, FD)
        for j in range(N):
            have[j] = False
        t = tau[p]
        u = U[p]
        # A chained position under the paper's law: its rollers put at the start's forces.
        mode[0] = 1 if q >= 0 and ok[q] else 0
        rm, sm, top, sf = _evaluate(
            p, y[p], t, u, st, lz, F[p], F[p], k, cf[p], r, rc, Q[p], kq, mode
        )
        # The steps under the paper's law: a loaded roller's force moves along its tangent,
        # its overlap the law's at the new force (forward: no inversion; the same step to
        # first order, Newton's convergence kept).
        mode[0] = 1
        for it in range(max_iter + 1):
            # Tighter than asked where round-off allows (a caller that iterates on these
            # forces, the crankshaft's fixed point, then sees no noise).
            if _settled(r, rm, sm, top, rc, sf, tight * rtol, tight * body_rtol):
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
            size = m + 1 + nc
            for x in range(size):
                for z in range(size):
                    J[x, z] = 0.0
            for x in range(m):
                i = act[x]
                c = 0 if i < R else 1
                for z in range(m):
                    J[x, z] = Ct[act[z], i] * k[act[z]]
                J[x, x] += 1.0
                J[x, m] = -a_c[p, i]
                J[m, x] = a_m[p, i] * k[i]
                b[x] = -r[i]
                if floating:
                    J[x, m + 1 + 2 * c] = -n[p, i, 0]
                    J[x, m + 2 + 2 * c] = -n[p, i, 1]
                    J[m + 1 + 2 * c, x] = n[p, i, 0] * k[i]
                    J[m + 2 + 2 * c, x] = n[p, i, 1] * k[i]
            b[m] = -rm
            if floating:
                for c in range(2):
                    o = m + 1 + 2 * c
                    for j in range(Z):
                        ex, ey = dirs[c, j, 0], dirs[c, j, 1]
                        J[o, o] += kq[c, j] * ex * ex
                        J[o, o + 1] += kq[c, j] * ex * ey
                        J[o + 1, o] += kq[c, j] * ey * ex
                        J[o + 1, o + 1] += kq[c, j] * ey * ey
                    b[o], b[o + 1] = -rc[2 * c], -rc[2 * c + 1]
            if not _gauss(J, b, size):
                break
            dt = b[m]
            for c in range(2):
                du[c, 0] = b[m + 1 + 2 * c] if floating else 0.0
                du[c, 1] = b[m + 2 + 2 * c] if floating else 0.0
            size_y, big = 0.0, 0.0
            for x in range(m):
                size_y = max(size_y, abs(b[x]))
                big = max(big, abs(y[p, act[x]]))
            if size_y <= 1e-15 * big and abs(dt) <= 1e-15 * abs(t):
                break  # the step is round-off: as settled as it gets
            for i in range(N):
                v[i] = 0.0
            for x in range(m):
                v[act[x]] = k[act[x]] * b[x]
            for i in range(N):
                if on[p, i]:
                    c = 0 if i < R else 1
                    dy[i] = -r[i] + a_c[p, i] * dt + n[p, i, 0] * du[c, 0] + n[p, i, 1] * du[c, 1]
                else:
                    dy[i] = 0.0
            for x in range(m):  # C's columns in place: its rows of the transposed
                j = act[x]
                for i in range(N):
                    if on[p, i]:
                        dy[i] -= Ct[j, i] * v[j]
            m0 = _merit(r, rm, sm, top, rc, sf)
            alpha, moved = 1.0, False
            for _ in range(12):
                for i in range(N):
                    yt[i] = y[p, i] + alpha * dy[i] if on[p, i] else y[p, i]
                    # The force along its tangent (and the inversion's start where it ends).
                    Fg[i] = max(F[p, i] + alpha * k[i] * dy[i], 0.0) if F[p, i] > 0.0 else 0.0
                tt = t + alpha * dt
                for c in range(2):
                    ut[c, 0] = u[c, 0] + alpha * du[c, 0]
                    ut[c, 1] = u[c, 1] + alpha * du[c, 1]
                rmt, smt, topt, sft = _evaluate(
                    p, yt, tt, ut, st, lz, Fg, Ft, kt, cft, rt, rct, Qt, kqt, mode
                )
                if _merit(rt, rmt, smt, topt, rct, sft) <= (1.0 - 1e-4 * alpha) * m0:
                    moved = True
                    break
                alpha *= 0.5
            if not moved:
                break
            t, rm, sm, top, sf = tt, rmt, smt, topt, sft
            for i in range(N):
                y[p, i], F[p, i], k[i], cf[p, i], r[i] = yt[i], Ft[i], kt[i], cft[i], rt[i]
            for c in range(2):
                u[c, 0], u[c, 1] = ut[c, 0], ut[c, 1]
                rc[2 * c], rc[2 * c + 1] = rct[2 * c], rct[2 * c + 1]
                for j in range(Z):
                    Q[p, c, j], kq[c, j] = Qt[c, j], kqt[c, j]
            its[0] = max(its[0], it + 1)
        tau[p] = t
        cams = 0.0
        for c in range(2):
            cams = max(cams, math.sqrt(rc[2 * c] ** 2 + rc[2 * c + 1] ** 2))
        rel[p] = max(abs(rm) / sm, cams / sf)
        ok[p] = _settled(r, rm, sm, top, rc, sf, rtol, body_rtol)
