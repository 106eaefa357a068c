"""Compiled Monte Carlo kernel of the datasheet metrics: each sample's windup, crank locked.

For every sample and every position of the evaluation grid the kernel builds
the sample's contact table once (the same gaps and compliances as
:mod:`corr_cad.mechanics.row.mc_kernel`, i.e. as the force solver) and then solves
the cam rotation at several cam moments with the same numerics
(:func:`corr_cad.mechanics.row.mc_kernel._solve_position`). The windup of an
output torque ``T`` is ``-tau / (z + 1)`` for the cam moment
``-load_share T / (z + 1)`` (:mod:`corr_cad.mechanics.row.windup`). At ``T = +-0``
it is an end of the free rotation, from the gaps alone, as
:meth:`corr_cad.mechanics.row.windup.Windup.free_ends`.

It also evaluates the gap-only binding of :mod:`corr_cad.mechanics.binding`
(the preload pressure where the free rotation is empty), so that the Monte
Carlo reads every datasheet metric off one pass over the sample's positions.
Results agree with :class:`~corr_cad.mechanics.row.windup.Windup` and
:func:`~corr_cad.mechanics.binding.binding` to round-off
(``tests/test_mc_datasheet.py``).
"""

from __future__ import annotations

import numpy as np

from corr_cad.mechanics.row.mc_kernel import (
    FIELDS,
    H0,
    K0,
    A,
    _fill_table,
    _free_ends,
    _invert,
    _jit,
    _jit_inner,
    _relative_residual,
    _roller_pressure,
    _solve_position,
)

__all__ = ["windup_samples"]


@_jit_inner
def _preload_pressure(C, kc, gap, R, length, floor):
    """Gap-only preload pressure (MPa) at one position where the free rotation is empty.

    ``tau*`` minimises the largest overlap ``max_i (gap_i + a_i tau)`` of the
    rollers (where the largest overlap of the rollers with ``a > 0`` meets
    that of ``a < 0``); each roller's chain is compressed by its overlap there
    and the force follows from its elastic approach ``G(F) = h``. Returns the
    largest Hertz pressure of any contact, or ``floor`` when it is not above
    ``floor`` (the sample's largest so far: a roller whose linear-contact force
    ``h / G'(0)``, an upper bound of its force since ``G`` is convex, cannot
    reach ``floor`` is not inverted), and the overlap at ``tau*`` (mm).
    """
    lo, hi = _free_ends(C, gap)  # first closing forward (a > 0), in reverse (a < 0)
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
        return floor, 0.0
    # Safeguarded Newton on the piecewise-linear up - down: intersect the two
    # active lines; bisect where that leaves the bracket [a_lo, a_hi].
    a_lo, a_hi = lo, hi
    tau = lo
    for _ in range(200):
        up = -np.inf
        down = -np.inf
        iu = -1
        idn = -1
        for i in range(R):
            a = C[A, i]
            if a > 0.0:
                v = gap[i] + a * tau
                if v > up:
                    up, iu = v, i
            elif a < 0.0:
                v = gap[i] + a * tau
                if v > down:
                    down, idn = v, i
        if up < down:
            a_lo = tau
        elif up > down:
            a_hi = tau
        else:
            break
        nxt = (gap[idn] - gap[iu]) / (C[A, iu] - C[A, idn])
        if not (a_lo < nxt < a_hi):
            nxt = 0.5 * (a_lo + a_hi)
        if nxt == tau or not (a_lo < nxt < a_hi):
            break
        tau = nxt
    scale = np.pi * length / 2.0  # p = sqrt(F / c) / scale
    top = floor * scale
    over = 0.0
    for i in range(R):
        h = tau * C[A, i] + C[H0, i]
        over = max(over, h)
        if h <= 0.0:
            continue
        f = h / C[K0, i]  # linear-contact force: an upper bound
        if _roller_pressure(C, i, f) <= top:
            continue
        f = _invert(f, h, C, i, kc)  # G(f) = h, monotone Newton from the right
        top = max(top, _roller_pressure(C, i, f))
    return top / scale, over


@_jit
def windup_samples(
    psi,
    s,
    rho_n,
    rho_s,
    a_nom,
    loadable,
    kg_nom,
    pd,
    cam_err,
    ecc_err,
    phase_err,
    dr_all,
    dl_all,
    e,
    L,
    z,
    r,
    Rj,
    length,
    modulus,
    moments,
    zero_sign,
    rtol,
    theta_out,
    backlash_out,
    pressure_out,
    interference_out,
    rel_out,
):
    """Windup of every sample at every position and cam moment; gap-only binding.

    Nominal arrays (P, R) and per-sample errors as
    :func:`corr_cad.mechanics.row.mc_kernel.solve_samples`. ``moments`` (M,): cam
    moments (solver sign) to solve; where ``zero_sign[j]`` is ``-1`` or
    ``+1`` the column is the end ``theta(0-)`` or ``theta(0+)`` of the free
    rotation instead (``0``: solve ``moments[j]``).

    Outputs: ``theta_out`` (n, P, M) windup, rad; ``backlash_out`` (n,) the
    largest free rotation of the output, rad; ``pressure_out`` (n,) the
    largest gap-only preload pressure, MPa, and ``interference_out`` (n,) the
    largest overlap at the best rotation, mm (0 where the free rotation is
    not empty); ``rel_out`` (n,) worst relative moment residual, ``inf``
    where a moment could not be carried.
    """
    n = cam_err.shape[0]
    P, R = psi.shape
    M = moments.shape[0]
    c0 = np.pi * length * modulus
    C = np.empty((FIELDS, R))
    W = np.zeros((5, R))
    gap = np.empty(R)
    bp = np.empty(R)
    order = np.empty(R, dtype=np.int64)
    ratio = float(R)
    for k in range(n):
        worst = 0.0
        lost = 0.0
        press = 0.0
        inter = 0.0
        for p in range(P):
            kc = _fill_table(
                C, gap, k, p, psi, s, rho_n, rho_s, a_nom, loadable, kg_nom, pd, cam_err,
                ecc_err, phase_err, dr_all, dl_all, e, L, z, r, Rj, c0,
            )  # fmt: skip
            # Free rotation from the gaps (Windup.free_ends).
            fwd, rev = _free_ends(C, gap)
            tight = fwd <= rev
            if np.isfinite(fwd) and np.isfinite(rev):
                lost = max(lost, max(fwd - rev, 0.0) / ratio)
            if tight:
                press, ov = _preload_pressure(C, kc, gap, R, length, press)
                inter = max(inter, ov)
            zero_theta = np.nan
            for j in range(M):
                sg = zero_sign[j]
                if sg != 0 and not tight:
                    theta_out[k, p, j] = -fwd / ratio if sg < 0 else -rev / ratio
                    continue
                if sg != 0 and zero_theta == zero_theta:
                    theta_out[k, p, j] = zero_theta
                    continue
                target = moments[j]
                tau, ok = _solve_position(C, kc, W, order, bp, target, rtol)
                if not ok:
                    worst = np.inf
                    theta_out[k, p, j] = np.nan
                    continue
                worst = max(worst, _relative_residual(C, W, gap, tau, target))
                theta_out[k, p, j] = -tau / ratio
                if sg != 0:
                    zero_theta = -tau / ratio
        backlash_out[k] = lost
        pressure_out[k] = press
        interference_out[k] = inter
        rel_out[k] = worst
