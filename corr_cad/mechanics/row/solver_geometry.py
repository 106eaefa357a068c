"""Geometry of the force model: per (crank position, roller) directions, arms and gaps.

Split out of :mod:`corr_cad.mechanics.row.solver` (the model is described there); the
names are re-exported from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors

__all__ = ["VARIANTS", "RollerGeometry", "cycle_angles", "roller_geometry"]

#: Printed forms of the paper that can be switched on to reproduce it:
#: ``eq3_printed``: gear normal from Eq. (3) as printed (arctan, no ``e``);
#: ``eq16_sin_gamma``: compatibility advance ``e sin(gamma)`` (Eq. 16) instead
#: of the moment arm; ``rj_for_link_length``: ``L = Rj`` in Eqs. (6)-(7);
#: ``working_half_only``: only rollers on the working half may carry load.
VARIANTS = ("eq3_printed", "eq16_sin_gamma", "rj_for_link_length", "working_half_only")


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


def _angles(design: GearDesign, crank_angles: np.ndarray) -> tuple:
    """The crank angles ``phi`` (P,), the slots' polar angles ``theta`` (R,) and
    ``psi = phi - theta`` (P, R), rad."""
    phi = np.asarray(crank_angles, dtype=float).reshape(-1)
    theta = np.arange(design.roller_count) * design.slot_pitch_rad
    return phi, theta, phi[:, None] - theta[None, :]


def _loadable(psi: np.ndarray, psi_contact_limit: float) -> np.ndarray:
    """Rollers that may carry a force, bool (P, R): all but those on the trimmed tooth tips of
    an allowed undercut (``|psi| > psi_contact_limit``)."""
    loadable = np.ones(psi.shape, dtype=bool)
    if psi_contact_limit < math.pi:
        loadable &= np.abs(_wrap(psi)) <= psi_contact_limit
    return loadable


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
    e, Rj, r = design.eccentricity, design.cam_radius, design.roller_radius
    L = Rj + r
    phi, theta, psi = _angles(design, crank_angles)
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

    loadable = _loadable(psi, psi_contact_limit)
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
    """Initial interference per roller from the errors (see ``corr_cad.geometry.deviations``).

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
    if errors.slot_clearance is None:  # one row: an oversize roller is taken up by its slot
        clearance_slot = np.maximum(-dr, 0.0)
    else:  # the slot's fit: each flank opens by c/2 - dr (negative: interference)
        clearance_slot = 0.5 * errors.slot_clearance - dr
    return g_j + rho_n * g_n - np.abs(rho_s) * clearance_slot, dr
