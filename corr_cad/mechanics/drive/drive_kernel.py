"""Compiled inversion of the paper's contact law for the drive's bearing Newton.

:class:`~corr_cad.mechanics.drive.drive.DriveSolver` finds each roller's force
``F`` from its overlap ``h`` (``G(F) = h``, ``G`` the three contacts in
series) at every step of its Newton on ``(tau, u_A, u_B)``. The numpy
inversion (:func:`corr_cad.mechanics.drive.drive_numerics._invert_convex`) iterates
every roller until the slowest one settles and builds some twenty temporaries
per iteration; here each roller is inverted on its own, in a compiled loop,
with the same Newton from the same start and the same stop (a step below
``1e-15`` of its force). The contact law is the one of the compiled Monte
Carlo kernel (:func:`corr_cad.mechanics.row.mc_kernel._approach`). The forces
agree with the numpy inversion to round-off (a roller stops when it has
settled, not when the slowest has), so a drive solved with it agrees with
the numpy one to the bearing Newton's tolerance; the drive's Monte Carlo
uses it (``tests/test_montecarlo_drive.py``).

The bearing Newton (:func:`bearing_newton`) sums in scalars, each cam's rollers in
turn, in the order of one loop over both cams (the same bits), and allocates no
scratch array a call. Its time is mostly the contact law's powers (``Q^(1/0.9)``,
one a loaded roller or needle and evaluation).
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.drive.drive import DRIVE_RTOL, DriveSolver
from corr_cad.mechanics.drive.drive_laws import _invert_one, _palmgren
from corr_cad.mechanics.row.mc_kernel import _jit, _jit_inner

__all__ = ["CompiledInverse", "CompiledDriveSolver", "bearing_solve", "loadable_arrays"]


@_jit
def _invert(h, start, T, F_out, k_out):
    """``F`` with ``G(F) = h`` (0 where ``h <= 0``) and ``dF/dh`` per position and roller
    ((P, N) arrays; ``T`` (11, P, N))."""
    for p in range(h.shape[0]):
        for i in range(h.shape[1]):
            if not h[p, i] > 0.0:
                F_out[p, i] = 0.0
                k_out[p, i] = 0.0
            else:
                F_out[p, i], k_out[p, i] = _invert_one(h[p, i], start[p, i], T, p, i)


class CompiledInverse:
    """``(F, dF/dh)`` at overlaps ``h`` (P, N) for a compliance of the paper's law
    (:class:`~corr_cad.mechanics.row.solver_numerics._Compliance`, ``model = "nonlinear"``)."""

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
        F, k = np.empty(self.shape), np.empty(self.shape)
        _invert(
            np.ascontiguousarray(np.broadcast_to(h, self.shape), dtype=float),
            np.ascontiguousarray(np.broadcast_to(start, self.shape), dtype=float),
            self.table.reshape(11, *self.shape),
            F,
            k,
        )
        return F, k


# ---------------------------------------------------------------- the bearing Newton

_IDLE = 1e-9  # drive._IDLE_FORCE
_MAX_STEP = 1e-2  # drive._MAX_TAU_STEP, drive._MAX_U_STEP


@_jit_inner
def _copy1(dst, src):
    """``dst[:] = src`` as a loop (a slice assignment costs LLVM far more to compile)."""
    for i in range(dst.shape[0]):
        dst[i] = src[i]


@_jit_inner
def _copy2(dst, src):
    """``dst[:, :] = src`` as a loop."""
    for i in range(dst.shape[0]):
        for j in range(dst.shape[1]):
            dst[i, j] = src[i, j]


@_jit_inner
def _state(p, tau, u, geo, law, T, K, slope0, target, prev, w, r):
    """Roller overlaps, forces and stiffnesses at ``(tau, u)`` of position ``p``, and
    the residual ``r`` (5,) less the needles' share (:func:`_needles` adds it).

    ``geo`` (5, P, N): advance, arm, gap (-1e300 where not loadable), n_x, n_y;
    ``w`` (4, N) out: h, F, dF/dh, gross overlap x stiffness; ``prev``: the last
    state's ``w`` (its loaded rollers start from the tangent), NaN for the first.
    """
    N = geo.shape[2]
    R = N // 2
    first = math.isnan(prev[0, 0])
    r0 = -target  # the sums in scalars, each cam's rollers in turn (one loop's order)
    for c in range(2):
        ux, uy = u[c, 0], u[c, 1]
        rx, ry = 0.0, 0.0
        for i in range(c * R, (c + 1) * R):
            a, h0 = geo[0, p, i], geo[2, p, i]
            nx, ny = geo[3, p, i], geo[4, p, i]
            nu = nx * ux + ny * uy
            h = a * tau + h0 + nu
            if law == 0:
                if not h > 0.0:
                    F, k = 0.0, 0.0
                else:
                    start = h / slope0[p, i]
                    if not first and prev[1, i] > 0.0:
                        start = max(prev[1, i] + (h - prev[0, i]) * prev[2, i], 0.0)
                    F, k = _invert_one(h, start, T, p, i)
            else:
                F, k = _palmgren(h, K[p, i])
            w[0, i], w[1, i], w[2, i] = h, F, k
            w[3, i] = (abs(a * tau) + abs(h0) + abs(nu)) * k if h0 > -1e300 else 0.0
            r0 += geo[1, p, i] * F
            rx += F * nx
            ry += F * ny
        r[1 + 2 * c], r[2 + 2 * c] = rx, ry
    r[0] = r0


@_jit_inner
def _needles(u, dirs, bear, Q, kq, gq, r):
    """Each cam's needle loads ``Q`` (2, Z), stiffness and gross terms; subtracts
    ``sum_j Q_j e_j`` from the cams' force residuals ``r[1:5]``."""
    Z = dirs.shape[1]
    for c in range(2):
        ux, uy = u[c, 0], u[c, 1]
        norm_u = math.sqrt(ux**2 + uy**2)
        half, coef, gross = bear[c, 0], bear[c, 1], norm_u + bear[c, 2]
        rx, ry = r[1 + 2 * c], r[2 + 2 * c]
        for j in range(Z):
            ex, ey = dirs[c, j, 0], dirs[c, j, 1]
            d = -(ux * ex + uy * ey) - half
            q, k = _palmgren(d, coef)
            Q[c, j], kq[c, j] = q, k
            gq[c, j] = k * gross
            rx -= q * ex
            ry -= q * ey
        r[1 + 2 * c], r[2 + 2 * c] = rx, ry


@_jit_inner
def _relative(r, w, geo, p, Q, gq, target, e):
    """The residual relative to the round-off of its terms (drive.DriveSolver._relative)."""
    N = w.shape[1]
    R = N // 2
    sm = abs(target)
    sf0, sf1 = 0.0, 0.0  # the cams' force scales (scalars: no array a call)
    for i in range(R):
        sm += (abs(geo[1, p, i]) + e) * abs(w[1, i]) + abs(geo[1, p, i]) * w[3, i]
        sf0 += w[1, i] + w[3, i]
    for i in range(R, N):
        sm += (abs(geo[1, p, i]) + e) * abs(w[1, i]) + abs(geo[1, p, i]) * w[3, i]
        sf1 += w[1, i] + w[3, i]
    for j in range(Q.shape[1]):
        sf0 += Q[0, j] + gq[0, j]
    for j in range(Q.shape[1]):
        sf1 += Q[1, j] + gq[1, j]
    rel = abs(r[0]) / (sm + 1e-300)
    top = max(sf0, sf1)  # an unloaded cam: against the loaded one's forces (drive._scales)
    for c in range(2):
        rel = max(rel, math.sqrt(r[1 + 2 * c] ** 2 + r[2 + 2 * c] ** 2) / (top + 1e-300))
    return rel


@_jit_inner
def _rest_idle(p, t, u, geo, law, T, K, slope0, target, w, r, Q, kq, gq, sf, rtol, e, tmp):
    """Settle the cams that carry nothing (drive.DriveSolver._rest_idle_cams): True, and
    the settled state in ``u, w, r, Q, kq, gq``, when the position is then converged.
    ``tmp``: scratch ``(ut (2, 2), wt (4, N), rt (5,), Qt, kqt, gqt (2, Z))``."""
    ut, wt, rt, Qt, kqt, gqt = tmp
    N = w.shape[1]
    R = N // 2
    carried0, carried1 = 0.0, 0.0
    for i in range(R):
        carried0 += w[1, i]
    for j in range(Q.shape[1]):
        carried0 += Q[0, j]
    for i in range(R, N):
        carried1 += w[1, i]
    for j in range(Q.shape[1]):
        carried1 += Q[1, j]
    if not (carried0 <= rtol * sf or carried1 <= rtol * sf):
        return False  # both cams carry: nothing to settle (no scratch made)
    tiny = np.zeros(2, dtype=np.bool_)
    tiny[0], tiny[1] = carried0 <= rtol * sf, carried1 <= rtol * sf
    _copy2(ut, u)
    for c in range(2):
        if tiny[c]:
            ut[c, 0], ut[c, 1] = 0.0, 0.0
    _state(p, t, ut, geo, law, T, K, slope0, target, w, wt, rt)  # the idle cams centred
    centred = np.zeros(2, dtype=np.bool_)
    for c in range(2):
        pressed = 0.0
        for i in range(c * R, (c + 1) * R):
            pressed += wt[1, i]
        centred[c] = tiny[c] and pressed <= rtol * sf
    _copy2(wt, w)
    _copy1(rt, r)
    _copy2(Qt, Q)
    _copy2(kqt, kq)
    _copy2(gqt, gq)
    _copy2(ut, u)
    for c in range(2):
        if not tiny[c]:
            continue
        if centred[c]:
            ut[c, 0], ut[c, 1] = 0.0, 0.0
        for i in range(c * R, (c + 1) * R):
            wt[1, i], wt[2, i], wt[3, i] = 0.0, 0.0, 0.0
        for j in range(Qt.shape[1]):
            Qt[c, j], kqt[c, j], gqt[c, j] = 0.0, 0.0, 0.0
        rt[1 + 2 * c], rt[2 + 2 * c] = 0.0, 0.0
    rt[0] = -target
    for i in range(N):
        rt[0] += geo[1, p, i] * wt[1, i]
    if not _relative(rt, wt, geo, p, Qt, gqt, target, e) <= rtol:
        return False
    _copy2(u, ut)
    _copy2(w, wt)
    _copy1(r, rt)
    _copy2(Q, Qt)
    _copy2(kq, kqt)
    _copy2(gq, gqt)
    return True


@_jit_inner
def _merit(r, sm, sf):
    return (r[0] / sm) ** 2 + (
        (r[1] / sf) ** 2 + (r[2] / sf) ** 2 + (r[3] / sf) ** 2 + (r[4] / sf) ** 2
    )


@_jit_inner
def _solve5(J, b, x):
    """``x = J^-1 b`` by Gaussian elimination with partial pivoting (J, b overwritten)."""
    n = 5
    for col in range(n):
        piv = col
        for row in range(col + 1, n):
            if abs(J[row, col]) > abs(J[piv, col]):
                piv = row
        if piv != col:
            for k in range(n):
                J[col, k], J[piv, k] = J[piv, k], J[col, k]
            b[col], b[piv] = b[piv], b[col]
        for row in range(col + 1, n):
            f = J[row, col] / J[col, col]
            for k in range(col, n):
                J[row, k] -= f * J[col, k]
            b[row] -= f * b[col]
    for row in range(n - 1, -1, -1):
        s = b[row]
        for k in range(row + 1, n):
            s -= J[row, k] * x[k]
        x[row] = s / J[row, row]


@_jit_inner
def _slope_at(p, t, u, d, a, geo, law, T, K, slope0, target, w, bear, dirs, out):
    """The energy's slope ``r(x + a d) . d`` along ``d`` at step ``a``; the state there in
    ``out = (u, w, r, Q, kq, gq)``."""
    ut, wt, rt, Qt, kqt, gqt = out
    for c in range(2):
        ut[c, 0] = u[c, 0] + a * d[1 + 2 * c]
        ut[c, 1] = u[c, 1] + a * d[2 + 2 * c]
    _state(p, t + a * d[0], ut, geo, law, T, K, slope0, target, w, wt, rt)
    _needles(ut, dirs, bear, Qt, kqt, gqt, rt)
    s = 0.0
    for k in range(5):
        s += rt[k] * d[k]
    return s


@_jit_inner
def _energy_search(p, t, u, d, r, geo, law, T, K, slope0, target, w, bear, dirs, out):
    """drive_numerics.energy_search at one position: the step ``a`` along ``d`` (its state
    in ``out``), 0 where ``d`` is no descent direction or no step lowers the energy."""
    s0 = 0.0
    for k in range(5):
        s0 += r[k] * d[k]
    if not s0 < 0.0:
        return 0.0
    a = 1.0
    if not _slope_at(p, t, u, d, 1.0, geo, law, T, K, slope0, target, w, bear, dirs, out) <= 0.0:
        lo, hi = 0.0, 1.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            s = _slope_at(p, t, u, d, mid, geo, law, T, K, slope0, target, w, bear, dirs, out)
            if s < 0.0:
                lo = mid
                if s >= 0.1 * s0:
                    break
            else:
                hi = mid
        a = lo
        if not a > 0.0:
            return 0.0
        _slope_at(p, t, u, d, a, geo, law, T, K, slope0, target, w, bear, dirs, out)
    return a


@_jit
def bearing_newton(
    geo,
    law,
    T,
    K,
    slope0,
    bear,
    strib,
    dirs,
    e,
    tau,
    F0,
    target,
    rtol,
    max_iter,
    u_out,
    Q_out,
    rel_out,
):
    """The joint Newton on ``(tau, u_A, u_B)`` of every position (drive.DriveSolver's
    ``_with_bearings``, one position at a time); ``tau`` (P,) in: the rigid solution, out:
    the solution; ``F0`` (P, N) in: the rigid forces, out: the forces."""
    P, N = geo.shape[1], geo.shape[2]
    R = N // 2
    Z = dirs.shape[1]
    w = np.empty((4, N))
    wt = np.empty((4, N))
    Q, kq, gq = np.empty((2, Z)), np.empty((2, Z)), np.empty((2, Z))
    Qt, kqt, gqt = np.empty((2, Z)), np.empty((2, Z)), np.empty((2, Z))
    r, rt = np.empty(5), np.empty(5)
    u, ut = np.empty((2, 2)), np.empty((2, 2))
    J, b, step, dd = np.empty((5, 5)), np.empty(5), np.empty(5), np.empty(5)
    ls = (
        np.empty((2, 2)),
        np.empty((4, N)),
        np.empty(5),
        np.empty((2, Z)),
        np.empty((2, Z)),
        np.empty((2, Z)),
    )
    nan_prev = np.full((4, N), np.nan)
    tmp = (
        np.empty((2, 2)),
        np.empty((4, N)),
        np.empty(5),
        np.empty((2, Z)),
        np.empty((2, Z)),
        np.empty((2, Z)),
    )
    for p in range(P):
        t = tau[p]
        sm = abs(target)
        for i in range(N):
            sm += (abs(geo[1, p, i]) + e) * abs(F0[p, i])
        sm += 1e-300
        sf = sm / e
        # Start: each cam displaced along its load by the clearance and Stribeck's approach.
        for c in range(2):
            px, py = 0.0, 0.0
            for i in range(c * R, (c + 1) * R):
                px += F0[p, i] * geo[3, p, i]
                py += F0[p, i] * geo[4, p, i]
            mag = math.sqrt(px * px + py * py)
            depth = 0.5 * bear[c, 2] + bear[c, 1] * (strib[c] * mag) ** 0.9
            if mag > 0:
                u[c, 0], u[c, 1] = -px / mag * depth, -py / mag * depth
            else:
                u[c, 0], u[c, 1] = 0.0, 0.0
        _state(p, t, u, geo, law, T, K, slope0, target, nan_prev, w, r)
        _needles(u, dirs, bear, Q, kq, gq, r)
        idle = False
        if target == 0.0:
            fmax = -np.inf
            for i in range(N):
                fmax = max(fmax, w[1, i])
            idle = fmax <= _IDLE
        done = idle or _relative(r, w, geo, p, Q, gq, target, e) <= rtol
        # Each state not converged gets the idle cams settled (one call site: the
        # compiler inlines it once), then a Newton step while steps are left.
        for it in range(max_iter + 1):
            if not done:
                done = _rest_idle(
                    p, t, u, geo, law, T, K, slope0, target, w, r, Q, kq, gq, sf, rtol, e, tmp
                )
            if done or it == max_iter:
                break
            for k in range(25):
                J[k // 5, k % 5] = 0.0
            # Each cam's rollers in turn, the sums in scalars (the same order as one
            # loop over both cams: J[0, 0] runs over row A's rollers, then row B's).
            j00 = 0.0
            for c in range(2):
                a, d = 1 + 2 * c, 2 + 2 * c
                j0a, j0d, ja0, jd0, jaa, jad, jda, jdd = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                for i in range(c * R, (c + 1) * R):
                    ac, am, kf = geo[0, p, i], geo[1, p, i], w[2, i]
                    nx, ny = geo[3, p, i], geo[4, p, i]
                    j00 += am * ac * kf
                    j0a += am * kf * nx
                    j0d += am * kf * ny
                    ja0 += ac * kf * nx
                    jd0 += ac * kf * ny
                    jaa += kf * nx * nx
                    jad += kf * nx * ny
                    jda += kf * ny * nx
                    jdd += kf * ny * ny
                J[0, a], J[0, d], J[a, 0], J[d, 0] = j0a, j0d, ja0, jd0
                J[a, a], J[a, d], J[d, a], J[d, d] = jaa, jad, jda, jdd
            J[0, 0] = j00
            for c in range(2):
                a, d = 1 + 2 * c, 2 + 2 * c
                for j in range(Z):
                    ex, ey = dirs[c, j, 0], dirs[c, j, 1]
                    J[a, a] += kq[c, j] * ex * ex
                    J[a, d] += kq[c, j] * ex * ey
                    J[d, a] += kq[c, j] * ey * ex
                    J[d, d] += kq[c, j] * ey * ey
                tr = J[a, a] + J[d, d]
                J[a, a] += 1e-12 * tr + 1e-9
                J[d, d] += 1e-12 * tr + 1e-9
            # The crank's floor, as the cams' (drive.DriveSolver._with_bearings).
            J[0, 0] += e * e * (1e-12 * (J[1, 1] + J[2, 2] + J[3, 3] + J[4, 4]) + 1e-9)
            for k in range(5):
                b[k] = -r[k]
            _solve5(J, b, step)
            for k in range(5):
                if not math.isfinite(step[k]):
                    step[k] = 0.0
            # The fallback's direction: the whole step scaled by one factor.
            whole = max(
                abs(step[0]) / _MAX_STEP,
                1.0,
                math.hypot(step[1], step[2]) / _MAX_STEP,
                math.hypot(step[3], step[4]) / _MAX_STEP,
            )
            for k in range(5):
                dd[k] = step[k] / whole
            # Each capped on its own (drive.DriveSolver._with_bearings).
            step[0] /= max(abs(step[0]) / _MAX_STEP, 1.0)
            for a in (1, 3):
                big = math.hypot(step[a], step[a + 1]) / _MAX_STEP
                if big > 1.0:
                    step[a] /= big
                    step[a + 1] /= big
            m0 = _merit(r, sm, sf)
            alpha = 1.0
            ok = False
            tt = t
            for _ls in range(50):
                tt = t + alpha * step[0]
                for c in range(2):
                    ut[c, 0] = u[c, 0] + alpha * step[1 + 2 * c]
                    ut[c, 1] = u[c, 1] + alpha * step[2 + 2 * c]
                _state(p, tt, ut, geo, law, T, K, slope0, target, w, wt, rt)
                _needles(ut, dirs, bear, Qt, kqt, gqt, rt)
                ok = _merit(rt, sm, sf) <= (1.0 - 1e-4 * alpha) * m0
                if ok:
                    break
                alpha *= 0.5
            if not ok:  # no decrease of the merit: an exact line search on the energy
                ae = _energy_search(
                    p, t, u, dd, r, geo, law, T, K, slope0, target, w, bear, dirs, ls
                )
                if not ae > 0.0:  # no descent: the position keeps its state
                    break
                tt = t + ae * dd[0]
                _copy2(wt, ls[1])
                _copy1(rt, ls[2])
                _copy2(ut, ls[0])
                _copy2(Qt, ls[3])
                _copy2(kqt, ls[4])
                _copy2(gqt, ls[5])
            t = tt
            _copy2(u, ut)
            _copy2(w, wt)
            _copy1(r, rt)
            _copy2(Q, Qt)
            _copy2(kq, kqt)
            _copy2(gq, gqt)
            done = _relative(r, w, geo, p, Q, gq, target, e) <= rtol
        tau[p] = t
        for i in range(N):
            F0[p, i] = w[1, i]
        for c in range(2):
            u_out[c, p, 0], u_out[c, p, 1] = u[c, 0], u[c, 1]
            for j in range(Z):
                Q_out[c, p, j] = Q[c, j]
        if idle:
            rel_out[p] = 0.0
        elif done:
            rel_out[p] = _relative(r, w, geo, p, Q, gq, target, e)
        else:
            rel_out[p] = np.inf


def loadable_arrays(geo) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The advance and arm (0 where a roller cannot load) and the gap (-1e300 there),
    contiguous (P, N), as the kernels take them."""
    return (
        np.ascontiguousarray(np.where(geo.loadable, geo.advance, 0.0)),
        np.ascontiguousarray(np.where(geo.loadable, geo.arm, 0.0)),
        np.ascontiguousarray(np.where(geo.loadable, geo.gap, -1e300)),
    )


def bearing_solve(solver, target: float, tau, F, iterations: int, max_iter: int, rtol: float):
    """:meth:`DriveSolver._with_bearings <corr_cad.mechanics.drive.drive.DriveSolver>` compiled:
    ``(tau, F, u, Qs, rel, iterations)`` from the rigid solution ``tau``, ``F``; ``rtol``:
    the relative residual each position reaches (``drive.DRIVE_RTOL``)."""
    geo, comp = solver.geo_joined, solver.comp
    P, N = F.shape
    if hasattr(solver, "kernel_geometry"):  # a Monte Carlo block's, from what it keeps
        g = solver.kernel_geometry()
    else:
        g = np.stack([*loadable_arrays(geo), solver.n[..., 0], solver.n[..., 1]])
        g = np.ascontiguousarray(g)
    explicit = getattr(comp, "explicit", False)
    if explicit:
        law, T, K = 1, np.zeros((11, 1, 1)), np.ascontiguousarray(comp.K, dtype=float)
        slope0 = K
    else:
        law = 0
        T = CompiledInverse(comp, (P, N)).table.reshape(11, P, N)
        K = np.zeros((1, 1))
        # A copy: a broadcast view is read-only, a second type numba would compile for.
        slope0 = np.array(np.broadcast_to(comp.slope0, (P, N)), dtype=float, order="C")
    bearings = solver.bearings
    dirs = np.ascontiguousarray(np.stack([b.directions() for b in bearings]))
    bear = np.array(
        [
            [0.5 * b.diametral_clearance, b.needle_coefficient, b.diametral_clearance]
            for b in bearings
        ]
    )
    strib = np.array([b.stribeck_max_load(1.0) for b in bearings])
    tau = np.array(tau, dtype=float)
    F = np.array(F, dtype=float)
    u = np.empty((2, P, 2))
    Q = np.empty((2, P, dirs.shape[1]))
    rel = np.empty(P)
    bearing_newton(
        g,
        law,
        T,
        K,
        slope0,
        bear,
        strib,
        dirs,
        float(solver.design.eccentricity),
        tau,
        F,
        float(target),
        float(rtol),
        int(max_iter),
        u,
        Q,
        rel,
    )
    return tau, F, u, [Q[0], Q[1]], rel, iterations


class CompiledDriveSolver(DriveSolver):
    """:class:`~corr_cad.mechanics.drive.drive.DriveSolver` whose bearing Newton and preloaded
    row's cam centre run compiled (:func:`bearing_newton`,
    :func:`corr_cad.mechanics.drive.drive_centre.row_centres`; the linear contact law keeps the
    numpy ones)."""

    def _with_bearings(self, target, tau, F, iterations, max_iter: int = 100):
        if getattr(self.comp, "linear", False):
            return super()._with_bearings(target, tau, F, iterations, max_iter)
        return bearing_solve(self, target, tau, F, iterations, max_iter, DRIVE_RTOL)

    def _row_centre(self, c, idx, v):
        if getattr(self.comp, "linear", False):
            return super()._row_centre(c, idx, v)
        from corr_cad.mechanics.drive.drive_centre import row_centres

        explicit = getattr(self.comp, "explicit", False)
        table = None if explicit else CompiledInverse(self.comp, self.geo_joined.gap.shape).table
        return row_centres(self, c, idx, v, DRIVE_RTOL, table)
