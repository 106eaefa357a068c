"""Hysteresis loss and starting torque from friction (corr_cad.mechanics.hysteresis).

The hand calculation writes the locked-input bench out: each roller carried
with its slot, moved along it by the change of its cam contact, rolling on
the cam (the larger friction weight) and sliding on the slot wall.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.friction import Friction
from corr_cad.mechanics.hysteresis import hysteresis_figures
from corr_cad.mechanics.windup import Windup, mesh_period_rad

D = GearDesign()
T_R = 2.86e6
X = mesh_period_rad(D) * np.arange(4) / 4


@pytest.fixture(scope="module")
def nominal():
    return Windup(D, X)


@pytest.fixture(scope="module")
def preloaded():
    # Cam 2 um oversize: every roller pressed at zero torque.
    return Windup(D, X, errors=ManufacturingErrors(cam_radius_error=0.002))


def test_zero_friction_has_no_loop_and_no_starting_torque(preloaded):
    h = hysteresis_figures(D, preloaded, T_R, Friction(0, 0, 0, 0, "bearing", 82.4))
    for k in ("loss", "width_at_rated", "starting_torque", "backdriving_torque"):
        assert np.all(h[k] == 0.0), k


def test_no_preload_no_loss_at_zero_torque(nominal):
    h = hysteresis_figures(D, nominal, T_R, Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4))
    arcmin = 10800 / math.pi
    assert np.all(h["loss"] * arcmin < 1e-9)
    assert np.all(h["starting_torque"] < 1e-9 * T_R)
    assert np.all(h["width_at_rated"] > 0.0)


def test_loop_width_grows_with_mu_slot(nominal):
    widths = [
        hysteresis_figures(D, nominal, T_R, Friction(0.05, m, 0.05, 0.0025, "bearing", 82.4))[
            "width_at_rated"
        ].max()
        for m in (0.0, 0.02, 0.05, 0.1)
    ]
    assert all(a < b for a, b in zip(widths, widths[1:], strict=False))
    # The slot dominates: without it the loop is over ten times narrower.
    assert widths[0] < widths[2] / 10


def test_hysteresis_loss_of_a_preload_against_a_hand_calculation(preloaded):
    mu = 0.005
    fr = Friction(mu, mu, 0.0, 0.0, "fixed", 82.4)
    h = hysteresis_figures(D, preloaded, T_R, fr)
    assert np.all(h["loss"] > 0)
    # Only the cam and the slot have friction: without the slot's the roller rolls on the cam.
    h0 = hysteresis_figures(D, preloaded, T_R, Friction(mu, 0.0, 0.0, 0.0, "fixed", 82.4))
    assert np.all(h0["loss"] == 0.0)

    e, L, r = D.eccentricity, D.link_length, D.roller_radius
    lam = 2.0 / (math.pi * D.roller_length * (206000.0 / (2 * (1 - 0.3**2))))
    zero, step = 1e-9 * T_R, 1e-3 * T_R
    hand = np.zeros(len(X))
    for sgn in (1.0, -1.0):
        t0, t1 = sgn * zero, sgn * zero + sgn * step
        a, b = (t0, t1) if sgn > 0 else (t1, t0)
        ra, rb = preloaded.forces(a), preloaded.forces(b)
        tha, thb = preloaded.contact_theta(a), preloaded.contact_theta(b)
        res = preloaded.forces(t0)
        K = (b - a) / (thb - tha)
        dF = (rb.F_j - ra.F_j) / (thb - tha)[:, None]
        for p, phi in enumerate(res.crank_angles):
            o1 = e * np.array([math.cos(phi), math.sin(phi)])
            D_p = 0.0
            for k in range(D.roller_count):
                th = 2 * math.pi * k / D.roller_count
                psi = phi - th
                s = e * math.cos(psi) + math.sqrt(L * L - (e * math.sin(psi)) ** 2)
                ur = np.array([math.cos(th), math.sin(th)])
                H = s * ur
                n = (H - o1) / L
                zx = lambda v: np.array([-v[1], v[0]])  # noqa: E731
                du = (-(zx(o1) @ n) - lam * dF[p, k]) / (n @ ur)
                vH = zx(H) + du * ur
                a_cam = vH @ (-zx(n))  # cam locked: the roller rolls on it
                side = 1.0 if res.F_s[p, k] >= 0 else -1.0
                a_slot = -side * du - r
                D_p += mu * abs(res.F_s[p, k]) * abs(a_slot - a_cam)
            hand[p] += 2 * D_p / K[p]
    # Agreement found: 8e-6 (the code balances each roller with friction, the hand
    # calculation uses the frictionless slot forces).
    assert np.allclose(h["loss"], hand, rtol=1e-4, atol=0.0)


def test_starting_torque_of_a_preload_grows_with_friction(preloaded):
    a = hysteresis_figures(D, preloaded, T_R, Friction(0.02, 0.02, 0.02, 0.0025, "bearing", 82.4))
    b = hysteresis_figures(D, preloaded, T_R, Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4))
    assert np.all(a["starting_torque"] > 0) and np.all(b["starting_torque"] > a["starting_torque"])
