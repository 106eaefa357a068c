"""Each row's free crank interval at no load with a bearing clearance, compiled.

The problem (:func:`corr_cad.mechanics.drive.drive_numerics.free_row`): roller ``k``
stays clear while ``n_k . v <= -g_k`` (a convex polygon of the cam centre's
offset ``v``), and the bearing lets ``v`` sit within ``c = Pd/2`` of ``e tau x``.
In the polygon's horizontal slice at ``v_y = y`` the rollers whose normal
points right (``n_x > 0``) bound ``v_x`` above by the lines
``b_k(y) = (-g_k - n_y y) / n_x``, those pointing left bound it below, and a
roller along the eccentric (``n_x = 0``) bounds ``y`` alone. So

    e fwd = max over y of  min_right b_k(y) + sqrt(c^2 - y^2)
    e rev = min over y of  max_left  b_k(y) - sqrt(c^2 - y^2)

over the ``y`` whose slice is not empty (to the round-off allowance ``tol``).
Both are solved exactly rather than searched:

- the slice is non-empty where every right line lies above every left one
  and no flat roller is pressed: a pair of lines gives a half-line of ``y``
  each, so the feasible ``y`` form the interval ``[y1, y2]`` found in one pass
  over the pairs (about ``(z / 2)^2`` of them);
- ``min_right b_k(y) + sqrt(c^2 - y^2)`` is concave: walking its lower
  envelope from ``y1``, line by line, the maximum is the first line's
  stationary point ``y* = c m / sqrt(1 + m^2)`` (``m`` its slope) that lies
  before the line's end; a handful of steps at most, each a pass over the
  rollers.

A preloaded row (no feasible ``y``) keeps the least-pressed ``v`` as a start
for its cam's own equilibrium (:meth:`~corr_cad.mechanics.drive.drive.DriveSolver._row_centre`):
the golden-section maximum of the slice's width, one evaluation an iteration.

One position costs a few microseconds: about the force solve's own cost per
position. The answers agree with the golden-section and bisection search this
replaces to round-off (``tests/test_free_play.py``, 20 seeded drives).
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.row.mc_kernel import _jit, _jit_inner

__all__ = ["free_rows"]

#: ``|n_x|`` below which a roller's normal counts as along the eccentric.
FLAT = 1e-9
#: The golden-section iterations of the preloaded row's start: its width
#: ``2 c 0.618^60``, 6e-13 of the clearance.
_GOLDEN = 60
_RATIO = 0.5 * (math.sqrt(5.0) - 1.0)


@_jit_inner
def _width(y, A, M, nr, B, N, nl, fg, fy, nf):
    """The slice's width at ``v_y = y`` (>= 0 where not empty), ``min(x_r - x_l, 1e300,
    -press)``, and its ends ``x_l``, ``x_r``."""
    xr, xl, press = np.inf, -np.inf, -np.inf
    for i in range(nr):
        xr = min(xr, A[i] + M[i] * y)
    for j in range(nl):
        xl = max(xl, B[j] + N[j] * y)
    for f in range(nf):
        press = max(press, fy[f] * y + fg[f])
    return min(min(xr - xl, 1e300), -press), xl, xr


@_jit_inner
def _golden_centre(c, A, M, nr, B, N, nl, fg, fy, nf):
    """The least-pressed ``v`` of a preloaded row: the golden-section argmax of the
    slice's width over ``[-c, c]`` (concave) and its slice's middle; a Newton's start."""
    lo, hi = -c, c
    x1, x2 = hi - _RATIO * (hi - lo), lo + _RATIO * (hi - lo)
    f1 = _width(x1, A, M, nr, B, N, nl, fg, fy, nf)[0]
    f2 = _width(x2, A, M, nr, B, N, nl, fg, fy, nf)[0]
    for _ in range(_GOLDEN):
        if f1 >= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - _RATIO * (hi - lo)
            f1 = _width(x1, A, M, nr, B, N, nl, fg, fy, nf)[0]
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + _RATIO * (hi - lo)
            f2 = _width(x2, A, M, nr, B, N, nl, fg, fy, nf)[0]
    y = 0.5 * (lo + hi)
    _, xl, xr = _width(y, A, M, nr, B, N, nl, fg, fy, nf)
    if math.isfinite(xl + xr):
        x = 0.5 * (xl + xr)
    elif math.isfinite(xl):
        x = xl
    elif math.isfinite(xr):
        x = xr
    else:
        x = 0.0
    return x, y


@_jit_inner
def _feasible_y(c, tol, A, M, nr, B, N, nl, fg, fy, nf):
    """``[y1, y2]``: the ``y`` in ``[-c, c]`` whose slice is not empty to ``tol``
    (right lines ``A + M y``, left lines ``B + N y``, flat rollers ``fy y + fg <= tol``)."""
    y1, y2 = -c, c
    for i in range(nr):
        for j in range(nl):
            alpha, beta = A[i] - B[j], M[i] - N[j]
            if beta > 0.0:
                y1 = max(y1, (-tol - alpha) / beta)
            elif beta < 0.0:
                y2 = min(y2, (-tol - alpha) / beta)
            elif alpha < -tol:
                return 1.0, -1.0
    for f in range(nf):
        if fy[f] > 0.0:
            y2 = min(y2, (tol - fg[f]) / fy[f])
        elif fy[f] < 0.0:
            y1 = max(y1, (tol - fg[f]) / fy[f])
        elif fg[f] > tol:
            return 1.0, -1.0
    return y1, y2


@_jit_inner
def _envelope_max(c, y1, y2, A, M, n):
    """``max over [y1, y2] of min_k (A_k + M_k y) + sqrt(c^2 - y^2)`` (``inf`` for no line).

    Concave: walk the lower envelope from ``y1``; on the piece of line ``i``
    the maximum is its stationary point clamped to the piece, and the first
    piece whose stationary point does not pass the piece's end holds the
    maximum of the whole.
    """
    if n == 0:
        return np.inf
    p = y1
    i = 0
    best = np.inf
    for k in range(n):  # the lowest line at y1; of equal ones the least slope
        v = A[k] + M[k] * p
        if v < best or (v == best and M[k] < M[i]):
            best, i = v, k
    for _ in range(n + 1):
        q, nxt = y2, -1
        for k in range(n):  # where a line of lesser slope passes below line i
            if M[k] < M[i]:
                y = (A[k] - A[i]) / (M[i] - M[k])
                if y > p and (y < q or (y == q and nxt >= 0 and M[k] < M[nxt])):
                    q, nxt = y, k
        m = M[i]
        ys = c * m / math.sqrt(1.0 + m * m) if math.isfinite(m) else math.copysign(c, m)
        if ys < q or nxt < 0:
            y = min(max(ys, p), q)
            return A[i] + m * y + math.sqrt(max(c * c - y * y, 0.0))
        p, i = q, nxt
    y = p
    return A[i] + M[i] * y + math.sqrt(max(c * c - y * y, 0.0))


@_jit
def _free_rows(g, n, c, e, want_centre, rev, fwd, centre):
    P, R = g.shape
    A, M = np.empty(R), np.empty(R)
    B, N = np.empty(R), np.empty(R)
    nB, nN = np.empty(R), np.empty(R)
    fg, fy = np.empty(R), np.empty(R)
    for p in range(P):
        nr, nl, nf = np.int64(0), np.int64(0), np.int64(0)
        big = 0.0
        for k in range(R):
            gg, nx, ny = g[p, k], n[p, k, 0], n[p, k, 1]
            if not math.isfinite(gg):
                continue  # no constraint (a roller that cannot load)
            big = max(big, abs(gg))
            if nx > FLAT:
                A[nr], M[nr] = -gg / nx, -ny / nx
                nr += 1
            elif nx < -FLAT:
                B[nl], N[nl] = -gg / nx, -ny / nx
                nB[nl], nN[nl] = gg / nx, ny / nx  # the negated left lines: -x_l
                nl += 1
            else:
                fg[nf], fy[nf] = gg, ny
                nf += 1
        tol = 1e-12 * (c + big)
        y1, y2 = _feasible_y(c, tol, A, M, nr, B, N, nl, fg, fy, nf)
        if y1 <= y2:
            fwd[p] = _envelope_max(c, y1, y2, A, M, nr) / e
            rev[p] = -_envelope_max(c, y1, y2, nB, nN, nl) / e
        else:
            fwd[p], rev[p] = -np.inf, np.inf
        if want_centre and not fwd[p] > rev[p]:  # a locked row's start (the only one used)
            centre[p, 0], centre[p, 1] = _golden_centre(c, A, M, nr, B, N, nl, fg, fy, nf)


def free_rows(g, n, half_clearance: float, e: float, want_centre: bool = False):
    """``(rev, fwd)`` (P,) of one row with a clearance ``half_clearance > 0``: ``g``
    (P, R) the rollers' gaps (``-inf``: no constraint), ``n`` (P, R, 2) their normals.
    With ``want_centre`` also the start ``v`` (P, 2) of a locked row's cam (zeros where
    the row turns freely); see the module's text."""
    g = np.ascontiguousarray(g, dtype=float)
    n = np.ascontiguousarray(n, dtype=float)
    P = g.shape[0]
    rev, fwd, centre = np.empty(P), np.empty(P), np.zeros((P, 2))
    _free_rows(g, n, float(half_clearance), float(e), bool(want_centre), rev, fwd, centre)
    return (rev, fwd, centre) if want_centre else (rev, fwd)
