"""Crank-slider kinematics of the second stage and the roller-centre locus.

Conventions (as in the paper): angles are measured from the +y axis towards
+x, so a point at polar angle ``t`` and radius ``s`` is ``s (sin t, cos t)``.
``psi`` is the angle between the eccentric and a slot; on the fixed gear the
roller centre at polar angle ``t`` has ``psi = z t``. A tooth space (roller
centre at its largest radius) lies on +y at ``t = 0``.

All functions are vectorised over ``psi`` (or ``t``) and pure numpy.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "unit_radial",
    "unit_tangential",
    "rotate_by_polar_angle",
    "centre_distance",
    "centre_distance_derivatives",
    "normal_offset_angle",
    "locus_points",
    "locus_derivative",
    "locus_normals",
    "locus_curvature",
    "profile_speed_factor",
    "floating_cam_spin",
]


def unit_radial(t: np.ndarray) -> np.ndarray:
    """Unit vector at polar angle ``t`` (from +y towards +x): (sin t, cos t). Shape (..., 2)."""
    t = np.asarray(t, dtype=float)
    return np.stack([np.sin(t), np.cos(t)], axis=-1)


def unit_tangential(t: np.ndarray) -> np.ndarray:
    """d/dt of :func:`unit_radial`: (cos t, -sin t), pointing towards increasing ``t``."""
    t = np.asarray(t, dtype=float)
    return np.stack([np.cos(t), -np.sin(t)], axis=-1)


def rotate_by_polar_angle(points: np.ndarray, dt_rad: float) -> np.ndarray:
    """Rotate ``points`` (n, 2) so that every polar angle grows by ``dt_rad``."""
    c, s = np.cos(dt_rad), np.sin(dt_rad)
    p = np.asarray(points, dtype=float)
    return np.stack([p[..., 0] * c + p[..., 1] * s, -p[..., 0] * s + p[..., 1] * c], axis=-1)


def _w(psi: np.ndarray, e: float, L: float) -> np.ndarray:
    return np.sqrt(L * L - (e * np.sin(psi)) ** 2)


def centre_distance(psi: np.ndarray, e: float, L: float) -> np.ndarray:
    """Roller-centre distance from the axis, Eq. (1) corrected, mm.

    ``s = e cos(psi) + sqrt(L^2 - e^2 sin^2(psi))`` with ``L = Rj + r``. The
    printed Eq. (1) factors ``e`` out of the square root as well, which puts
    the roller about ``e L`` (500 mm for Table 1) from the axis.
    """
    psi = np.asarray(psi, dtype=float)
    return e * np.cos(psi) + _w(psi, e, L)


def centre_distance_derivatives(
    psi: np.ndarray, e: float, L: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(s, ds/dpsi, d2s/dpsi2, W)`` with ``W = sqrt(L^2 - e^2 sin^2 psi)``.

    ``ds/dpsi = -e sin(psi) s / W`` exactly, so ``(ds/dpsi) / s = -e sin(psi) / W``.
    """
    psi = np.asarray(psi, dtype=float)
    sp, cp = np.sin(psi), np.cos(psi)
    W = _w(psi, e, L)
    s = e * cp + W
    ds = -e * sp * s / W
    d2s = -e * cp - e * e * np.cos(2.0 * psi) / W - e**4 * sp**2 * cp**2 / W**3
    return s, ds, d2s, W


def normal_offset_angle(psi: np.ndarray, z: int, e: float, L: float) -> np.ndarray:
    """Angle ``beta`` from the radial direction to the outward locus normal, rad.

    Eq. (3) corrected: ``alpha = t + beta`` with
    ``beta = atan2(z e sin(psi), W)``. Derived from the tangent
    ``dP/dt = s' u_r + s u_t``: the outward normal is ``s u_r - s' u_t``, and
    ``-s'/s = z e sin(psi) / W``. ``W > 0`` so ``|beta| < pi/2`` and there are
    no quadrant jumps.
    """
    psi = np.asarray(psi, dtype=float)
    return np.arctan2(z * e * np.sin(psi), _w(psi, e, L))


def locus_points(t: np.ndarray, z: int, e: float, L: float) -> np.ndarray:
    """Roller-centre locus (theoretical profile) at polar angles ``t``: (n, 2), mm."""
    t = np.asarray(t, dtype=float)
    return centre_distance(z * t, e, L)[..., None] * unit_radial(t)


def locus_derivative(t: np.ndarray, z: int, e: float, L: float) -> np.ndarray:
    """dP/dt of the locus, (n, 2), mm/rad."""
    t = np.asarray(t, dtype=float)
    s, ds, _, _ = centre_distance_derivatives(z * t, e, L)
    return (z * ds)[..., None] * unit_radial(t) + s[..., None] * unit_tangential(t)


def locus_normals(t: np.ndarray, z: int, e: float, L: float) -> np.ndarray:
    """Outward unit normals of the locus, (n, 2)."""
    t = np.asarray(t, dtype=float)
    return unit_radial(t + normal_offset_angle(z * t, z, e, L))


def locus_curvature(psi: np.ndarray, z: int, e: float, L: float) -> np.ndarray:
    """Signed curvature of the locus at ``psi = z t``, 1/mm.

    Positive where the locus is convex seen from outside (centre of curvature
    towards the axis, e.g. in the tooth spaces), negative at the tooth tips.
    Polar form ``k = (s^2 + 2 s'^2 - s s'') / (s^2 + s'^2)^(3/2)``, ``' = d/dt``.
    """
    s, ds, d2s, _ = centre_distance_derivatives(psi, e, L)
    s1 = z * ds
    s2 = z * z * d2s
    return (s * s + 2.0 * s1 * s1 - s * s2) / (s * s + s1 * s1) ** 1.5


def profile_speed_factor(psi: np.ndarray, z: int, e: float, L: float, offset: float) -> np.ndarray:
    """``1 + offset * k``: the offset curve's tangent is this times the locus tangent.

    Where it is negative the offset curve runs backwards: a swallowtail
    (undercut). The working profile's curvature is ``k / (1 + r k)``.
    """
    return 1.0 + offset * locus_curvature(psi, z, e, L)


def floating_cam_spin(design) -> float:
    """A cam floating on its bearing: its absolute spin per turn of the output, ``2 L / R_j``.

    The rollers about the cam are a roller bearing whose cage is the output frame
    (speed 1), whose outer race is the fixed ring and whose inner race is the cam;
    rolling at both races turns the cage at ``omega_i (1 - gamma) / 2 + omega_o (1 +
    gamma) / 2``, ``gamma = r / L`` (Harris & Kotzalas, *Rolling Bearing Analysis*, the
    rolling element and cage speeds), so the cam spins at ``2 / (1 - gamma) = 2 L / R_j``
    times the output, whatever the friction coefficients. Per absolute crank turn it
    is that over ``z + 1``. The one statement of the cam's spin: the lives, the
    friction's speeds, the input inertia and the assembly's cam angle all take it here.
    """
    return 2.0 * design.link_length / design.cam_radius
