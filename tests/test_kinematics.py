"""Kinematics of the crank-slider and the roller-centre locus (Eqs. 1 and 3)."""

import math

import numpy as np
import pytest

from corr_cad.geometry import kinematics as kin


def printed_eq1_radius(psi, e, L):
    """Eq. (1) as printed: e (cos psi + sqrt(L^2 - sin^2 psi))."""
    return e * (np.cos(psi) + np.sqrt(L**2 - np.sin(psi) ** 2))


def printed_eq3_alpha(t, z, L):
    """Eq. (3) as printed: arctan, and no e."""
    zt = z * t
    w = np.sqrt(L**2 - np.sin(zt) ** 2)
    return np.arctan(
        -(z * np.sin(zt) * np.sin(t) + w * np.cos(t)) / (z * np.sin(zt) * np.cos(t) - w * np.sin(t))
    )


Z, E, L = 25, 3.5, 143.0


def test_roller_centre_is_link_length_from_cam_centre():
    # The crank-slider's defining property: |H - O1| = L = Rj + r for every psi.
    psi = np.linspace(-np.pi, np.pi, 1001)
    s = kin.centre_distance(psi, E, L)
    h = s[:, None] * kin.unit_radial(np.zeros_like(psi))
    o1 = E * kin.unit_radial(psi)
    np.testing.assert_allclose(np.linalg.norm(h - o1, axis=1), L, rtol=0, atol=1e-12)
    assert s[500] == pytest.approx(L + E, abs=1e-12)  # psi = 0: tooth space
    assert s[0] == pytest.approx(L - E, abs=1e-12)  # psi = pi: tooth tip


def test_printed_eq1_fails_the_same_property():
    # Errata: the printed Eq. (1) puts the roller e*(1 + L) ~ 504 mm out.
    s_printed = printed_eq1_radius(0.0, E, L)
    assert s_printed == pytest.approx(E * (1 + L))
    assert abs(s_printed - (L + E)) > 300


def test_ds_over_s_closed_form():
    psi = np.linspace(-3, 3, 401)
    s, ds, d2s, W = kin.centre_distance_derivatives(psi, E, L)
    np.testing.assert_allclose(ds / s, -E * np.sin(psi) / W, rtol=1e-14, atol=1e-16)
    h = 1e-5
    fd1 = (kin.centre_distance(psi + h, E, L) - kin.centre_distance(psi - h, E, L)) / (2 * h)
    h2 = 1e-3  # second differences: larger step against round-off
    fd2 = (
        kin.centre_distance(psi + h2, E, L) - 2 * s + kin.centre_distance(psi - h2, E, L)
    ) / h2**2
    np.testing.assert_allclose(ds, fd1, atol=1e-8)
    np.testing.assert_allclose(d2s, fd2, atol=1e-6)


def test_normal_is_perpendicular_to_tangent_and_outward():
    t = np.linspace(0, 2 * np.pi, 2001)
    h = 1e-6
    fd = (kin.locus_points(t + h, Z, E, L) - kin.locus_points(t - h, Z, E, L)) / (2 * h)
    n = kin.locus_normals(t, Z, E, L)
    assert np.max(np.abs(np.sum(n * fd, axis=1)) / np.linalg.norm(fd, axis=1)) < 1e-8
    assert np.all(np.sum(n * kin.unit_radial(t), axis=1) > 0)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-15)


def test_printed_eq3_normal_is_not_perpendicular():
    # Errata: the printed Eq. (3) normal misses the tangent's perpendicular by tens of degrees.
    t = np.linspace(0.01, 2 * np.pi / Z - 0.01, 50)
    a_printed = printed_eq3_alpha(t, Z, L)
    n_p = kin.unit_radial(a_printed)
    fd = kin.locus_derivative(t, Z, E, L)
    cosines = np.abs(np.sum(n_p * fd, axis=1)) / np.linalg.norm(fd, axis=1)
    assert np.max(cosines) > 0.3


def test_curvature_against_finite_differences():
    t = np.linspace(0, 2 * np.pi / Z, 301)
    h = 1e-5
    d1 = kin.locus_derivative(t, Z, E, L)
    d2 = (kin.locus_derivative(t + h, Z, E, L) - kin.locus_derivative(t - h, Z, E, L)) / (2 * h)
    # Clockwise traversal for growing t: convex-from-outside has negative cross.
    k_fd = -(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.linalg.norm(d1, axis=1) ** 3
    np.testing.assert_allclose(kin.locus_curvature(Z * t, Z, E, L), k_fd, rtol=1e-6, atol=1e-9)
    # A circle (e -> 0): curvature 1/L.
    np.testing.assert_allclose(kin.locus_curvature(Z * t, Z, 1e-12, L), 1 / L, rtol=1e-9)


def test_rotation_by_polar_angle():
    p = kin.unit_radial(np.array([0.3]))
    np.testing.assert_allclose(kin.rotate_by_polar_angle(p, 0.5), kin.unit_radial(np.array([0.8])))
    assert math.isclose(float(np.linalg.norm(kin.rotate_by_polar_angle(p, 2.0))), 1.0)
