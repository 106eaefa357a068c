"""Mesh forces on every roller over the cycle (paper Section 3, corrected).

Model
-----
Roller ``i`` sits in slot ``i`` at polar angle ``theta_i = i 2 pi/(z+1)`` of
the (held) frame; the crank is at ``phi`` and ``psi_i = phi - theta_i``. Three
contact forces act on it, each along a direction fixed by the nominal
geometry:

* cam ``F_j`` along ``c = (H - O1)/L`` (through the cam centre),
* gear ``F_n`` along ``-n`` (the working-profile normal),
* slot wall ``F_s`` along the slot normal ``-u_t``.

*Equilibrium* of the roller as vectors gives, with ``W = sqrt(L^2 - e^2
sin^2 psi)`` and ``beta`` the normal's angle from the radial direction:

    F_n = F_j W / (L cos beta),     F_s = -F_j (e sin psi + W tan beta) / L
        = -F_j (z + 1) e sin(psi) / L.

``F_s`` is reported positive when the roller drives the frame forwards.

*Compatibility*: the roller moves rigidly by ``d``; the cam turns by a small
``tau``, advancing its surface at roller ``i`` by ``tau a_i`` along ``c`` with
``a_i = -e s_i sin(psi_i) / L`` (the moment arm of ``c`` about the axis).
Eliminating ``d`` with the gear and slot approaches leaves one monotone
equation per roller,

    delta_j(F_j) + rho_n delta_n(rho_n F_j) + |rho_s| delta_s(|rho_s| F_j)
        = tau a_i + g_i,

(``rho_n = F_n/F_j``, ``rho_s = F_s/F_j``, ``g_i`` the initial interference
from errors), and *moment equilibrium* of one cam (Eq. 8) closes it:
``sum_i a_i F_j,i = share M0``. Rollers whose right-hand side is not positive
are in clearance and carry nothing. Virtual work holds exactly:
``sum_i F_j,i tau a_i = share M0 tau``.

Numerics: per position a safeguarded Newton-bisection on ``tau`` (the moment
is monotone in ``tau``, so the root is bracketed); the per-roller equation is
inverted by Newton from a start to the right of the root, which converges
monotonically because the approach is convex in the force. Everything is
vectorised over positions and rollers, and a full cycle solves only one
position per class of the ``2 pi/(z+1)`` periodicity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from . import contact
from . import kinematics as kin
from .design import GearDesign
from .deviations import ManufacturingErrors
from .errors import SolverError

__all__ = [
    "VARIANTS",
    "CONTACT_MODELS",
    "ForceResult",
    "RollerGeometry",
    "roller_geometry",
    "solve_forces",
    "cycle_angles",
    "solve_forces_batch",
    "BatchSolver",
]

#: Printed forms of the paper that can be switched on to reproduce it:
#: ``eq3_printed``: gear normal from Eq. (3) as printed (arctan, no ``e``);
#: ``eq16_sin_gamma``: compatibility advance ``e sin(gamma)`` (Eq. 16) instead
#: of the moment arm; ``rj_for_link_length``: ``L = Rj`` in Eqs. (6)-(7);
#: ``working_half_only``: only rollers on the working half may carry load.
VARIANTS = ("eq3_printed", "eq16_sin_gamma", "rj_for_link_length", "working_half_only")

#: ``nonlinear``: the paper's overlap model (Eqs. 9-12, corrected);
#: ``linear``: its small-half-width limit ``delta = 2 F / (pi l E')``.
CONTACT_MODELS = ("nonlinear", "linear")

_RTOL = 1e-13


@dataclass(frozen=True)
class RollerGeometry:
    """Per (position, roller) quantities of the force model; arrays (P, R)."""

    psi: np.ndarray
    s: np.ndarray
    rho_n: np.ndarray  # F_n / F_j
    rho_s: np.ndarray  # F_s / F_j (reported sign)
    advance: np.ndarray  # a_c: cam advance per unit rotation used in compatibility, mm/rad
    arm: np.ndarray  # a_m: moment arm of F_j about the crank axis, mm
    gap: np.ndarray  # effective initial interference g_j + rho_n g_n - |rho_s| c_s, mm
    k_roller: np.ndarray  # roller curvature 1/(r + dr)
    k_cam: float
    k_gear: np.ndarray  # gear curvature at contact, positive convex towards the roller
    loadable: np.ndarray  # bool


def cycle_angles(positions: int) -> np.ndarray:
    """``positions`` crank angles evenly over one cycle, rad."""
    if isinstance(positions, bool) or not isinstance(positions, (int, np.integer)) or positions < 1:
        raise SolverError(f"positions = {positions!r}: must be an integer >= 1")
    return 2.0 * np.pi * np.arange(positions) / positions


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.mod(a + np.pi, 2.0 * np.pi) - np.pi


def roller_geometry(
    design: GearDesign,
    crank_angles: np.ndarray,
    errors: ManufacturingErrors | None = None,
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
) -> RollerGeometry:
    """Geometry of the force model at crank angles (P,) for all z + 1 rollers."""
    bad = [v for v in variants if v not in VARIANTS]
    if bad:
        raise SolverError(f"variant {bad[0]!r} is unknown; valid variants: {', '.join(VARIANTS)}")
    errors = errors or ManufacturingErrors()
    z = design.tooth_count
    R = design.roller_count
    e, Rj, r = design.eccentricity, design.cam_radius, design.roller_radius
    L = Rj + r
    phi = np.asarray(crank_angles, dtype=float).reshape(-1)
    theta = np.arange(R) * design.slot_pitch_rad
    psi = phi[:, None] - theta[None, :]
    sp, cp = np.sin(psi), np.cos(psi)

    W = np.sqrt(L * L - (e * sp) ** 2)
    s = e * cp + W
    if "eq3_printed" in variants:
        # Eq. (3) as printed: alpha = arctan(-(z sin(z t) sin t + W1 cos t) /
        # (z sin(z t) cos t - W1 sin t)), W1 = sqrt(L^2 - sin^2(z t)), no e.
        t = theta[None, :] + 0.0 * psi
        w1 = np.sqrt(L * L - sp**2)
        with np.errstate(divide="ignore", invalid="ignore"):
            alpha = np.arctan(
                -(z * sp * np.sin(t) + w1 * np.cos(t)) / (z * sp * np.cos(t) - w1 * np.sin(t))
            )
        alpha = np.where(np.isfinite(alpha), alpha, 0.5 * np.pi)
        beta = np.mod(alpha - t + 0.5 * np.pi, np.pi) - 0.5 * np.pi  # the line, oriented outwards
    else:
        beta = kin.normal_offset_angle(psi, z, e, L)

    Lf = Rj if "rj_for_link_length" in variants else L
    Wf = np.sqrt(Lf * Lf - (e * sp) ** 2)
    sf = e * cp + Wf
    cos_b = np.cos(beta)
    rho_n = Wf / (Lf * cos_b)
    rho_s = (e * sp + Wf * np.tan(beta)) / Lf  # on the roller along +u_t; reported: -rho_s
    arm = -e * sf * sp / Lf
    if "eq16_sin_gamma" in variants:
        advance = -e * (e * sp / Lf)  # e sin(gamma), signed like the arm
    else:
        advance = arm

    k_locus = kin.locus_curvature(psi, z, e, L)
    k_gear = -k_locus / (1.0 + r * k_locus)

    if errors.any:
        gap, dr = _error_gaps(design, errors, phi, theta, psi, s, rho_n, rho_s)
    else:
        gap, dr = np.zeros_like(psi), np.zeros_like(psi)

    loadable = np.ones_like(psi, dtype=bool)
    if psi_contact_limit < math.pi:
        loadable &= np.abs(_wrap(psi)) <= psi_contact_limit
    return RollerGeometry(
        psi=psi,
        s=s,
        rho_n=rho_n,
        rho_s=-rho_s,
        advance=advance,
        arm=arm,
        gap=gap,
        k_roller=1.0 / (r + dr),
        k_cam=1.0 / (Rj + errors.cam_radius_error),
        k_gear=k_gear,
        loadable=loadable,
    )


def _error_gaps(design, errors, phi, theta, psi, s, rho_n, rho_s):
    """Initial interference per roller from the errors (see ``corr_cad.deviations``).

    Returns the effective gap ``g_j + rho_n g_n - |rho_s| c_s`` and each
    roller's radius error, (P, R). Only called when the scene has errors.
    """
    z, e = design.tooth_count, design.eccentricity
    L = design.link_length
    R = design.roller_count
    dr = errors.roller_errors(R)[None, :] + 0.0 * psi
    e_act = e + errors.eccentricity_error
    delta = errors.slot_errors(R)[None, :]
    g_j = errors.cam_radius_error + dr
    if errors.eccentricity_error or errors.cam_phase_error or np.any(delta):
        # The roller sits where its (possibly turned) slot meets the gear's
        # roller-centre locus; the (possibly moved) cam centre then overlaps it.
        s_slot = kin.centre_distance(psi + z * delta, e, L) if np.any(delta) else s
        ang = psi - delta + errors.cam_phase_error
        g_j = g_j + L - np.sqrt(s_slot**2 + e_act**2 - 2.0 * s_slot * e_act * np.cos(ang))
    g_n = dr
    if errors.profile_deviation is not None:
        # Polar angle of roller i on the fixed gear: frame angle phi/z + slot angle.
        t_abs = phi[:, None] / z + theta[None, :]
        g_n = g_n + np.asarray(errors.profile_deviation(t_abs), dtype=float)
    clearance_slot = np.maximum(-dr, 0.0)
    return g_j + rho_n * g_n - np.abs(rho_s) * clearance_slot, dr


#: A roller counts as loaded when its cam force exceeds this share of the
#: largest cam force at the same position. A roller exactly at the edge of
#: the loaded zone (psi = 0 or pi) comes out of the solve with a force of
#: ~1e-13 of the others': that is round-off, not load, and counting it made
#: the loaded-roller count depend on which positions were solved.
LOADED_SHARE = 1e-9


def loaded_mask(F_j: np.ndarray) -> np.ndarray:
    """Rollers carrying load, (P, R) bool, from cam forces (P, R), N."""
    F_j = np.asarray(F_j)
    return F_j > LOADED_SHARE * np.max(F_j, axis=-1, keepdims=True).clip(min=0.0) + 0.0


@dataclass
class ForceResult:
    """Mesh forces over crank positions, in the style of ``scipy.optimize.OptimizeResult``.

    Arrays are (P, R): P crank positions, R = z + 1 rollers (roller 0 is the
    paper's roller 1). Forces in N, pressures in MPa, angles in rad.
    """

    success: bool
    message: str
    iterations: int
    moment_residual: float
    crank_angles: np.ndarray
    psi: np.ndarray
    F_j: np.ndarray
    F_s: np.ndarray
    F_n: np.ndarray
    p_cam: np.ndarray
    p_slot: np.ndarray
    p_gear: np.ndarray
    valid_cam: np.ndarray
    valid_slot: np.ndarray
    valid_gear: np.ndarray
    cam_rotation: np.ndarray
    cam_moment: float
    positions_solved: int
    geometry: RollerGeometry = field(repr=False)
    full_cycle: bool = True

    @property
    def loaded(self) -> np.ndarray:
        """Which rollers carry load, (P, R) bool: see :func:`loaded_mask`."""
        return loaded_mask(self.F_j)

    @property
    def loaded_count(self) -> np.ndarray:
        """Rollers carrying load at each position, (P,)."""
        return np.count_nonzero(self.loaded, axis=1)

    @property
    def small_rotation(self) -> np.ndarray:
        """True where the cam's rotation stays small (< 0.01 rad) as the model assumes.

        A large value means gaps (clearances) that the cam can only close by
        turning far: the static small-displacement picture no longer holds.
        """
        return np.abs(self.cam_rotation) < 0.01

    @property
    def lost_motion(self) -> np.ndarray:
        """Output lost motion at each position, rad (P,).

        With the crank held, the frame turns freely until a roller closes its
        clearance: the cam may turn from ``max(-g/a)`` over rollers with
        ``a < 0`` to ``min(-g/a)`` over rollers with ``a > 0`` without load,
        and the output turns ``1/(z + 1)`` of that. Zero where rollers are in
        contact both ways (no clearance).
        """
        g = self.geometry
        a = np.where(g.loadable, g.advance, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -g.gap / a
        fwd = np.min(np.where(a > 0, t, np.inf), axis=1)
        rev = np.max(np.where(a < 0, t, -np.inf), axis=1)
        play = np.where(np.isfinite(fwd) & np.isfinite(rev), np.maximum(fwd - rev, 0.0), 0.0)
        return play / g.psi.shape[1]

    @property
    def valid(self) -> np.ndarray:
        """True where all three contacts of a roller are inside the model's validity."""
        return self.valid_cam & self.valid_slot & self.valid_gear

    @property
    def output_torque(self) -> np.ndarray:
        """Torque the rollers put on the frame, sum s F_s, N*mm (P,)."""
        return np.sum(self.geometry.s * self.F_s, axis=1)

    def summary(self) -> dict:
        """Roller 0 over the solved positions (means over its loaded part)."""
        fj, fn, fs = self.F_j[:, 0], self.F_n[:, 0], self.F_s[:, 0]
        loaded = fj > 0

        def mean(x: np.ndarray) -> float:
            return float(x[loaded].mean()) if np.any(loaded) else 0.0

        p_all = np.maximum(np.maximum(self.p_cam, self.p_slot), self.p_gear)
        return {
            "F_j_mean": mean(fj),
            "F_n_mean": mean(fn),
            "F_s_mean": mean(fs),
            "F_j_peak": float(fj.max()),
            "F_n_peak": float(fn.max()),
            "F_s_peak_to_peak": float(fs.max() - fs.min()),
            "p_max": float(p_all.max()),
            "loaded_rollers_min": int(self.loaded_count.min()),
            "loaded_rollers_max": int(self.loaded_count.max()),
            "positions_beyond_small_rotation": int(np.count_nonzero(~self.small_rotation)),
        }


class _Contact:
    """One contact of every roller, with weight ``w`` (force = w F_j).

    The knee of the validity continuation is located once; Newton then
    calls :func:`contact.approach_and_slope` with it (the continuation
    itself is evaluated only where a force passes the knee).
    """

    def __init__(self, w, c, k1, k2):
        self.w = w  # None: unit weight
        self.cw = c if w is None else c * w  # b^2 per unit F_j
        self.wcw = self.cw if w is None else w * self.cw
        self.k1 = k1
        self.k2 = k2
        self.uk = contact.knee_point(k1, k2)

    def take(self, sel):
        out = object.__new__(_Contact)
        out.w = None if self.w is None else self.w[sel]
        out.cw, out.wcw, out.k1, out.uk = self.cw[sel], self.wcw[sel], self.k1[sel], self.uk[sel]
        out.k2 = self.k2 if np.ndim(self.k2) == 0 else self.k2[sel]
        return out

    def value_and_slope(self, F):
        knee = (self.uk, None, None)
        val, slope = contact.approach_and_slope(self.cw * F, self.k1, self.k2, knee)
        if self.w is None:
            return val, self.wcw * slope
        return self.w * val, self.wcw * slope


class _Compliance:
    """``G(F) = delta_j(F) + rho_n delta_n(rho_n F) + |rho_s| delta_s(|rho_s| F)``."""

    def __init__(self, geo: RollerGeometry, design: GearDesign, model: str):
        length = design.roller_length
        modulus = design.material.contact_modulus
        self.linear = model == "linear"
        wn = geo.rho_n
        ws = np.abs(geo.rho_s)
        k1 = geo.k_roller
        one = np.ones_like(wn)
        self.cj = contact.half_width_sq_per_force(k1, geo.k_cam, length, modulus)
        self.cn = contact.half_width_sq_per_force(k1, geo.k_gear, length, modulus)
        self.cs = contact.half_width_sq_per_force(k1, 0.0, length, modulus)
        lam = contact.linear_compliance(length, modulus)
        #: G'(0), the linear-contact slope; G(F) >= slope0 F (convexity).
        self.slope0 = lam * (1.0 + wn**2 + ws**2)
        if not self.linear:
            self.contacts = [
                _Contact(None, self.cj, k1, geo.k_cam * one),
                _Contact(wn, self.cn, k1, geo.k_gear),
                _Contact(ws, self.cs, k1, 0.0),
            ]

    def take(self, rows: np.ndarray) -> _Compliance:
        """The compliance of a subset of positions."""
        sub = _Compliance.__new__(_Compliance)
        sub.linear = self.linear
        sub.slope0 = self.slope0[rows]
        if not self.linear:
            sub.contacts = [c.take(rows) for c in self.contacts]
        return sub

    def value_and_slope(self, F: np.ndarray, sel=None):
        if self.linear:
            k = self.slope0 if sel is None else self.slope0[sel]
            return k * F, k
        g = dg = 0.0
        for c in self.contacts:
            cc = c if sel is None else c.take(sel)
            v, d = cc.value_and_slope(F)
            g = g + v
            dg = dg + d
        return g, dg

    def invert(self, h: np.ndarray, start: np.ndarray, sel=None) -> tuple[np.ndarray, np.ndarray]:
        """Solve ``G(F) = h`` for ``h > 0`` (0 elsewhere); returns ``(F, G'(F))``.

        Newton converges monotonically from any start: ``G`` is convex and
        increasing with ``G'(F) >= G'(0) > 0``.
        """
        pos = h > 0
        k0 = self.slope0 if sel is None else self.slope0[sel]
        if self.linear:
            return np.where(pos, h / k0, 0.0), k0 + 0.0 * h
        F = np.where(pos, start, 0.0)
        for _ in range(100):
            g, dg = self.value_and_slope(F, sel)
            step = np.where(pos, (g - h) / dg, 0.0)
            F_new = np.maximum(F - step, 0.0)
            if np.all(np.abs(F_new - F) <= 4e-16 * F):
                F = F_new
                break
            F = F_new
        _, dg = self.value_and_slope(F, sel)
        return np.where(pos, F, 0.0), dg


def _linear_tau(a_c, a_m, h0, k0, target):
    """Exact ``tau`` for the linear-contact model: the moment is piecewise linear.

    Per position, ``M(tau) = sum a_m max(tau a_c + h0, 0) / k0`` is continuous
    and non-decreasing with a kink at each roller's breakpoint
    ``-h0 / a_c``. Sorting the breakpoints and accumulating each roller's
    slope and intercept gives ``M`` at every breakpoint in O(R log R); the
    root is interpolated in the segment that holds ``target``.
    """
    P, R = a_c.shape
    ar = np.arange(P)[:, None]
    slope = a_m * a_c / k0
    icpt = a_m * h0 / k0
    up = a_c > 0
    down = a_c < 0
    const = np.sum(np.where(~up & ~down & (h0 > 0), icpt, 0.0), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        bp = np.where(up | down, -h0 / a_c, np.inf)
    order = np.argsort(bp, axis=1)
    bp_s = bp[ar, order]
    su = np.where(up, slope, 0.0)[ar, order].cumsum(axis=1)
    iu = np.where(up, icpt, 0.0)[ar, order].cumsum(axis=1)
    sd = np.where(down, slope, 0.0)[ar, order]
    idn = np.where(down, icpt, 0.0)[ar, order]
    sd_after = sd.sum(axis=1, keepdims=True) - sd.cumsum(axis=1)
    id_after = idn.sum(axis=1, keepdims=True) - idn.cumsum(axis=1)
    finite = np.isfinite(bp_s)
    tb = np.where(finite, bp_s, 0.0)
    # Segment k is (bp_k, bp_{k+1}); slope/intercept valid on it.
    seg_s = su + sd_after
    seg_i = iu + id_after + const[:, None]
    M_at = np.where(finite, seg_s * tb + seg_i, np.inf)
    # Left of the first breakpoint: only "down" rollers (all of them) act.
    s_left = np.sum(np.where(down, slope, 0.0), axis=1)
    i_left = np.sum(np.where(down, icpt, 0.0), axis=1) + const
    k = np.argmax(M_at >= target, axis=1)  # first breakpoint reaching the target
    reached = M_at[np.arange(P), k] >= target
    # Segment holding the root: (bp_{k-1}, bp_k), or left of bp_0 when k = 0,
    # or right of the last finite breakpoint when never reached.
    n_f = finite.sum(axis=1)
    last = np.maximum(n_f - 1, 0)
    kk = np.where(reached, k - 1, last)
    use_left = reached & (k == 0) | (n_f == 0)
    kk = np.maximum(kk, 0)
    s_seg = np.where(use_left, s_left, seg_s[np.arange(P), kk])
    i_seg = np.where(use_left, i_left, seg_i[np.arange(P), kk])
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = (target - i_seg) / s_seg
    # Flat segment exactly at the target: any tau in it solves; take its start.
    flat = ~np.isfinite(tau)
    tau = np.where(flat, np.where(use_left, 0.0, tb[np.arange(P), kk]), tau)
    return tau


def _newton(a_c, a_m, h0, comp: _Compliance, target, tau, max_iter=30, rtol=_RTOL):
    """Joint Newton on (tau, F) per position, from the linear-contact solution.

    Works only on the positions not yet converged. Returns
    ``tau, F, iterations, converged (P,)``.
    """
    P = len(tau)
    tau = tau.copy()
    h = tau[:, None] * a_c + h0
    F = np.where(h > 0, h / comp.slope0, 0.0)
    converged = np.zeros(P, dtype=bool)
    todo = np.arange(P)
    it = 0
    for it in range(1, max_iter + 1):
        ac, am, hz = a_c[todo], a_m[todo], h0[todo]
        sub = comp.take(todo) if len(todo) < P else comp
        t, f = tau[todo], F[todo]
        h = t[:, None] * ac + hz
        active = h > 0
        f = np.where(active, np.where(f > 0, f, h / sub.slope0), 0.0)
        g, dg = sub.value_and_slope(f)
        r = np.where(active, g - h, 0.0)
        r_m = np.sum(am * f, axis=1) - target
        inv = np.where(active, 1.0 / dg, 0.0)
        den = np.sum(am * ac * inv, axis=1)
        scale_m = np.sum(np.abs(am * f), axis=1)
        scale_h = np.max(np.where(active, h, 0.0), axis=1)
        done = (np.abs(r_m) <= rtol * (abs(target) + scale_m) + 1e-300) & np.all(
            np.abs(r) <= rtol * scale_h[:, None] + 1e-300, axis=1
        )
        with np.errstate(divide="ignore", invalid="ignore"):
            dtau = np.where(den > 0, (np.sum(am * r * inv, axis=1) - r_m) / den, 0.0)
        df = np.where(active, (ac * dtau[:, None] - r) * inv, 0.0)
        F[todo] = np.where(done[:, None], f, np.maximum(f + df, 0.0))
        tau[todo] = np.where(done, t, t + dtau)
        converged[todo[done]] = True
        todo = todo[~done]
        if todo.size == 0:
            break
    return tau, F, it, converged


def _nested(geo_a_c, a_m, h0, comp: _Compliance, target, max_iter: int = 200, rtol=_RTOL):
    """Robust path: safeguarded Newton-bisection on ``tau``, exact inner inversion."""
    a_c = geo_a_c
    P = a_c.shape[0]

    def evaluate(tau: np.ndarray, F_prev=None, h_prev=None, dg_prev=None):
        h = tau[:, None] * a_c + h0
        start = h / comp.slope0
        if F_prev is not None:
            # Tangent predictor: to the right of the root because G is convex.
            pred = F_prev + (h - h_prev) / dg_prev
            start = np.where(F_prev > 0, np.maximum(pred, 0.0), start)
        F, dg = comp.invert(h, start)
        moment = np.sum(a_m * F, axis=1)
        dmom = np.sum(np.where(F > 0, a_m * a_c / dg, 0.0), axis=1)
        scale = np.sum(np.abs(a_m * F), axis=1)
        return F, h, dg, moment, dmom, scale

    tau = _linear_tau(a_c, a_m, h0, comp.slope0, target)
    F, h, dg, mom, dmom, scale = evaluate(tau)
    res = mom - target
    lo = np.where(res <= 0, tau, -np.inf)
    hi = np.where(res >= 0, tau, np.inf)
    amax = np.maximum(np.max(np.abs(a_c), axis=1), 1e-300)
    gap_scale = np.max(np.abs(h0), axis=1) / amax
    step = np.maximum(np.maximum(1e-3 * np.abs(tau), 1e-3 * gap_scale), 1e-15)
    for _ in range(200):
        need_hi = ~np.isfinite(hi)
        need_lo = ~np.isfinite(lo)
        if not (np.any(need_hi) or np.any(need_lo)):
            break
        trial = np.where(need_hi, tau + step, np.where(need_lo, tau - step, tau))
        _, _, _, momt, _, _ = evaluate(trial)
        r_t = momt - target
        hi = np.where(need_hi & (r_t >= 0), trial, hi)
        lo = np.where(need_hi & (r_t < 0), trial, lo)
        lo = np.where(need_lo & (r_t <= 0), trial, lo)
        hi = np.where(need_lo & (r_t > 0), trial, hi)
        step = np.where(need_hi | need_lo, 4.0 * step, step)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        bad = np.flatnonzero(~(np.isfinite(lo) & np.isfinite(hi)))
        raise SolverError(
            f"no roller can carry the moment {target:g} N*mm at {len(bad)} of {P} positions "
            "(all loadable rollers face the wrong way or are masked)"
        )
    it = 0
    for it in range(1, max_iter + 1):
        res = mom - target
        tol = rtol * (abs(target) + scale) + 1e-300
        done = np.abs(res) <= tol
        if np.all(done):
            break
        lo = np.where(res < 0, tau, lo)
        hi = np.where(res > 0, tau, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = tau - res / dmom
        ok = (dmom > 0) & (newton > lo) & (newton < hi)
        tau_new = np.where(done, tau, np.where(ok, newton, 0.5 * (lo + hi)))
        if np.array_equal(tau_new, tau):
            break
        F, h, dg, mom, dmom, scale = evaluate(tau_new, F, h, dg)
        tau = tau_new
    return tau, F, it


def _solve_positions(geo: RollerGeometry, comp: _Compliance, target: float, rtol: float = _RTOL):
    """``tau`` and ``F_j`` per position so that ``sum a_m F_j = target``.

    Fast path: exact linear-contact solution, then joint Newton. Positions it
    does not settle go through the bracketed nested solver.
    """
    a_c = np.where(geo.loadable, geo.advance, 0.0)
    a_m = np.where(geo.loadable, geo.arm, 0.0)
    h0 = np.where(geo.loadable, geo.gap, -1e300)
    tau = _linear_tau(a_c, a_m, h0, comp.slope0, target)
    tau, F, iterations, ok = _newton(a_c, a_m, h0, comp, target, tau, rtol=rtol)
    if not np.all(ok):
        bad = np.flatnonzero(~ok)
        sub = comp.take(bad)
        t2, F2, it2 = _nested(a_c[bad], a_m[bad], h0[bad], sub, target, rtol=rtol)
        tau[bad] = t2
        F[bad] = F2
        iterations += it2
    mom = np.sum(a_m * F, axis=1)
    # Scale of the residual: the forces, and the forces the gross terms of
    # h = tau a + gap would give before they cancel (a gap closed by a large
    # cam rotation leaves only round-off of those terms).
    gross = np.where(geo.loadable, np.abs(tau[:, None] * a_c) + np.abs(geo.gap), 0.0)
    scale = np.sum(np.abs(a_m) * (np.abs(F) + gross / comp.slope0), axis=1)
    res = mom - target
    rel = np.abs(res) / (abs(target) + scale + 1e-300)
    return tau, F, iterations, res, rel


def solve_forces(
    design: GearDesign,
    input_torque: float,
    crank_angles: np.ndarray | None = None,
    *,
    positions: int = 3600,
    load_share: float = 0.55,
    errors: ManufacturingErrors | None = None,
    variants: tuple[str, ...] = (),
    contact_model: str = "nonlinear",
    psi_contact_limit: float = math.pi,
    rtol: float = _RTOL,
) -> ForceResult:
    """Mesh forces on every roller at each crank angle.

    Parameters
    ----------
    design : GearDesign
    input_torque : float, N*mm
        Crankshaft moment ``M0``; one cam carries ``load_share * M0``.
    crank_angles : (P,) float, rad, optional
        Positions to solve; default ``positions`` evenly over a cycle, using
        the ``2 pi/(z+1)`` periodicity to solve each class once.
    errors : ManufacturingErrors, optional
    variants : tuple of str
        Printed-paper forms to switch on (:data:`VARIANTS`).
    contact_model : {"nonlinear", "linear"}
    psi_contact_limit : float, rad
        Rollers with ``|psi|`` beyond it (wrapped, 0 at the tooth space) find
        no gear flank and carry nothing: the trimmed tips of an allowed undercut.
    rtol : float
        Relative tolerance of the moment balance and the contact equations.
        ``success`` requires the moment residual below ``max(rtol, 1e-9)``.

    Examples
    --------
    >>> import numpy as np
    >>> from corr_cad import GearDesign, solve_forces
    >>> res = solve_forces(GearDesign(), 1.1e5, positions=360)   # M0 = 110 N*m
    >>> res.F_j.shape                       # (positions, z + 1 rollers), N
    (360, 26)
    >>> res.success, round(float(res.F_n.max()))   # peak gear force over all rollers, N
    (True, 2882)
    >>> one = solve_forces(GearDesign(), 1.1e5, np.radians([90.0]))
    >>> int(one.loaded_count[0])            # rollers carrying load at 90 deg
    13
    """
    if contact_model not in CONTACT_MODELS:
        raise SolverError(
            f"contact_model = {contact_model!r}: must be one of {', '.join(CONTACT_MODELS)}"
        )
    for name, v in (("input_torque", input_torque), ("load_share", load_share)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise SolverError(f"{name} = {v!r}: must be a finite number")
    if not 0.0 < load_share <= 1.0:
        raise SolverError(f"load_share = {load_share!r}: allowed range is (0, 1]")
    errors = errors or ManufacturingErrors()
    R = design.roller_count
    full_cycle = crank_angles is None
    if full_cycle:
        angles = cycle_angles(positions)
        N = len(angles)
        periodic = not errors.per_roller and "eq3_printed" not in variants
        if periodic:
            cls = (np.arange(N) * R) % N
            _, first, inverse = np.unique(cls, return_index=True, return_inverse=True)
            canon = first[inverse]
            shift = ((np.arange(N) - canon) * R // N) % R
            solve_angles = angles[first]
        else:
            solve_angles = angles
    else:
        angles = np.asarray(crank_angles, dtype=float).reshape(-1)
        if angles.size == 0 or not np.all(np.isfinite(angles)):
            raise SolverError("crank_angles must be a non-empty array of finite angles (rad)")
        periodic = False
        solve_angles = angles

    target = load_share * float(input_torque)
    sign = 1.0 if input_torque >= 0 else -1.0
    block = max(1, _BLOCK_ELEMENTS // R)
    pieces = []
    for a in range(0, len(solve_angles), block):
        geo = roller_geometry(
            design, solve_angles[a : a + block], errors, variants, psi_contact_limit
        )
        if "working_half_only" in variants:
            geo = replace(geo, loadable=geo.loadable & (sign * geo.arm > 0))
        comp = _Compliance(geo, design, contact_model)
        tau, Fj, iterations, _, rel = _solve_positions(geo, comp, target, rtol)
        pieces.append(
            _result(
                design,
                geo,
                Fj,
                tau,
                rel,
                iterations,
                solve_angles[a : a + block],
                target,
                0,
                comp=comp,
            )
        )
    out = _concatenate(pieces) if len(pieces) > 1 else pieces[0]
    out.positions_solved = len(solve_angles)
    out.full_cycle = full_cycle
    if periodic:
        # Position n is its class's solution with the rollers turned by shift[n].
        flat = inverse.reshape(-1)[:, None] * R + (np.arange(R)[None, :] - shift[:, None]) % R
        flat = flat.reshape(-1)
        idx = inverse.reshape(-1)

        def remap(v):
            if isinstance(v, np.ndarray) and v.ndim == 2:
                return v.reshape(-1).take(flat).reshape(N, R)
            return v

        psi = np.mod(angles[:, None] - np.arange(R)[None, :] * design.slot_pitch_rad, 2 * np.pi)
        geo = _ExpandedGeometry(out.geometry, remap, psi)
        fields = {k: remap(v) for k, v in out.__dict__.items() if k not in ("geometry", "psi")}
        fields.update(
            geometry=geo,
            psi=psi,
            crank_angles=angles,
            cam_rotation=out.cam_rotation[idx],
        )
        out = ForceResult(**fields)
    return out


class _ExpandedGeometry:
    """The :class:`RollerGeometry` of a full cycle, each field expanded on first use.

    A full cycle solves one position per periodicity class; the per-position
    geometry is the class's, with the rollers turned. Expanding every field
    up front costs more than the solve, and most callers read few of them.
    """

    def __init__(self, compact: RollerGeometry, remap, psi: np.ndarray):
        self._compact = compact
        self._remap = remap
        self.psi = psi

    def __getattr__(self, name: str):
        if name.startswith("_"):
            raise AttributeError(name)
        value = self._remap(getattr(self._compact, name))
        setattr(self, name, value)
        return value

    def expanded(self) -> RollerGeometry:
        """A plain :class:`RollerGeometry` with every field expanded."""
        return RollerGeometry(**{k: getattr(self, k) for k in RollerGeometry.__dataclass_fields__})


#: Elements (positions x rollers) solved together: small enough that the
#: solver's temporaries stay in the CPU cache (about 2x faster than one large
#: batch). Each position is solved on its own, so the block size changes no bit.
_BLOCK_ELEMENTS = 6000


def _concatenate(pieces: list[ForceResult]) -> ForceResult:
    """Stack block results along positions."""
    first = pieces[0]

    def cat(vals):
        v = vals[0]
        if isinstance(v, np.ndarray) and v.ndim >= 1:
            return np.concatenate(vals, axis=0)
        return v

    geo = RollerGeometry(
        **{k: cat([getattr(p.geometry, k) for p in pieces]) for k in first.geometry.__dict__}
    )
    fields = {
        k: cat([getattr(p, k) for p in pieces])
        for k in first.__dict__
        if k not in ("geometry", "iterations", "moment_residual", "success", "message")
    }
    worst = max(p.moment_residual for p in pieces)
    bad = [p for p in pieces if not p.success]
    return ForceResult(
        success=not bad,
        message=bad[0].message if bad else first.message,
        iterations=max(p.iterations for p in pieces),
        moment_residual=worst,
        geometry=geo,
        **fields,
    )


def _result(
    design,
    geo,
    Fj,
    tau,
    rel,
    iterations,
    angles,
    target,
    solved,
    full_cycle=False,
    rtol=_RTOL,
    comp: _Compliance | None = None,
) -> ForceResult:
    """Forces, pressures and validity from the solved cam forces.

    ``comp``: the compliance the solve used; its half-width factors (the
    same expressions of the same arrays) are reused.
    """
    Fn = geo.rho_n * Fj
    Fs = geo.rho_s * Fj
    length = design.roller_length
    modulus = design.material.contact_modulus
    k1 = geo.k_roller
    if comp is not None:
        cj, cn, cs = comp.cj, comp.cn, comp.cs
    else:
        cj = contact.half_width_sq_per_force(k1, geo.k_cam, length, modulus)
        cn = contact.half_width_sq_per_force(k1, geo.k_gear, length, modulus)
        cs = contact.half_width_sq_per_force(k1, 0.0, length, modulus)
    uj, un, us = cj * Fj, cn * Fn, cs * np.abs(Fs)
    limit = max(rtol, 1e-9)
    success = bool(np.all(rel <= limit))
    worst = float(rel.max()) if rel.size else 0.0
    msg = (
        "converged"
        if success
        else f"moment balance not reached to {limit:g} (worst relative residual {worst:.3g})"
    )
    return ForceResult(
        success=success,
        message=msg,
        iterations=int(iterations),
        moment_residual=worst,
        crank_angles=angles,
        psi=geo.psi,
        F_j=Fj,
        F_s=Fs,
        F_n=Fn,
        p_cam=contact.max_pressure(Fj, cj, length),
        p_slot=contact.max_pressure(np.abs(Fs), cs, length),
        p_gear=contact.max_pressure(Fn, cn, length),
        valid_cam=contact.is_valid(uj, k1, geo.k_cam),
        valid_slot=contact.is_valid(us, k1, 0.0),
        valid_gear=contact.is_valid(un, k1, geo.k_gear),
        cam_rotation=tau,
        cam_moment=target,
        positions_solved=int(solved),
        geometry=geo,
        full_cycle=full_cycle,
    )


class BatchSolver:
    """Many error samples at the same crank angles: the nominal geometry is built once.

    Only the gaps and the contact curvatures depend on the errors, so each
    sample costs its own :func:`_error_gaps` and the solve. Results are
    identical, bit for bit, to :func:`roller_geometry` per sample.
    """

    def __init__(
        self,
        design: GearDesign,
        crank_angles: np.ndarray,
        *,
        input_torque: float,
        load_share=0.55,
        psi_contact_limit: float = math.pi,
    ):
        self.design = design
        self.angles = np.asarray(crank_angles, dtype=float).reshape(-1)
        # The contact limit (trimmed tooth tips) only masks the nominal
        # geometry's ``loadable``, which every sample shares.
        self.nominal = roller_geometry(design, self.angles, psi_contact_limit=psi_contact_limit)
        self.target = load_share * float(input_torque)
        R = design.roller_count
        self.theta = np.arange(R) * design.slot_pitch_rad

    def geometry(self, errors_list: list[ManufacturingErrors]) -> RollerGeometry:
        """The stacked (sample-major) geometry of ``errors_list``."""
        g0 = self.nominal
        d = self.design
        n = len(errors_list)
        gaps, k_roller, k_cam = [], [], []
        r, Rj = d.roller_radius, d.cam_radius
        for err in errors_list:
            if err.any:
                gap, dr = _error_gaps(
                    d, err, self.angles, self.theta, g0.psi, g0.s, g0.rho_n, g0.rho_s
                )
            else:
                gap, dr = np.zeros_like(g0.psi), np.zeros_like(g0.psi)
            gaps.append(gap)
            k_roller.append(1.0 / (r + dr))
            k_cam.append(1.0 / (Rj + err.cam_radius_error))
        P = len(self.angles)

        def tile(a):
            return np.tile(a, (n, 1))

        return RollerGeometry(
            psi=tile(g0.psi),
            s=tile(g0.s),
            rho_n=tile(g0.rho_n),
            rho_s=tile(g0.rho_s),
            advance=tile(g0.advance),
            arm=tile(g0.arm),
            gap=np.concatenate(gaps, axis=0),
            k_roller=np.concatenate(k_roller, axis=0),
            k_cam=np.repeat(np.asarray(k_cam, dtype=float), P)[:, None],
            k_gear=tile(g0.k_gear),
            loadable=tile(g0.loadable),
        )

    def solve(self, errors_list: list[ManufacturingErrors]) -> ForceResult:
        """Rows ``k P .. (k+1) P - 1`` of the result belong to ``errors_list[k]``."""
        geo = self.geometry(errors_list)
        comp = _Compliance(geo, self.design, "nonlinear")
        tau, Fj, iterations, _, rel = _solve_positions(geo, comp, self.target)
        return _result(
            self.design,
            geo,
            Fj,
            tau,
            rel,
            iterations,
            np.tile(self.angles, len(errors_list)),
            self.target,
            len(tau),
            False,
            comp=comp,
        )


def solve_forces_batch(
    design: GearDesign,
    input_torque: float,
    crank_angles: np.ndarray,
    errors_list: list[ManufacturingErrors],
    *,
    load_share: float = 0.55,
    psi_contact_limit: float = math.pi,
) -> ForceResult:
    """Solve many error samples at the same crank angles in one vectorised call.

    Returns one :class:`ForceResult` whose rows are sample-major: rows
    ``k P .. (k+1) P - 1`` belong to ``errors_list[k]`` (``P`` angles).
    """
    solver = BatchSolver(
        design,
        crank_angles,
        input_torque=input_torque,
        load_share=load_share,
        psi_contact_limit=psi_contact_limit,
    )
    return solver.solve(errors_list)
