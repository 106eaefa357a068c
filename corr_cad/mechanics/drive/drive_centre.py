"""Compiled Newton for the cam centre a preloaded row's own rollers hold.

:meth:`DriveSolver._row_centre <corr_cad.mechanics.drive.drive.DriveSolver>` finds,
at each position of a row left with no free rotation, the cam centre ``v``
where its rollers' forces balance with no bearing load,
``sum_k F_k(g_k + n_k . v) n_k = 0``: Newton on ``v`` with the 2 x 2 tangent
``sum_k dF_k/dh n_k n_k^T`` (regularised by ``1e-12`` of its trace and
``1e-9``), backtracking (halving the step until the residual's norm falls by
``1e-4`` of the step fraction, at most 40 times), each position until
``|r| <= DRIVE_RTOL sum_k F_k``. Here the same iteration runs position by
position in a compiled loop over the row's own rollers (the numpy method
evaluates the law over both rows' columns and every position still going);
the contact laws are the drive kernel's (:func:`corr_cad.mechanics.drive.drive_laws._invert_one`
for the paper's, :func:`~corr_cad.mechanics.drive.drive_laws._palmgren` for
Palmgren's). The sums and the 2 x 2 solve are taken in another order than
numpy's, so the centres agree with the numpy method's to round-off
(``tests/test_drive_centre.py``: 1e-12 relative on seeded drives).
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.drive.drive_laws import _invert_one, _palmgren
from corr_cad.mechanics.row.mc_kernel import _jit, _jit_inner

__all__ = ["row_centres"]


@_jit_inner
def _residual(p, gap, n, ux, uy, law, T, K, slope0, F, k):
    """Row forces ``F``, stiffnesses ``k`` (R,) at centre ``(ux, uy)`` of position ``p``;
    returns the residual ``sum F n`` and ``sum F``."""
    rx, ry, total = 0.0, 0.0, 0.0
    for i in range(gap.shape[1]):
        h = gap[p, i] + (n[p, i, 0] * ux + n[p, i, 1] * uy)
        if law == 0:
            if not h > 0.0:
                f, s = 0.0, 0.0
            else:
                f, s = _invert_one(h, h / slope0[p, i], T, p, i)
        else:
            f, s = _palmgren(h, K[p, i])
        F[i], k[i] = f, s
        rx += f * n[p, i, 0]
        ry += f * n[p, i, 1]
        total += f
    return rx, ry, total


@_jit
def _centres(gap, n, v, law, T, K, slope0, rtol):
    """Settle each position's centre ``v`` (m, 2) in place (see the module text)."""
    m, R = gap.shape
    F, k = np.empty(R), np.empty(R)
    for p in range(m):
        ux, uy = v[p, 0], v[p, 1]
        rx, ry, total = _residual(p, gap, n, ux, uy, law, T, K, slope0, F, k)
        for _ in range(100):
            norm = math.sqrt(rx * rx + ry * ry)
            if not norm > rtol * (total + 1e-300):
                break
            j00, j01, j11 = 0.0, 0.0, 0.0
            for i in range(R):
                nx, ny = n[p, i, 0], n[p, i, 1]
                j00 += k[i] * nx * nx
                j01 += k[i] * nx * ny
                j11 += k[i] * ny * ny
            reg = 1e-12 * (j00 + j11) + 1e-9
            j00 += reg
            j11 += reg
            det = j00 * j11 - j01 * j01
            sx = -(j11 * rx - j01 * ry) / det
            sy = -(j00 * ry - j01 * rx) / det
            alpha = 1.0
            for _ in range(40):
                rx, ry, total = _residual(
                    p, gap, n, ux + alpha * sx, uy + alpha * sy, law, T, K, slope0, F, k
                )
                if math.sqrt(rx * rx + ry * ry) <= (1.0 - 1e-4 * alpha) * norm:
                    break
                alpha *= 0.5
            ux += alpha * sx
            uy += alpha * sy
        v[p, 0], v[p, 1] = ux, uy


def row_centres(
    solver,
    c: int,
    idx: np.ndarray,
    v: np.ndarray,
    rtol: float,
    table: np.ndarray | None,
    rows: tuple | None = None,
) -> np.ndarray:
    """:meth:`DriveSolver._row_centre` compiled: row ``c``'s cam centres (len(idx), 2) at
    positions ``idx`` from the starts ``v``; ``table``: the paper's law's contacts (11,
    P * N) (:class:`~corr_cad.mechanics.drive.drive_kernel.CompiledInverse`), None for
    Palmgren's."""
    R, geo, comp = solver.R, solver.geo_joined, solver.comp
    P, N = geo.gap.shape
    sl = slice(c * R, (c + 1) * R)
    if rows is not None and table is None:  # the row's gaps, directions and factors given
        gap, n, K = rows
        if len(idx) < P:
            gap, n, K = gap[idx], n[idx], K[idx]
        gap, n, K = (np.ascontiguousarray(x, dtype=float) for x in (gap, n, K))
        out = np.array(v, dtype=float)
        _centres(gap, n, out, 1, np.zeros((11, 1, 1)), K, K, float(rtol))
        return out
    gap = np.ascontiguousarray(np.where(geo.loadable, geo.gap, -1e300)[idx][:, sl])
    n = np.ascontiguousarray(solver.n[idx][:, sl])
    if table is None:
        law, T = 1, np.zeros((11, 1, 1))
        K = np.ascontiguousarray(np.broadcast_to(comp.K, (P, N))[idx][:, sl], dtype=float)
        slope0 = K
    else:
        law, K = 0, np.zeros((1, 1))
        T = table.reshape(11, P, N)[:, idx][:, :, sl]
        T = np.ascontiguousarray(T)
        slope0 = np.broadcast_to(comp.slope0, (P, N))[idx][:, sl]
        slope0 = np.ascontiguousarray(slope0, dtype=float)
    out = np.array(v, dtype=float)
    _centres(gap, n, out, law, T, K, slope0, float(rtol))
    return out
