"""Compiled Monte Carlo kernel: many error samples of one design, metrics only.

The same model and the same numerics as :mod:`corr_cad.mechanics.row.solver` (exact
linear-contact start, joint Newton on the cam rotation and the roller forces,
a bracketed Newton-bisection where that does not settle), written as loops
over one position's rollers and compiled with numba. A sample never leaves
the CPU cache and no (positions x rollers) array is written: the kernel keeps
the four Monte Carlo metrics as it goes. It agrees with the numpy solver to
round-off (about 1e-13 relative; ``tests/test_mc_kernel.py``); it is not
bit-identical to it, because sums run in another order.

Why compiled: a Monte Carlo of 10,000 samples x 360 positions is 94 million
roller solves; numpy spends most of its time making temporaries. The kernel
is compiled once and cached on disk (``cache=True``), and imported only when
a Monte Carlo or an allocation runs, so a run without them pays nothing.
Each sample is solved on its own, so results are the same on every executor
and for every chunking.
"""

from __future__ import annotations

import math
import os
from contextlib import contextmanager

import numba
import numpy as np
from numba.core import compiler, config
from numba.core.registry import CPUDispatcher

__all__ = ["solve_samples", "METRICS", "load_target"]

#: Columns of the kernel's output, in order.
METRICS = ("peak_gear_force", "peak_pressure", "min_loaded_rollers", "backlash_rad")

_KNEE = 0.99  # contact.VALIDITY_KNEE
_LOADED_SHARE = 1e-9  # solver.LOADED_SHARE


def kernel_inputs(geometry, profile_deviation, errors, design) -> tuple:
    """The arguments the compiled kernels share, contiguous and typed.

    ``geometry`` is a :func:`~corr_cad.mechanics.row.solver.roller_geometry`,
    ``profile_deviation`` its gear deviation per cell, ``errors`` the sampled
    ``(cam, ecc, phase, dr, dl)``; used by :func:`solve_samples` and
    :func:`corr_cad.mechanics.row.mc_windup_kernel.windup_samples` callers.
    """
    g, c = geometry, np.ascontiguousarray
    cam, ecc, phase, dr, dl = errors
    return (
        c(g.psi),
        c(g.s),
        c(g.rho_n),
        c(np.abs(g.rho_s)),
        c(np.where(g.loadable, g.advance, 0.0)),
        c(g.loadable),
        c(g.k_gear),
        c(profile_deviation),
        c(cam, dtype=float),
        c(ecc, dtype=float),
        c(phase, dtype=float),
        c(dr, dtype=float),
        c(dl, dtype=float),
        float(design.eccentricity),
        float(design.link_length),
        float(design.tooth_count),
        float(design.roller_radius),
        float(design.cam_radius),
        float(design.roller_length),
        float(design.material.contact_modulus),
    )


def load_target() -> None:
    """Build numba's CPU target (its typing and lowering tables) now.

    A process builds it at its first call of a compiled kernel otherwise,
    cached or not (about 0.15 s; loading a cached kernel takes 0.01 s): a pool
    worker does it as it starts, while the main process runs the stages
    before. Nothing where numba's internals differ (an attribute missing).
    """
    try:
        from numba.core.registry import cpu_target

        cpu_target.typing_context.refresh()
        cpu_target.target_context.refresh()
    except (ImportError, AttributeError):
        pass


#: LLVM's optimisation levels (numba's default is 3): the kernels Python calls, and the
#: helpers only compiled code calls (each caller links them in and optimises them again
#: at its own level). Without ``fastmath`` LLVM reorders no floating-point arithmetic at
#: any level: the same bits (docs/accuracy-and-speed.md, "Compiling the kernels").
#: ``NUMBA_OPT`` set in the environment overrides both.
OPT_LEVEL, INNER_OPT_LEVEL = 2, 1


@contextmanager
def _opt_level(level: int):
    """numba's ``config.OPT`` at ``level`` while a kernel compiles (numba reads it as it
    optimises each function and module), restored after: only the kernels' compiles see
    it, which hold numba's compiler lock."""
    if "NUMBA_OPT" in os.environ:
        yield
        return
    saved = config.OPT
    config.OPT = config._OptLevel(level)
    try:
        yield
    finally:
        config.OPT = saved


def _compiler(level: int) -> type:
    """numba's compiler, at optimisation ``level`` (:func:`_opt_level`)."""

    class Compiler(compiler.Compiler):
        def compile_extra(self, func):
            with _opt_level(level):
                return super().compile_extra(func)

        def compile_ir(self, func_ir, lifted=(), lifted_from=None):
            with _opt_level(level):
                return super().compile_ir(func_ir, lifted, lifted_from)

    Compiler.__qualname__ = Compiler.__name__ = f"Compiler{level}"
    return Compiler


_COMPILERS = {level: _compiler(level) for level in {OPT_LEVEL, INNER_OPT_LEVEL}}


def _jit(fn, level: int = OPT_LEVEL, **options):
    """Compile with numba at LLVM's optimisation ``level``, cached on disk when numba finds a
    writable place.

    Without one (a read-only install, no writable home, no usable
    ``NUMBA_CACHE_DIR``) numba refuses ``cache=True`` at decoration; the
    kernel is then compiled in memory on every run (same machine code, same
    bits, ~4 s more).
    """
    jit = {"nogil": True, "error_model": "numpy", "pipeline_class": _COMPILERS[level]}
    jit.update(no_cfunc_wrapper=True, **options)  # no kernel is a C callback
    try:
        return numba.njit(cache=True, **jit)(fn)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return numba.njit(cache=False, **jit)(fn)


class _InnerDispatcher(CPUDispatcher):
    """A helper compiled without the wrapper Python calls it through: numba would jump
    through a null pointer (the process dies); this says what to do instead."""

    def __call__(self, *args, **kwargs):
        raise TypeError(
            f"{self.py_func.__module__}.{self.py_func.__qualname__} is compiled for compiled "
            "callers only (@_jit_inner): decorate it with @_jit to call it from Python"
        )


def _jit_inner(fn):
    """:func:`_jit` for a helper that only compiled code calls: without the wrapper that lets
    Python call it (about 0.1 s of compile each), at :data:`INNER_OPT_LEVEL`; a call from
    Python raises ``TypeError``."""
    kernel = _jit(fn, INNER_OPT_LEVEL, no_cpython_wrapper=True)
    kernel.__class__ = _InnerDispatcher  # same layout: only the Python call differs
    return kernel


# Rows of a position's per-roller table ``C`` (fields x rollers).
A, H0, K0, CJ, CN, CS, WN, WS, K1, KG, UKJ, UKN, UKS = range(13)
FIELDS = 13
# Rows of the work table ``W``: forces, residuals, inverse slopes, and the
# previous rotation's h and G' (for the tangent predictor).
F, RES, INV, HP, DG = range(5)


@_jit_inner
def _approach(u, uk, k1, k2):
    """``(delta(u), delta'(u))`` of one contact, tangent continuation past the knee."""
    ue = min(u, uk)
    q1 = math.sqrt(1.0 - k1 * k1 * ue)
    q2 = math.sqrt(1.0 - k2 * k2 * ue)
    val = k1 * ue / (1.0 + q1) + k2 * ue / (1.0 + q2)
    slope = 0.5 * k1 / q1 + 0.5 * k2 / q2
    if u > uk:
        val = val + slope * (u - uk)
    return val, slope


@_jit_inner
def _compliance(f, C, i, kc):
    """``G(f)`` and ``G'(f)`` of roller ``i``: cam, gear and slot contacts in series."""
    cj, cn, cs, wn, ws, k1 = C[CJ, i], C[CN, i], C[CS, i], C[WN, i], C[WS, i], C[K1, i]
    vj, sj = _approach(cj * f, C[UKJ, i], k1, kc)
    vn, sn = _approach(cn * wn * f, C[UKN, i], k1, C[KG, i])
    vs, ss = _approach(cs * ws * f, C[UKS, i], k1, 0.0)
    return vj + wn * vn + ws * vs, cj * sj + wn * cn * wn * sn + ws * cs * ws * ss


@_jit_inner
def _invert(f, h, C, i, kc):
    """Roller ``i``'s force with ``G(F) = h`` by Newton from ``f``: monotone from the right
    of the root (``G`` convex), so ``f`` is the linear-contact force or a predictor above it."""
    for _ in range(100):
        g, d = _compliance(f, C, i, kc)
        f_new = max(f - (g - h) / d, 0.0)
        if abs(f_new - f) <= 4e-16 * f:
            return f_new
        f = f_new
    return f


@_jit_inner
def _roller_pressure(C, i, f):
    """Largest ``sqrt(F / c)`` of roller ``i``'s cam, gear and slot contacts at ``F_j = f``."""
    pj = math.sqrt(f / C[CJ, i])
    pn = math.sqrt(C[WN, i] * f / C[CN, i])
    ps_ = math.sqrt(C[WS, i] * f / C[CS, i])
    return max(max(pj, ps_), pn)


@_jit_inner
def _free_ends(C, gap):
    """The cam rotations ``(fwd, rev)`` where the first roller closes its gap turning forward
    (``a > 0``: the smallest ``-gap / a``) and in reverse (``a < 0``: the largest); ``inf``
    and ``-inf`` where none does."""
    fwd = np.inf
    rev = -np.inf
    for i in range(C.shape[1]):
        a = C[A, i]
        if a > 0.0:
            fwd = min(fwd, -gap[i] / a)
        elif a < 0.0:
            rev = max(rev, -gap[i] / a)
    return fwd, rev


@_jit_inner
def _relative_residual(C, W, gap, tau, target):
    """The moment residual of the forces ``W[F]`` at the rotation ``tau``, relative to the
    moment's gross scale (as ``solver._solve_positions`` measures it)."""
    mom = 0.0
    scale = 0.0
    for i in range(C.shape[1]):
        a = C[A, i]
        f = W[F, i]
        mom += a * f
        if a != 0.0:
            gross = abs(tau * a) + abs(gap[i])
            scale += abs(a) * (abs(f) + gross / C[K0, i])
    return abs(mom - target) / (abs(target) + scale + 1e-300)


@_jit_inner
def _fill_table(
    C, gap, k, p, psi, s, rho_n, rho_s, a_nom, loadable, kg_nom, pd, cam_err, ecc_err,
    phase_err, dr_all, dl_all, e, L, z, r, Rj, c0,
):  # fmt: skip
    """Sample ``k``'s gaps ``gap`` and contact table ``C`` at position ``p`` (the arguments
    of :func:`solve_samples`, ``c0 = pi length modulus``); returns its cam's curvature."""
    kc = 1.0 / (Rj + cam_err[k])
    ea = e + ecc_err[k]
    any_delta = False
    for i in range(C.shape[1]):
        if dl_all[k, i] != 0.0:
            any_delta = True
    geo = ecc_err[k] != 0.0 or phase_err[k] != 0.0 or any_delta
    lam = 2.0 / c0
    for i in range(C.shape[1]):
        # The sample's initial interference (solver._error_gaps).
        dr = dr_all[k, i]
        dl = dl_all[k, i]
        gj = cam_err[k] + dr
        if geo:
            ss = s[p, i]
            if any_delta:
                ps = psi[p, i] + z * dl
                sn = e * math.sin(ps)
                ss = e * math.cos(ps) + math.sqrt(L * L - sn * sn)
            ang = psi[p, i] - dl + phase_err[k]
            gj = gj + L - math.sqrt(ss * ss + ea * ea - 2.0 * ss * ea * math.cos(ang))
        gap[i] = gj + rho_n[p, i] * (dr + pd[p, i]) - rho_s[p, i] * max(-dr, 0.0)
        # Its contacts (solver._Compliance).
        k1 = 1.0 / (r + dr)
        kg = kg_nom[p, i]
        wn = rho_n[p, i]
        ws = rho_s[p, i]
        C[A, i] = a_nom[p, i]
        C[H0, i] = gap[i] if loadable[p, i] else -1e300
        C[K0, i] = lam * (1.0 + wn * wn + ws * ws)
        C[CJ, i] = 4.0 / (c0 * max(k1 + kc, 1e-300))
        C[CN, i] = 4.0 / (c0 * max(k1 + kg, 1e-300))
        C[CS, i] = 4.0 / (c0 * max(k1, 1e-300))
        C[WN, i] = wn
        C[WS, i] = ws
        C[K1, i] = k1
        C[KG, i] = kg
        C[UKJ, i] = _KNEE / max(max(k1 * k1, kc * kc), 1e-300)
        C[UKN, i] = _KNEE / max(max(k1 * k1, kg * kg), 1e-300)
        C[UKS, i] = _KNEE / max(k1 * k1, 1e-300)
    return kc


@_jit
def _linear_tau(C, target, order, bp):
    """Exact cam rotation of the linear-contact model (piecewise-linear moment)."""
    R = C.shape[1]
    n = 0
    slope = 0.0
    icpt = 0.0
    for i in range(R):
        a = C[A, i]
        if a != 0.0:
            bp[n] = -C[H0, i] / a
            order[n] = i
            n += 1
            if a < 0.0:  # active left of its breakpoint
                slope += a * a / C[K0, i]
                icpt += a * C[H0, i] / C[K0, i]
    # insertion sort of the breakpoints (R is about 26)
    for j in range(1, n):
        b = bp[j]
        o = order[j]
        k = j - 1
        while k >= 0 and bp[k] > b:
            bp[k + 1] = bp[k]
            order[k + 1] = order[k]
            k -= 1
        bp[k + 1] = b
        order[k + 1] = o
    start = 0.0
    for j in range(n):
        if slope * bp[j] + icpt >= target:  # the root is left of this breakpoint
            if slope > 0.0:
                return (target - icpt) / slope
            return start if j > 0 else 0.0
        i = order[j]
        a = C[A, i]
        sign = 1.0 if a > 0.0 else -1.0  # becomes active, or inactive
        slope += sign * a * a / C[K0, i]
        icpt += sign * a * C[H0, i] / C[K0, i]
        start = bp[j]
    if slope > 0.0:
        return (target - icpt) / slope
    return start


@_jit_inner
def _evaluate(tau, C, kc, W, warm):
    """Forces at a fixed cam rotation, each roller's ``G(F) = h`` solved by Newton.

    Newton converges monotonically from the right of the root (``G`` convex):
    the start is the linear-contact force, or with ``warm > 0`` the tangent
    predictor from the previous rotation (a float, not a bool: numba compiles a
    constant bool argument once per value). Returns the moment, its slope in
    the rotation and the moment's scale.
    """
    mom = 0.0
    dmom = 0.0
    scale = 0.0
    for i in range(C.shape[1]):
        a = C[A, i]
        h = tau * a + C[H0, i]
        f = h / C[K0, i]
        if warm > 0.0 and W[F, i] > 0.0:
            f = max(W[F, i] + (h - W[HP, i]) / W[DG, i], 0.0)
        W[HP, i] = h
        if h <= 0.0:
            W[F, i] = 0.0
            W[DG, i] = C[K0, i]
            continue
        f = _invert(f, h, C, i, kc)
        g, d = _compliance(f, C, i, kc)
        W[F, i] = f
        W[DG, i] = d
        mom += a * f
        if f > 0.0:
            dmom += a * a / d
        scale += abs(a * f)
    return mom, dmom, scale


@_jit
def _nested(tau, C, kc, W, target, rtol):
    """Bracketed Newton-bisection on the rotation; returns (tau, bracketed)."""
    mom, dmom, scale = _evaluate(tau, C, kc, W, 0.0)
    res = mom - target
    lo = tau if res <= 0.0 else -np.inf
    hi = tau if res >= 0.0 else np.inf
    amax = 1e-300
    gmax = 0.0
    for i in range(C.shape[1]):
        amax = max(amax, abs(C[A, i]))
        if C[A, i] != 0.0:
            gmax = max(gmax, abs(C[H0, i]))
    step = max(max(1e-3 * abs(tau), 1e-3 * gmax / amax), 1e-15)
    for _ in range(200):
        need_hi = not np.isfinite(hi)
        need_lo = not np.isfinite(lo)
        if not (need_hi or need_lo):
            break
        trial = tau + step if need_hi else tau - step
        above = _evaluate(trial, C, kc, W, 0.0)[0] - target
        if (need_hi and above >= 0.0) or (need_lo and above > 0.0):
            hi = trial
        else:
            lo = trial
        step *= 4.0
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return tau, False
    mom, dmom, scale = _evaluate(tau, C, kc, W, 0.0)
    for _ in range(200):
        res = mom - target
        if abs(res) <= rtol * (abs(target) + scale) + 1e-300:
            break
        if res < 0.0:
            lo = tau
        if res > 0.0:
            hi = tau
        new = tau - res / dmom if dmom > 0.0 else np.nan
        if not (dmom > 0.0 and lo < new < hi):
            new = 0.5 * (lo + hi)
        if new == tau:
            break
        mom, dmom, scale = _evaluate(new, C, kc, W, 1.0)
        tau = new
    return tau, True


@_jit_inner
def _solve_position(C, kc, W, order, bp, target, rtol):
    """Cam rotation and forces ``W[F]`` at one position; returns (tau, bracketed).

    Joint Newton on the rotation and the forces from the linear-contact
    solution (as :func:`corr_cad.mechanics.row.solver._newton`); :func:`_nested` where
    that does not settle in 30 steps.
    """
    R = C.shape[1]
    tau = _linear_tau(C, target, order, bp)
    for i in range(R):
        h = tau * C[A, i] + C[H0, i]
        W[F, i] = h / C[K0, i] if h > 0.0 else 0.0
    for _ in range(30):
        r_m = 0.0
        scale_m = 0.0
        scale_h = 0.0
        rmax = 0.0
        den = 0.0
        num = 0.0
        for i in range(R):
            a = C[A, i]
            h = tau * a + C[H0, i]
            if h > 0.0:
                f = W[F, i] if W[F, i] > 0.0 else h / C[K0, i]
                g, d = _compliance(f, C, i, kc)
                r = g - h
                inv = 1.0 / d
                W[F, i] = f
                W[RES, i] = r
                W[INV, i] = inv
                den += a * a * inv
                num += a * r * inv
                scale_h = max(scale_h, h)
                rmax = max(rmax, abs(r))
            else:
                W[F, i] = 0.0
                W[RES, i] = 0.0
                W[INV, i] = 0.0
            r_m += a * W[F, i]
            scale_m += abs(a * W[F, i])
        r_m -= target
        if abs(r_m) <= rtol * (abs(target) + scale_m) + 1e-300 and rmax <= rtol * scale_h + 1e-300:
            return tau, True
        dtau = (num - r_m) / den if den > 0.0 else 0.0
        for i in range(R):
            if W[INV, i] != 0.0:
                W[F, i] = max(W[F, i] + (C[A, i] * dtau - W[RES, i]) * W[INV, i], 0.0)
        tau += dtau
    return _nested(tau, C, kc, W, target, rtol)


@_jit
def solve_samples(
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
    target,
    rtol,
    out,
    rel_out,
):
    """Solve every sample at every position; write its metrics.

    Nominal arrays (P, R): ``psi``, ``s``, ``rho_n``, ``rho_s`` (absolute),
    ``a_nom`` (advance, 0 where not loadable), ``loadable``, ``kg_nom`` (gear
    curvature), ``pd`` (profile deviation of the base errors, mm). Per sample:
    ``cam_err``, ``ecc_err``, ``phase_err`` (n,), ``dr_all`` and ``dl_all``
    (n, R): roller radius errors (mm) and slot angle errors (rad).

    ``out`` (n, 4): :data:`METRICS`; ``rel_out`` (n,): worst relative moment
    residual, or ``inf`` where no rotation could carry the moment.
    """
    n = cam_err.shape[0]
    P, R = psi.shape
    c0 = np.pi * length * modulus
    C = np.empty((FIELDS, R))
    W = np.zeros((5, R))
    gap = np.empty(R)
    bp = np.empty(R)
    order = np.empty(R, dtype=np.int64)
    for k in range(n):
        peak_f = 0.0
        peak_p = 0.0
        min_loaded = R + 1
        lost = 0.0
        worst = 0.0
        for p in range(P):
            kc = _fill_table(
                C, gap, k, p, psi, s, rho_n, rho_s, a_nom, loadable, kg_nom, pd, cam_err,
                ecc_err, phase_err, dr_all, dl_all, e, L, z, r, Rj, c0,
            )  # fmt: skip
            tau, ok = _solve_position(C, kc, W, order, bp, target, rtol)
            if not ok:
                worst = np.inf
                break
            # Residual as solver._solve_positions measures it, and the backlash.
            worst = max(worst, _relative_residual(C, W, gap, tau, target))
            fwd, rev = _free_ends(C, gap)
            if np.isfinite(fwd) and np.isfinite(rev):
                lost = max(lost, max(fwd - rev, 0.0) / R)
            fmax = 0.0
            for i in range(R):
                fmax = max(fmax, W[F, i])
            threshold = _LOADED_SHARE * max(fmax, 0.0) + 0.0
            loaded = 0
            for i in range(R):
                f = W[F, i]
                if f > threshold:
                    loaded += 1
                peak_f = max(peak_f, C[WN, i] * f)
                peak_p = max(peak_p, _roller_pressure(C, i, f))
            min_loaded = min(min_loaded, loaded)
        out[k, 0] = peak_f
        out[k, 1] = 2.0 * peak_p / (np.pi * length)
        out[k, 2] = min_loaded
        out[k, 3] = lost
        rel_out[k] = worst
