"""Compiled assembly of the bodies' influence matrices (numba).

The loop of :func:`corr_cad.mechanics.drive.coupling.influence_matrices` over
positions and roller pairs, with the numpy path's interpolation (bilinear in the
load coordinate and the read's offset from it; the ring's ``z``-fold symmetry,
the frame's ``R``-fold and mirror symmetry), without its temporaries: some
ten million table readings for the prototype's 3,600 positions.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.row.mc_kernel import _jit, _jit_inner

__all__ = ["column", "influence_kernel", "prepare"]


@_jit
def _ring_at(T, xa, xb):
    M, Mz = T.shape
    d = xb - xa + 0.5 * Mz
    d = d - Mz * math.floor(d / Mz) - 0.5 * Mz
    a = xa - M * math.floor(xa / M)
    i0 = min(int(math.floor(a)), M - 1)
    d0 = int(math.floor(d))
    fi, fd = a - i0, d - d0
    v = 0.0
    for di in range(2):
        i = (i0 + di) % M
        wi = fi if di else 1.0 - fi
        for dd in range(2):
            wd = fd if dd else 1.0 - fd
            v += wi * wd * T[i, (i + d0 + dd) % Mz]
    return v


@_jit
def _frame_at(T, rho0, step, ra, sa, ka, rb, sb, kb):
    Mf, R = T.shape[0], T.shape[1]
    m = (kb - ka) % R
    flip = sa < 0.0
    if flip:
        m = (R - m) % R
    side = 0 if (sb > 0.0) != flip else 1
    xa = min(max((ra - rho0) / step, 0.0), Mf - 1.0)
    xb = min(max((rb - rho0) / step, 0.0), Mf - 1.0)
    i0 = min(int(math.floor(xa)), Mf - 2)
    d = xb - xa
    d0 = int(math.floor(d))
    fi, fd = xa - i0, d - d0
    v = 0.0
    for di in range(2):
        wi = fi if di else 1.0 - fi
        for dd in range(2):
            wd = fd if dd else 1.0 - fd
            r = min(max(i0 + di + d0 + dd, 0), Mf - 1)
            v += wi * wd * T[i0 + di, m, side, r]
    return v


@_jit_inner
def prepare(p, tb, xf, D0, FD):
    """What position ``p``'s columns share: each roller's frame coordinate ``xf`` (N,)
    (its radius, clipped to the table) and, within a row, the ring offset of read ``k``
    from load ``j``, ``x_k - x_j`` wrapped to [-Mz/2, Mz/2), by the pair's index
    difference ``k - j + R2 - 1`` (``D0``, ``FD`` (2 R2 - 1,): its floor and fraction)."""
    ring, frame, rho0, step, x, rn, rs, s, cam, xc, on = tb
    Mz = ring.shape[1]
    Mf = frame.shape[0]
    N = x.shape[1]
    R2 = N // 2
    for i in range(N):
        xf[i] = min(max((s[p, i] - rho0) / step, 0.0), Mf - 1.0)
    for q in range(2 * R2 - 1):
        # k - j = q - (R2 - 1); row A's rollers give every difference.
        k, j = (q - (R2 - 1), 0) if q >= R2 - 1 else (0, R2 - 1 - q)
        d = x[p, k] - x[p, j] + 0.5 * Mz
        d = d - Mz * math.floor(d / Mz) - 0.5 * Mz
        D0[q] = int(math.floor(d))
        FD[q] = d - D0[q]


@_jit_inner
def column(p, j, tb, xf, D0, FD, Ct):
    """Column ``j`` of position ``p``'s matrix into row ``j`` of ``Ct`` (N, N), the matrix
    transposed (a column read and written in place; ``xf``, ``D0``, ``FD`` from
    :func:`prepare`): :func:`_ring_at` and
    :func:`_frame_at` (the readings the tests compare with the numpy path) with what
    depends on the load alone worked out once."""
    ring, frame, rho0, step, x, rn, rs, s, cam, xc, on = tb
    Mc = cam.shape[0]
    M, Mz = ring.shape
    Mf, R = frame.shape[0], frame.shape[1]
    N = x.shape[1]
    R2 = N // 2
    rowj = j < R2
    jr = j - R2 if j >= R2 else j
    # The ring: the load's angle within the table's rows (z-fold symmetry).
    a = x[p, j] - M * math.floor(x[p, j] / M)
    i0 = min(int(math.floor(a)), M - 1)
    fi = a - i0
    i1 = i0 + 1 if i0 + 1 < M else 0
    # The frame: the load's radius and side (the mirror for a - side's load).
    flip = rs[p, j] < 0.0
    ka = j % R
    xa = xf[j]
    f0 = min(int(math.floor(xa)), Mf - 2)
    ff = xa - f0
    sj = abs(rs[p, j])
    for k in range(N):
        same = (k < R2) == rowj
        v = 0.0
        if same and rn[p, k] != 0.0 and rn[p, j] != 0.0:
            q = (k - R2 if k >= R2 else k) - jr + R2 - 1
            d0, fd = D0[q], FD[q]
            c0 = i0 + d0
            c0 = c0 + Mz if c0 < 0 else (c0 - Mz if c0 >= Mz else c0)
            c1 = c0 + 1 if c0 + 1 < Mz else 0
            e0 = i1 + d0
            e0 = e0 + Mz if e0 < 0 else (e0 - Mz if e0 >= Mz else e0)
            e1 = e0 + 1 if e0 + 1 < Mz else 0
            t = (1.0 - fi) * ((1.0 - fd) * ring[i0, c0] + fd * ring[i0, c1])
            t += fi * ((1.0 - fd) * ring[i1, e0] + fd * ring[i1, e1])
            v = rn[p, k] * rn[p, j] * t
        if rs[p, k] != 0.0 and sj != 0.0:
            m = (k - R if k >= R else k) - ka  # k < 2 R: no integer division
            m = m + R if m < 0 else m
            if flip:
                m = R - m if m > 0 else 0
            side = 0 if (rs[p, k] > 0.0) != flip else 1
            d = xf[k] - xa
            d0 = int(math.floor(d))
            fd = d - d0
            r0 = min(max(f0 + d0, 0), Mf - 1)
            r1 = min(max(f0 + d0 + 1, 0), Mf - 1)
            r2 = min(max(f0 + d0 + 2, 0), Mf - 1)
            t = (1.0 - ff) * ((1.0 - fd) * frame[f0, m, side, r0] + fd * frame[f0, m, side, r1])
            t += ff * ((1.0 - fd) * frame[f0 + 1, m, side, r1] + fd * frame[f0 + 1, m, side, r2])
            v += (0.5 if same else 0.25) * abs(rs[p, k]) * sj * t
        if same and on[p, k] and on[p, j]:
            dc = xc[p, k] - xc[p, j]  # both in [0, Mc]: wrapped once at most
            if dc < 0.0:
                dc += Mc
            elif dc >= Mc:
                dc -= Mc
            c0 = min(int(math.floor(dc)), Mc - 1)
            fc = dc - c0
            c1 = c0 + 1 if c0 + 1 < Mc else 0
            v += (1.0 - fc) * cam[c0] + fc * cam[c1]
        Ct[j, k] = v


@_jit
def influence_kernel(tb, cols, C):
    """Fill ``C`` (P, 2R, 2R) from ``tb = (ring, frame, rho0, step, x, rn, rs, s, cam,
    xc, on)``: the tables and the frame's first radius and step; ``x`` (P, 2R) each
    roller's ring coordinate, ``rn``, ``rs`` (P, 2R) its gear and slot force ratios (0
    where not loadable), ``s`` its centre's radius, mm; ``cam`` (Mc,) the cam's table by
    angle, ``xc`` each roller's direction from its cam's centre as its index, ``on`` where
    the cam term counts; ``cols`` (P, 2R): the loads ``j`` whose columns are made (the
    others left 0), each position's transposed in place (``C[p, j, k]``: the caller
    transposes)."""
    x = tb[4]
    P, N = x.shape
    xf = np.empty(N)
    D0 = np.empty(N - 1, dtype=np.int64)
    FD = np.empty(N - 1)
    for p in range(P):
        prepare(p, tb, xf, D0, FD)
        Ct = C[p]
        for j in range(N):
            if cols[p, j]:
                column(p, j, tb, xf, D0, FD, Ct)
            else:
                for k in range(N):
                    Ct[j, k] = 0.0
