"""The drive kernels' contact laws, compiled, for one roller or one needle.

:func:`_invert_one` inverts the paper's contact law (three contacts in series,
``G(F) = h``) by Newton for one roller (the compiled Monte Carlo kernel's law,
:func:`corr_cad.mechanics.row.mc_kernel._approach`); :func:`_palmgren` is
Palmgren's line contact ``delta = c Q^0.9`` solved for ``Q``
(:mod:`corr_cad.mechanics.palmgren`). The drive's bearing Newton
(:mod:`corr_cad.mechanics.drive.drive_kernel`) and the preloaded row's cam centre
(:mod:`corr_cad.mechanics.drive.drive_centre`) both call them.
"""

from __future__ import annotations

from corr_cad.mechanics.row.mc_kernel import _approach, _jit_inner

__all__ = ["_invert_one", "_palmgren"]

# Rows of the per-roller table: cam, gear and slot contacts (b^2 per unit force,
# weight, curvatures, knee).
CJ, K1, KC, UKJ, CN, WN, KG, UKN, CS, WS, UKS = range(11)

_EXP = 0.9  # palmgren.PALMGREN_FORCE_EXPONENT


@_jit_inner
def _invert_one(hi, f, T, p, i):
    """``(F, dF/dh)`` of roller ``i`` of position ``p`` at overlap ``hi > 0`` by Newton
    from ``f`` (``T`` (11, P, N): the contacts' table, a column per position and roller;
    indexed in place, not sliced: a view per call is one more type to compile)."""
    cj, k1, kc, ukj = T[CJ, p, i], T[K1, p, i], T[KC, p, i], T[UKJ, p, i]
    cn, wn, kg, ukn = T[CN, p, i], T[WN, p, i], T[KG, p, i], T[UKN, p, i]
    cs, ws, uks = T[CS, p, i], T[WS, p, i], T[UKS, p, i]
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
    # G' of the last iterate: within 1e-15 of the force's own (the step was below it).
    return f, (1.0 / dg if f > 0.0 else 0.0)


@_jit_inner
def _palmgren(d, c):
    """``(Q, dQ/d delta)`` of ``delta = c Q^0.9`` (both 0 for ``delta <= 0``)."""
    if not d > 0.0:
        return 0.0, 0.0
    q = (d / c) ** (1.0 / _EXP)
    return q, q / (_EXP * d)
