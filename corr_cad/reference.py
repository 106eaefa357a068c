"""A slow, scalar reference solver, independent of :mod:`corr_cad.solver`.

It solves one crank position at a time with plain vectors and
``scipy.optimize.brentq``: force ratios from a 2x2 equilibrium solve,
compatibility from the roller's explicit rigid displacement, the cam's
advance from the velocity of its centre, the moment from cross products, and
the textbook (cancelling) overlap formula ``R - sqrt(R^2 - b^2)``. The tests
compare the vectorised solver against it, and the benchmark measures the
speed-up over it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from . import kinematics as kin
from .design import GearDesign
from .deviations import ManufacturingErrors

__all__ = ["reference_position"]


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _overlap(b2: float, R: float) -> float:
    # Convex R > 0: R - sqrt(R^2 - b^2); concave R < 0: -(|R| - sqrt(R^2 - b^2)).
    if math.isinf(R):
        return 0.0
    return math.copysign(abs(R) - math.sqrt(R * R - b2), R)


def reference_position(
    design: GearDesign,
    input_torque: float,
    crank_angle: float,
    load_share: float = 0.55,
    errors: ManufacturingErrors | None = None,
) -> tuple[np.ndarray, float]:
    """Cam forces ``F_j`` (z + 1,) and cam rotation at one crank angle (rad)."""
    errors = errors or ManufacturingErrors()
    z, R = design.tooth_count, design.roller_count
    e, Rj, r = design.eccentricity, design.cam_radius, design.roller_radius
    L = Rj + r
    length = design.roller_length
    Ep = design.material.contact_modulus
    dr_all = errors.roller_errors(R)
    # ``crank_angle`` is relative to the frame: phi_rel = z theta_frame.
    # Place the mechanism in the fixed gear's coordinates.
    theta0 = crank_angle / z
    phi_abs = crank_angle + theta0
    o1 = e * kin.unit_radial(phi_abs)
    o1_velocity = e * kin.unit_tangential(phi_abs)  # d O1 / d phi
    e_act = e + errors.eccentricity_error
    o1_act = e_act * kin.unit_radial(phi_abs + errors.cam_phase_error)
    slot_err = errors.slot_errors(R)

    rollers = []
    for i in range(R):
        theta = theta0 + i * design.slot_pitch_rad
        ur, ut = kin.unit_radial(theta), kin.unit_tangential(theta)
        # Roller centre on the slot line at distance L from the cam centre.
        s = optimize.brentq(
            lambda x, ur=ur: np.linalg.norm(x * ur - o1) - L, L - e - 1.0, L + e + 1.0, xtol=1e-14
        )
        h = s * ur
        c = (h - o1) / np.linalg.norm(h - o1)
        psi = phi_abs - theta
        t_polar = math.atan2(h[0], h[1])
        tangent = kin.locus_derivative(np.array([t_polar]), z, e, L)[0]
        n = np.array([tangent[1], -tangent[0]])
        n /= np.linalg.norm(n)
        if np.dot(n, ur) < 0:
            n = -n
        # Equilibrium F_j c + F_n (-n) + F_t u_t = 0 for unit F_j.
        A = np.column_stack([-n, ut])
        fn, ft = np.linalg.solve(A, -c)
        k_loc = float(kin.locus_curvature(np.array([psi]), z, e, L)[0])
        rho_gear_locus = 1.0 / k_loc if k_loc != 0 else math.inf
        rho_w = rho_gear_locus + r  # working-profile radius, centre towards the axis if > 0
        R_gear = -rho_w  # as seen from the roller: concave (negative) when rho_w > 0
        dr = dr_all[i]
        r_i = r + dr
        # Where the (turned) slot line meets the gear's roller-centre locus.
        t_true = theta + slot_err[i]
        h_true = float(kin.centre_distance(z * t_true, e, L)) * kin.unit_radial(t_true)
        g_j = errors.cam_radius_error + dr + (L - float(np.linalg.norm(h_true - o1_act)))
        g_n = dr
        if errors.profile_deviation is not None:
            g_n += float(errors.profile_deviation(np.array([theta]))[0])
        slot_clear = max(-dr, 0.0)
        advance = float(np.dot(c, o1_velocity))
        rollers.append((h, c, n, ut, fn, ft, R_gear, r_i, g_j, g_n, slot_clear, advance))

    def delta(F: float, R1: float, R2: float) -> float:
        if F <= 0:
            return 0.0
        inv = 1.0 / R1 + (0.0 if math.isinf(R2) else 1.0 / R2)
        b2 = 4.0 * F / (math.pi * length * Ep * inv)
        return _overlap(b2, R1) + _overlap(b2, R2)

    def roller_force(tau: float, k: int) -> float:
        h, c, n, ut, fn, ft, R_gear, r_i, g_j, g_n, clr, adv = rollers[k]
        Rc = Rj + errors.cam_radius_error

        def residual(Fj: float) -> float:
            Fn, Ft = fn * Fj, ft * Fj
            dn = delta(Fn, r_i, R_gear)
            ds = delta(abs(Ft), r_i, math.inf)
            # Roller displacement: d.n = dn - g_n; along u_t towards the wall
            # that pushes back (sign opposite to Ft), by clearance + ds.
            x_t = -math.copysign(clr + ds, Ft) if Ft != 0 else 0.0
            M = np.array([n, ut])
            d = np.linalg.solve(M, np.array([dn - g_n, x_t]))
            dj_kin = tau * adv - float(np.dot(d, c)) + g_j
            return delta(Fj, r_i, Rc) - dj_kin

        # Slot clearance makes the residual jump at F = 0+: check just above 0.
        if residual(0.0) >= 0.0 or residual(1e-300) >= 0.0:
            return 0.0

        def f_limit(R1: float, R2: float, weight: float) -> float:
            # Force at which b reaches 0.98 of the smaller radius (validity).
            inv = 1.0 / R1 + (0.0 if math.isinf(R2) else 1.0 / R2)
            rmin = min(abs(R1), abs(R2))
            return 0.98**2 * rmin**2 * math.pi * length * Ep * inv / 4.0 / max(weight, 1e-300)

        hi = min(
            f_limit(r_i, Rc, 1.0), f_limit(r_i, R_gear, abs(fn)), f_limit(r_i, math.inf, abs(ft))
        )
        if residual(hi) < 0.0:
            raise ValueError("reference solver: contact outside the model's validity")
        return optimize.brentq(residual, 0.0, hi, xtol=1e-300, rtol=1e-15, maxiter=500)

    target = load_share * input_torque

    def moment(tau: float) -> float:
        total = 0.0
        for k in range(R):
            F = roller_force(tau, k)
            c = rollers[k][1]
            # The roller pushes the cam with -F c along a line through O1; the
            # crank must supply the opposite torque. Angles grow clockwise
            # (from +y towards +x), so a torque along growing phi is -cross.
            total += _cross(o1, -F * c)
        return total - target

    # Bracket from a linear-contact estimate, grown gently (an overshoot would
    # leave the contact model's validity).
    lam = 2.0 / (math.pi * length * Ep)
    stiff = sum(
        rl[11] * _cross(o1, -rl[1]) / (lam * (1 + rl[4] ** 2 + rl[5] ** 2))
        for rl in rollers
        if rl[11] > 0
    )
    gaps = max(abs(rl[8]) + abs(rl[9]) + rl[10] for rl in rollers)
    seed = abs(target) / stiff + gaps / max(abs(rl[11]) for rl in rollers) + 1e-300
    hi, lo = 0.5 * seed, -0.5 * seed
    while moment(hi) < 0:
        hi *= 1.3
    while moment(lo) > 0:
        lo *= 1.3
    tau = optimize.brentq(moment, lo, hi, xtol=1e-300, rtol=1e-15, maxiter=500)
    return np.array([roller_force(tau, k) for k in range(R)]), tau
