"""Hysteresis loss and starting torque from friction (corr_cad.mechanics.losses.hysteresis).

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
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.losses.hysteresis import hysteresis_figures, hysteresis_loop
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad

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

    hand = np.zeros(len(X))
    for sgn in (1.0, -1.0):
        Dh, K = _hand_dissipation(preloaded, sgn * 1e-9 * T_R, mu)
        hand += 2 * Dh / K
    # Agreement found: 8e-6 (the code balances each roller with friction, the hand
    # calculation uses the frictionless slot forces).
    assert np.allclose(h["loss"], hand, rtol=1e-4, atol=0.0)


def test_starting_torque_of_a_preload_grows_with_friction(preloaded):
    a = hysteresis_figures(D, preloaded, T_R, Friction(0.02, 0.02, 0.02, 0.0025, "bearing", 82.4))
    b = hysteresis_figures(D, preloaded, T_R, Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4))
    assert np.all(a["starting_torque"] > 0) and np.all(b["starting_torque"] > a["starting_torque"])


def _hand_dissipation(windup, torque: float, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """The bench written out (cam and slot friction ``mu``), one-sided differences
    away from zero: D (P,) N*mm/rad of the modelled row and K (P,) N*mm/rad."""
    e, L, r = D.eccentricity, D.link_length, D.roller_radius
    lam = 2.0 / (math.pi * D.roller_length * (206000.0 / (2 * (1 - 0.3**2))))
    step = 1e-3 * T_R
    sgn = 1.0 if torque > 0 else -1.0
    a, b = sorted((torque, torque + sgn * step)) if abs(torque) < step else (
        torque - step, torque + step)  # fmt: skip
    ra, rb = windup.forces(a), windup.forces(b)
    tha, thb = windup.contact_theta(a), windup.contact_theta(b)
    res = windup.forces(torque)
    K = (b - a) / (thb - tha)
    dF = (rb.F_j - ra.F_j) / (thb - tha)[:, None]
    out = np.zeros(len(K))
    for p, phi in enumerate(res.crank_angles):
        o1 = e * np.array([math.cos(phi), math.sin(phi)])
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
            a_cam = vH @ (-zx(n))
            side = 1.0 if res.F_s[p, k] >= 0 else -1.0
            a_slot = -side * du - r
            out[p] += mu * abs(res.F_s[p, k]) * abs(a_slot - a_cam)
    return out, K


def test_hysteresis_loop_branches_against_the_hand_bench(preloaded):
    """Each branch stands D / (share K) from the frictionless windup at T = T_R / 2 (the
    row stands for the drive at its share), the zero-torque levels sum to the loss and
    the +-T_R levels to the width the datasheet reports."""
    # The code balances each roller with its friction, the hand uses the frictionless
    # slot forces: they differ by about 0.15 mu relative (7.3e-4 at mu = 0.005, 7.3e-6 at
    # 5e-5: linear in mu), 7e-5 here.
    mu = 0.0005
    fr = Friction(mu, mu, 0.0, 0.0, "fixed", 82.4)
    T = np.array([-T_R, -0.5 * T_R, -0.0, 0.0, 0.5 * T_R, T_R])
    loop = hysteresis_loop(D, preloaded, T, T_R, fr)
    Dh, K = _hand_dissipation(preloaded, 0.5 * T_R, mu)
    hand = Dh / (preloaded.load_share * K)
    assert np.allclose(loop["rising"][4], hand, rtol=1e-4, atol=0.0)
    assert np.allclose(loop["falling"][4], hand, rtol=1e-4, atol=0.0)
    h = hysteresis_figures(D, preloaded, T_R, fr)
    for i in (2, 3):
        assert np.allclose(loop["rising"][i] + loop["falling"][i], h["loss"], rtol=1e-12)
    width = 0.5 * (loop["rising"][[0, 5]] + loop["falling"][[0, 5]]).sum(axis=0)
    assert np.allclose(width, h["width_at_rated"], rtol=1e-12, atol=0.0)


def test_hysteresis_loop_closes_without_friction(preloaded):
    T = np.array([-T_R, -0.0, 0.0, T_R])
    loop = hysteresis_loop(D, preloaded, T, T_R, Friction(0, 0, 0, 0, "bearing", 82.4))
    assert np.all(loop["rising"] == 0.0) and np.all(loop["falling"] == 0.0)
