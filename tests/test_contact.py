"""Line-contact deformation (Eqs. 9-12, corrected) in stable form."""

from decimal import Decimal, getcontext

import numpy as np
import pytest

from corr_cad.mechanics import contact


def exact(u, k1, k2):
    """Geometric overlap in 50-digit decimal arithmetic (no cancellation issue)."""
    getcontext().prec = 50
    out = []
    for ui in np.atleast_1d(u):
        total = Decimal(0)
        for k in (k1, k2):
            if k == 0:
                continue
            R = 1 / Decimal(k)
            sign = 1 if R > 0 else -1
            total += sign * (abs(R) - (R * R - Decimal(float(ui))).sqrt())
        out.append(float(total))
    return np.array(out)


def naive(u, k1, k2):
    """R - sqrt(R^2 - b^2) summed, signed radii: the printed structure, corrected."""
    out = 0.0
    for k in (k1, k2):
        if k == 0:
            continue
        R = 1.0 / k
        out = out + np.sign(R) * (abs(R) - np.sqrt(R * R - u))
    return out


@pytest.mark.parametrize("k2", [1 / 135.0, -1 / 60.0, 0.0, 1 / 1.75])
def test_stable_form_equals_geometric_overlap(k2):
    k1 = 1 / 8.0
    u = np.array([1e-2, 1e-1, 1.0])  # b^2, mm^2, well inside validity
    np.testing.assert_allclose(contact.approach(u, k1, k2), exact(u, k1, k2), rtol=1e-14)


def test_stable_form_does_not_cancel_for_tiny_half_width():
    k1, k2 = 1 / 8.0, 1 / 135.0
    u = 1e-14  # b = 1e-7 mm
    ref = exact(u, k1, k2)[0]
    assert contact.approach(u, k1, k2) == pytest.approx(ref, rel=1e-15)
    # The textbook form loses most digits here.
    assert abs(naive(u, k1, k2) - ref) / ref > 1e-3


def test_linear_limit_is_radius_independent():
    length, modulus = 12.0, 2.06e5 / (2 * (1 - 0.09))
    F = 1e-6
    for k2 in (1 / 135.0, -1 / 20.0, 0.0):
        c = contact.half_width_sq_per_force(1 / 8.0, k2, length, modulus)
        d = contact.approach(c * F, 1 / 8.0, k2)
        assert d / F == pytest.approx(contact.linear_compliance(length, modulus), rel=1e-9)


def test_beyond_validity_finite_monotone_convex_and_flagged():
    k1, k2 = 1 / 8.0, 1 / 1.75
    u = np.linspace(0, 20.0, 20001)  # up to b = 4.5 mm > 1.75 mm
    d = contact.approach(u, k1, k2)
    s = contact.approach_slope(u, k1, k2)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(s))
    assert np.all(np.diff(d) > 0)
    assert np.all(np.diff(s) >= -1e-12)
    valid = contact.is_valid(u, k1, k2)
    assert valid[0] and not valid[-1]
    assert u[valid].max() < 1.75**2 <= u[~valid].min()
    # Slope matches a finite difference of the value (C1 across the knee).
    fd = np.gradient(d, u)
    knee = contact.VALIDITY_KNEE / max(k1, k2) ** 2
    away = np.abs(u - knee) > 5 * (u[1] - u[0])
    away[[0, -1]] = False
    np.testing.assert_allclose(s[away], fd[away], rtol=2e-3)


def test_max_pressure_matches_hertz():
    F, length, modulus, k1, k2 = 2000.0, 12.0, 113186.8, 1 / 8, 1 / 135
    c = contact.half_width_sq_per_force(k1, k2, length, modulus)
    b = np.sqrt(c * F)
    p = contact.max_pressure(F, c, length)
    assert p == pytest.approx(2 * F / (np.pi * b * length), rel=1e-14)
    assert p == pytest.approx(np.sqrt(F * modulus * (k1 + k2) / (np.pi * length)), rel=1e-14)
    assert contact.max_pressure(0.0, c, length) == 0.0
