"""Fast path of :func:`~corr_cad.mechanics.row.solver.solve_forces` for a design without errors.

Without manufacturing errors every gap is zero, the roller and cam
curvatures are one number each, and the model's quantities have closed forms
in ``sin psi`` (:func:`nominal_geometry`). With zero gaps a roller can carry
load only where its advance has the sign of the moment (``tau a > 0``), so
the solve runs on a window of ``R // 2 + 2`` consecutive rollers per position
that holds all of them (checked; the full width otherwise), about half the
rollers. The linear-contact start is closed-form: ``tau = M / sum(a^2 / k0)``
over those rollers. Newton is the shared :func:`~corr_cad.mechanics.row.solver_numerics._newton`.

Monte Carlo (``BatchSolver``) never comes here: its results stay bit for bit
those of the general path. A single design's forces agree with the general
path to round-off (``tests/test_solver.py::test_nominal_fast_path_equals_general_path``).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from corr_cad.geometry.design import GearDesign
from corr_cad.mechanics import contact
from corr_cad.mechanics.row.solver_geometry import RollerGeometry, _angles, _loadable
from corr_cad.mechanics.row.solver_numerics import _RTOL, _Compliance, _Contact, _nested, _newton

__all__ = ["nominal_geometry", "solve_nominal"]


def nominal_geometry(
    design: GearDesign, crank_angles: np.ndarray, psi_contact_limit: float = math.pi
) -> RollerGeometry:
    """:func:`~corr_cad.mechanics.row.solver_geometry.roller_geometry`, closed form.

    Without errors or variants.

    ``sin psi`` and ``cos psi`` by the angle difference from the crank's and
    the slots' (no transcendental per roller); with ``W = sqrt(L^2 - e^2
    sin^2 psi)`` and ``tan beta = z e sin psi / W``:
    ``rho_n = 1 / cos beta = sqrt(1 + (z^2 - 1) (e sin psi / L)^2)``,
    ``rho_s = -(z + 1) e sin psi / L`` (reported sign), and the locus
    curvature ``(1 + 2 tan^2 beta - z^2 s''/s) cos^3 beta / s``.
    """
    z, R = design.tooth_count, design.roller_count
    e, Rj, r = design.eccentricity, design.cam_radius, design.roller_radius
    L = Rj + r
    phi, theta, psi = _angles(design, crank_angles)
    # One (P, 2) x (2, 2R) product: sin(phi - theta) | cos(phi - theta). A
    # broadcast (P, 1) x (R,) loop pays numpy's per-row overhead 4 times.
    s_th, c_th = np.sin(theta), np.cos(theta)
    sc = np.stack([np.sin(phi), np.cos(phi)], axis=1) @ np.array(
        [np.concatenate([c_th, s_th]), np.concatenate([-s_th, c_th])]
    )
    sp, cp = sc[:, :R], sc[:, R:]
    esp = e * sp
    ecp = e * cp
    esp2 = esp * esp
    W = np.sqrt(L * L - esp2)
    s = ecp + W
    rho_n = np.sqrt(1.0 + ((z * z - 1) / (L * L)) * esp2)
    tan2 = (z * z) * esp2 / (W * W)
    # s'' (d/dpsi) of kinematics.centre_distance_derivatives, cos 2psi = 1 - 2 sin^2 psi.
    d2s = -ecp - (e * e - 2.0 * esp2) / W - esp2 * (ecp * ecp) / (W * W * W)
    cos_b = W / (L * rho_n)
    k_locus = (1.0 + 2.0 * tan2 - (z * z) * d2s / s) * (cos_b * cos_b * cos_b) / s
    arm = (-1.0 / L) * esp * s
    loadable = _loadable(psi, psi_contact_limit)
    return RollerGeometry(
        psi=psi,
        s=s,
        rho_n=rho_n,
        rho_s=(-(z + 1) / L) * esp,
        advance=arm,
        arm=arm.copy(),
        gap=np.zeros(psi.shape),
        k_roller=np.full(psi.shape, 1.0 / r),
        k_cam=1.0 / Rj,
        k_gear=-k_locus / (1.0 + r * k_locus),
        loadable=loadable,
    )


def _window(design: GearDesign, phi: np.ndarray, sign: float, cand: np.ndarray) -> np.ndarray:
    """Flat indices (P, K) of ``K`` consecutive rollers holding every candidate of a position.

    The rollers with ``sign * a > 0`` have ``psi`` in ``(-pi, 0)`` (forward
    moment) or ``(0, pi)``: the window starts at the roller with ``psi`` in
    ``[0, pitch)`` (or ``[pi, pi + pitch)``). Falls back to all rollers when a
    candidate is outside (round-off at the window's ends, a small ``R``).
    """
    P, R = cand.shape
    K = R // 2 + 2
    rows = np.arange(P)[:, None] * R
    if K >= R:
        return rows + np.arange(R)
    offset = 0.0 if sign > 0 else math.pi
    start = np.floor((phi - offset) / design.slot_pitch_rad).astype(np.intp)
    flat = rows + (start[:, None] + np.arange(K)) % R
    if np.count_nonzero(cand.reshape(-1).take(flat)) != np.count_nonzero(cand):
        return rows + np.arange(R)
    return flat


def solve_nominal(
    design: GearDesign,
    geo: RollerGeometry,
    phi: np.ndarray,
    target: float,
    contact_model: str,
    rtol: float = _RTOL,
):
    """Cam forces of a design without errors: ``(tau, F_j, iterations, rel, factors)``.

    ``geo`` from :func:`nominal_geometry` (its ``loadable`` may be narrowed).
    Returns None where the general path must answer: zero moment, or a
    position where no roller can carry it (the general path raises).
    ``factors``: the half-width factors ``cj, cn, cs`` for the pressures.
    """
    if target == 0.0:
        return None
    sign = 1.0 if target > 0 else -1.0
    P, R = geo.psi.shape
    cand = geo.loadable & (sign * geo.arm > 0)
    flat = _window(design, phi, sign, cand)
    K = flat.shape[1]

    def win(x):
        return x.reshape(-1).take(flat)

    a = np.where(win(cand), win(geo.arm), 0.0)
    wn = win(geo.rho_n)
    ws = np.abs(win(geo.rho_s))
    length = design.roller_length
    modulus = design.material.contact_modulus
    k1 = 1.0 / design.roller_radius
    cj = contact.half_width_sq_per_force(k1, geo.k_cam, length, modulus)
    cn_all = contact.half_width_sq_per_force(k1, geo.k_gear, length, modulus)
    cs = contact.half_width_sq_per_force(k1, 0.0, length, modulus)
    comp = object.__new__(_Compliance)
    comp.linear = contact_model == "linear"
    comp.slope0 = contact.linear_compliance(length, modulus) * (1.0 + wn * wn + ws * ws)
    if not comp.linear:
        cn = win(cn_all)
        comp.contacts = [
            _Contact(None, cj, k1, geo.k_cam),
            _Contact(wn, cn, k1, win(geo.k_gear)),
            _Contact(ws, cs, k1, 0.0),
        ]
    S = np.sum(a * a / comp.slope0, axis=1)
    if not np.all(S > 0):
        return None
    tau = target / S
    h0 = np.zeros((P, K))
    tau, F, iterations, ok = _newton(a, a, h0, comp, target, tau, rtol=rtol)
    if not np.all(ok):
        bad = np.flatnonzero(~ok)
        t2, F2, it2 = _nested(a[bad], a[bad], h0[bad], comp.take(bad), target, rtol=rtol)
        tau[bad] = t2
        F[bad] = F2
        iterations += it2
    # The residual's scale as in _solve_positions (no gaps: the gross terms are |tau a|).
    mom = np.sum(a * F, axis=1)
    scale = np.sum(np.abs(a) * (F + np.abs(tau[:, None] * a) / comp.slope0), axis=1)
    rel = np.abs(mom - target) / (abs(target) + scale + 1e-300)
    Fj = np.zeros(P * R)
    Fj[flat.reshape(-1)] = F.reshape(-1)
    return tau, Fj.reshape(P, R), iterations, rel, SimpleNamespace(cj=cj, cn=cn_all, cs=cs)
