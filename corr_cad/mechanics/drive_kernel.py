"""Compiled inversion of the paper's contact law for the drive's bearing Newton.

:class:`~corr_cad.mechanics.drive.DriveSolver` finds each roller's force
``F`` from its overlap ``h`` (``G(F) = h``, ``G`` the three contacts in
series) at every step of its Newton on ``(tau, u_A, u_B)``. The numpy
inversion (:func:`corr_cad.mechanics.drive_numerics._invert_convex`) iterates
every roller until the slowest one settles and builds some twenty temporaries
per iteration; here each roller is inverted on its own, in a compiled loop,
with the same Newton from the same start and the same stop (a step below
``1e-15`` of its force). The contact law is the one of the compiled Monte
Carlo kernel (:func:`corr_cad.mechanics.mc_kernel._approach`). The forces
agree with the numpy inversion to round-off (a roller stops when it has
settled, not when the slowest has), so a drive solved with it agrees with
the numpy one to the bearing Newton's tolerance; the drive's Monte Carlo
uses it (``tests/test_montecarlo_drive.py``).
"""

from __future__ import annotations

import numpy as np

from corr_cad.mechanics.mc_kernel import _approach, _jit

__all__ = ["CompiledInverse"]

# Rows of the per-roller table: cam, gear and slot contacts (b^2 per unit force,
# weight, curvatures, knee).
CJ, K1, KC, UKJ, CN, WN, KG, UKN, CS, WS, UKS = range(11)


@_jit
def _invert(h, start, T, F_out, k_out):
    """``F`` with ``G(F) = h`` (0 where ``h <= 0``) and ``dF/dh`` per roller (flat arrays)."""
    for i in range(h.shape[0]):
        hi = h[i]
        if not hi > 0.0:
            F_out[i] = 0.0
            k_out[i] = 0.0
            continue
        cj, k1, kc, ukj = T[CJ, i], T[K1, i], T[KC, i], T[UKJ, i]
        cn, wn, kg, ukn = T[CN, i], T[WN, i], T[KG, i], T[UKN, i]
        cs, ws, uks = T[CS, i], T[WS, i], T[UKS, i]
        f = start[i]
        dg = 1.0
        for _ in range(60):
            vj, sj = _approach(cj * f, ukj, k1, kc)
            vn, sn = _approach(cn * f, ukn, k1, kg)
            vs, ss = _approach(cs * f, uks, k1, 0.0)
            g = vj + wn * vn + ws * vs
            dg = cj * sj + wn * cn * sn + ws * cs * ss
            step = (g - hi) / dg
            f = max(f - step, 0.0)
            if abs(step) <= 1e-15 * f + 1e-300:
                break
        vj, sj = _approach(cj * f, ukj, k1, kc)
        vn, sn = _approach(cn * f, ukn, k1, kg)
        vs, ss = _approach(cs * f, uks, k1, 0.0)
        dg = cj * sj + wn * cn * sn + ws * cs * ss
        F_out[i] = f
        k_out[i] = 1.0 / dg if f > 0.0 else 0.0


class CompiledInverse:
    """``(F, dF/dh)`` at overlaps ``h`` (P, N) for a compliance of the paper's law
    (:class:`~corr_cad.mechanics.solver_numerics._Compliance`, ``model = "nonlinear"``)."""

    def __init__(self, comp, shape: tuple[int, int]):
        cam, gear, slot = comp.contacts

        def full(x):
            return np.broadcast_to(np.asarray(x, dtype=float), shape).reshape(-1)

        self.table = np.ascontiguousarray(
            np.stack(
                [
                    full(cam.cw),
                    full(cam.k1),
                    full(cam.k2),
                    full(cam.uk),
                    full(gear.cw),
                    full(gear.w),
                    full(gear.k2),
                    full(gear.uk),
                    full(slot.cw),
                    full(slot.w),
                    full(slot.uk),
                ]
            )
        )
        self.shape = shape

    def __call__(self, h: np.ndarray, start: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.table.shape[1]
        F, k = np.empty(n), np.empty(n)
        _invert(
            np.ascontiguousarray(h, dtype=float).reshape(-1),
            np.ascontiguousarray(start, dtype=float).reshape(-1),
            self.table,
            F,
            k,
        )
        return F.reshape(self.shape), k.reshape(self.shape)
