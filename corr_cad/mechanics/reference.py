"""A slow, scalar reference solver that shares no code with the package's model.

It imports nothing from :mod:`corr_cad` (no kinematics, contact law, error
mapping or solver) and reads only plain attributes of the design and error
objects it is given. Everything is derived here again from the paper's
geometry, one crank position and one roller at a time, with Python floats
and ``scipy.optimize.brentq``:

* **Placement.** The cam centre ``O1`` is at distance ``e`` from the axis at
  the crank's absolute angle; each roller centre lies on its slot line at
  exactly ``L = Rj + r`` from ``O1`` (found by ``brentq``, not by a formula).
* **Gear profile.** The roller-centre locus is the set of these centres on
  the fixed gear, ``P(t) = s(z t) (sin t, cos t)``, with ``s`` from the law
  of cosines in the triangle axis - cam centre - roller centre. Its tangent
  and curvature come from first and second derivatives written out in
  Cartesian coordinates; the working profile is the outer offset by ``r``, so
  its radius of curvature is the locus's plus ``r``.
* **Equilibrium.** Cam force along ``(H - O1)/|H - O1|``, gear force along
  the inward profile normal, slot force along the slot normal: a 2x2 linear
  system solved by Cramer's rule.
* **Contact law.** Hertz half-width ``b^2 = 4 F R* / (pi l E')`` with
  ``1/E' = 2 (1 - nu^2)/E``; each body's approach is the sagitta of its circle
  over the chord ``2 b``, ``R - sqrt(R^2 - b^2)`` (negative for a concave
  body). Refuses forces whose half-width reaches 0.98 of a radius.
* **Compatibility.** The roller moves rigidly by ``d``; the overlap at each
  contact is the initial interference plus the relative motion along its
  normal; the cam's surface moves with its centre, whose velocity per unit
  crank rotation is ``dO1/dphi``.
* **Errors.** Read from the error object's raw fields: radius errors add to
  the cam and gear overlaps and open a slot clearance; an eccentricity or cam
  phase error moves ``O1``; a slot angle error puts the roller where the turned
  slot line meets the gear's locus; a gear profile deviation (harmonics
  evaluated here from their rows) is an interference at the gear.
* **Moment.** ``sum`` of the crank torques of the cam forces, from cross
  products, equals ``load_share M0``; the cam rotation ``tau`` is found by
  ``brentq``.

The tests compare the vectorised solver against it (to 1e-9), and the
benchmark measures the speed-up over it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

__all__ = ["reference_position", "reference_geometry", "locus_frame"]


def _u(t: float) -> tuple[float, float]:
    """Unit vector at polar angle ``t`` (from +y towards +x)."""
    return (math.sin(t), math.cos(t))


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1]


def _cross(a, b) -> float:
    return a[0] * b[1] - a[1] * b[0]


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1])


def _scale(k: float, a):
    return (k * a[0], k * a[1])


def _norm(a) -> float:
    return math.hypot(a[0], a[1])


def _centre_distance(psi: float, e: float, L: float) -> tuple[float, float, float]:
    """Law of cosines ``L^2 = s^2 + e^2 - 2 s e cos psi``: ``s`` and ``ds/dpsi``, ``d2s/dpsi2``."""
    sn, cs = math.sin(psi), math.cos(psi)
    q = L * L - e * e * sn * sn  # the discriminant
    w = math.sqrt(q)
    s = e * cs + w
    # dq/dpsi = -2 e^2 sn cs = -e^2 sin(2 psi); w' = q' / (2 w); w'' = q''/(2w) - q'^2/(4 w^3)
    dq = -(e * e) * math.sin(2.0 * psi)
    d2q = -2.0 * (e * e) * math.cos(2.0 * psi)
    dw = dq / (2.0 * w)
    d2w = d2q / (2.0 * w) - dq * dq / (4.0 * w**3)
    return s, -e * sn + dw, -e * cs + d2w


def locus_frame(t: float, z: int, e: float, L: float) -> dict:
    """The gear's roller-centre locus at polar angle ``t`` (psi = z t).

    Returns the point, the outward unit normal and the locus curvature
    ``k`` (positive where the locus is convex seen from outside, i.e. its
    centre of curvature towards the axis).
    """
    s, ds, d2s = _centre_distance(z * t, e, L)
    st, ct = math.sin(t), math.cos(t)
    # P(t) = s(t) (sin t, cos t); s_t = z s', s_tt = z^2 s''.
    s1, s2 = z * ds, z * z * d2s
    x1, y1 = s1 * st + s * ct, s1 * ct - s * st
    x2 = s2 * st + 2.0 * s1 * ct - s * st
    y2 = s2 * ct - 2.0 * s1 * st - s * ct
    speed = math.hypot(x1, y1)
    n = (y1 / speed, -x1 / speed)  # tangent turned clockwise: outward for a clockwise curve
    if _dot(n, (st, ct)) < 0.0:
        n = (-n[0], -n[1])
    # Signed curvature of a curve run clockwise (as t grows) is negative where
    # it is convex; flip it so that convex-outward is positive.
    k = -(x1 * y2 - y1 * x2) / speed**3
    return {"point": (s * st, s * ct), "normal": n, "curvature": k, "s": s}


def _deviation(dev, t: float) -> float:
    rows = getattr(dev, "harmonics", None)
    if rows is not None:  # rows (order, amplitude mm, phase rad): evaluated here
        return sum(a * math.cos(k * t - p) for k, a, p in rows)
    return float(np.asarray(dev(np.array([t])), dtype=float).reshape(-1)[0])


def reference_geometry(
    design, crank_angle: float, errors=None, psi_contact_limit: float = math.pi
) -> list[dict]:
    """Per-roller geometry at one crank angle (rad, relative to the frame).

    Each entry: ``psi`` (wrapped to (-pi, pi]), ``centre``, cam direction
    ``c``, outward gear normal ``n``, slot direction ``ut``, force ratios
    ``fn = F_n/F_j`` and ``ft`` (slot force along ``ut`` per unit ``F_j``),
    gear curvature seen from the roller ``k_gear`` (negative concave), initial
    interferences ``g_j``, ``g_n``, slot clearance ``clr``, the cam's advance
    along ``c`` per unit crank rotation ``advance``, the roller radius
    ``r_i`` and ``loadable`` (False beyond ``psi_contact_limit``).
    """
    z = int(design.tooth_count)
    R = z + 1
    e, Rj, r = float(design.eccentricity), float(design.cam_radius), float(design.roller_radius)
    L = Rj + r
    pitch = 2.0 * math.pi / R
    dRj = float(getattr(errors, "cam_radius_error", 0.0) or 0.0)
    de = float(getattr(errors, "eccentricity_error", 0.0) or 0.0)
    dr_all = float(getattr(errors, "roller_radius_error", 0.0) or 0.0)
    dr_each = getattr(errors, "roller_radius_errors", None) or (0.0,) * R
    slot_each = getattr(errors, "slot_angle_errors", None) or (0.0,) * R
    dphase = float(getattr(errors, "cam_phase_error", 0.0) or 0.0)
    dev = getattr(errors, "profile_deviation", None)

    # The frame has turned by crank/z; the crank's absolute angle is crank + crank/z.
    theta0 = crank_angle / z
    phi = crank_angle + theta0
    o1 = _scale(e, _u(phi))
    o1_velocity = (e * math.cos(phi), -e * math.sin(phi))  # d O1 / d phi
    o1_act = _scale(e + de, _u(phi + dphase))
    out = []
    for i in range(R):
        theta = theta0 + i * pitch
        ur = _u(theta)
        ut = (math.cos(theta), -math.sin(theta))  # direction of growing polar angle
        s = optimize.brentq(
            lambda x, ur=ur: _norm(_sub(_scale(x, ur), o1)) - L,
            L - e - 1.0,
            L + e + 1.0,
            xtol=1e-14,
            rtol=4 * np.finfo(float).eps,
        )
        h = _scale(s, ur)
        c = _scale(1.0 / _norm(_sub(h, o1)), _sub(h, o1))
        psi = math.remainder(phi - theta, 2.0 * math.pi)
        frame = locus_frame(theta, z, e, L)
        n = frame["normal"]
        # Equilibrium for unit F_j: c - fn n + ft ut = 0 (Cramer's rule).
        det = _cross((-n[0], -n[1]), ut)
        fn = _cross((-c[0], -c[1]), ut) / det
        ft = _cross((-n[0], -n[1]), (-c[0], -c[1])) / det
        k_loc = frame["curvature"]
        # Working profile: radius of curvature of the locus plus r, same centre.
        k_gear = -k_loc / (1.0 + r * k_loc)
        r_i = r + dr_all + float(dr_each[i])
        dri = r_i - r
        t_true = theta + float(slot_each[i])
        h_true = locus_frame(t_true, z, e, L)["point"]
        g_j = dRj + dri + (L - _norm(_sub(h_true, o1_act)))
        g_n = dri + (_deviation(dev, theta) if dev is not None else 0.0)
        out.append(
            {
                "psi": psi,
                "centre": h,
                "c": c,
                "n": n,
                "ut": ut,
                "fn": fn,
                "ft": ft,
                "k_gear": k_gear,
                "r_i": r_i,
                "g_j": g_j,
                "g_n": g_n,
                "clr": max(-dri, 0.0),
                "advance": _dot(c, o1_velocity),
                "o1": o1,
                "loadable": abs(psi) <= psi_contact_limit,
            }
        )
    return out


def _sag(b2: float, k: float) -> float:
    """Sagitta of a circle of signed curvature ``k`` over the chord ``2 b``."""
    if k == 0.0:
        return 0.0
    R = 1.0 / k
    return math.copysign(abs(R) - math.sqrt(R * R - b2), R)


def reference_position(
    design,
    input_torque: float,
    crank_angle: float,
    load_share: float = 0.55,
    errors=None,
    psi_contact_limit: float = math.pi,
) -> tuple[np.ndarray, float]:
    """Cam forces ``F_j`` (z + 1,) and cam rotation at one crank angle (rad)."""
    rollers = reference_geometry(design, crank_angle, errors, psi_contact_limit)
    length = float(design.roller_length)
    E, nu = float(design.material.young_modulus), float(design.material.poisson_ratio)
    Ep = E / (2.0 * (1.0 - nu * nu))
    k_cam = 1.0 / (float(design.cam_radius) + float(getattr(errors, "cam_radius_error", 0.0)))

    def delta(F: float, k1: float, k2: float) -> float:
        if F <= 0.0:
            return 0.0
        b2 = 4.0 * F / (math.pi * length * Ep * (k1 + k2))
        return _sag(b2, k1) + _sag(b2, k2)

    def f_limit(k1: float, k2: float, weight: float) -> float:
        # Force at which b reaches 0.98 of the smaller radius.
        kmax = max(abs(k1), abs(k2))
        return 0.98**2 / kmax**2 * math.pi * length * Ep * (k1 + k2) / 4.0 / max(weight, 1e-300)

    def roller_force(tau: float, g: dict) -> float:
        if not g["loadable"]:
            return 0.0
        k_r = 1.0 / g["r_i"]
        n, ut, c = g["n"], g["ut"], g["c"]

        def residual(Fj: float) -> float:
            Fn, Ft = g["fn"] * Fj, g["ft"] * Fj
            dn = delta(Fn, k_r, g["k_gear"])
            ds = delta(abs(Ft), k_r, 0.0)
            # d.n = dn - g_n; d.ut = -(clr + ds) towards the wall that pushes back.
            a_n = dn - g["g_n"]
            a_t = -math.copysign(g["clr"] + ds, Ft) if Ft != 0.0 else 0.0
            # Solve d from d.n = a_n, d.ut = a_t (Cramer).
            det = n[0] * ut[1] - n[1] * ut[0]
            d = ((a_n * ut[1] - n[1] * a_t) / det, (n[0] * a_t - a_n * ut[0]) / det)
            overlap = g["g_j"] + tau * g["advance"] - _dot(d, c)
            return delta(Fj, k_r, k_cam) - overlap

        if residual(0.0) >= 0.0 or residual(1e-300) >= 0.0:
            return 0.0
        hi = min(
            f_limit(k_r, k_cam, 1.0),
            f_limit(k_r, g["k_gear"], abs(g["fn"])),
            f_limit(k_r, 0.0, abs(g["ft"])),
        )
        if residual(hi) < 0.0:
            raise ValueError("reference solver: contact outside the model's validity")
        return optimize.brentq(residual, 0.0, hi, xtol=1e-300, rtol=1e-15, maxiter=500)

    target = load_share * input_torque

    def moment(tau: float) -> float:
        total = 0.0
        for g in rollers:
            F = roller_force(tau, g)
            total += _cross(g["o1"], _scale(-F, g["c"]))
        return total - target

    # Bracket from a linear-contact estimate, grown gently.
    lam = 2.0 / (math.pi * length * Ep)
    stiff = sum(
        g["advance"]
        * _cross(g["o1"], _scale(-1.0, g["c"]))
        / (lam * (1 + g["fn"] ** 2 + g["ft"] ** 2))
        for g in rollers
        if g["advance"] > 0 and g["loadable"]
    )
    gaps = max(abs(g["g_j"]) + abs(g["g_n"]) + g["clr"] for g in rollers)
    seed = abs(target) / stiff + gaps / max(abs(g["advance"]) for g in rollers) + 1e-300
    hi, lo = 0.5 * seed, -0.5 * seed
    while moment(hi) < 0:
        hi *= 1.3
    while moment(lo) > 0:
        lo *= 1.3
    tau = optimize.brentq(moment, lo, hi, xtol=1e-300, rtol=1e-15, maxiter=500)
    return np.array([roller_force(tau, g) for g in rollers]), tau
