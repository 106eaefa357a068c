"""Compiled assembly of the bodies' influence matrices (numba).

The loop of :func:`corr_cad.mechanics.bodies.coupling.influence_matrices` over
positions and roller pairs, with the numpy path's interpolation (bilinear in the
load coordinate and the read's offset from it; the ring's ``z``-fold symmetry,
the frame's ``R``-fold and mirror symmetry), without its temporaries: some
ten million table readings for the prototype's 3,600 positions.
"""

from __future__ import annotations

import math

from corr_cad.mechanics.mc_kernel import _jit

__all__ = ["influence_kernel"]


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


@_jit
def influence_kernel(ring, frame, rho0, step, x, rn, rs, s, cam, xc, on, cols, C):
    """Fill ``C`` (P, 2R, 2R): ``x`` (P, 2R) each roller's ring coordinate, ``rn``,
    ``rs`` (P, 2R) its gear and slot force ratios (0 where not loadable), ``s`` its
    centre's radius, mm; ``cam`` (Mc,) the cam's table by angle, ``xc`` each roller's
    direction from its cam's centre as its index, ``on`` where the cam term counts;
    ``cols`` (P, 2R): the loads ``j`` whose columns are made (the others left 0)."""
    Mc = cam.shape[0]
    P, N = x.shape
    R = N // 2
    for p in range(P):
        for k in range(N):
            for j in range(N):
                if not cols[p, j]:
                    C[p, k, j] = 0.0
                    continue
                same = (k < R) == (j < R)
                v = 0.0
                if same and rn[p, k] != 0.0 and rn[p, j] != 0.0:
                    v = rn[p, k] * rn[p, j] * _ring_at(ring, x[p, j], x[p, k])
                if rs[p, k] != 0.0 and rs[p, j] != 0.0:
                    share = 0.5 if same else 0.25
                    sj = 1.0 if rs[p, j] > 0.0 else -1.0
                    sk = 1.0 if rs[p, k] > 0.0 else -1.0
                    f = _frame_at(frame, rho0, step, s[p, j], sj, j % R, s[p, k], sk, k % R)
                    v += share * abs(rs[p, k]) * abs(rs[p, j]) * f
                if same and on[p, k] and on[p, j]:
                    dc = xc[p, k] - xc[p, j]
                    dc -= Mc * math.floor(dc / Mc)
                    i0 = int(math.floor(dc))
                    fc = dc - i0
                    v += (1.0 - fc) * cam[i0 % Mc] + fc * cam[(i0 + 1) % Mc]
                C[p, k, j] = v
