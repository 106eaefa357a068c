"""Ratings from the rolling kinematics: finite and continuous as every mu -> 0.

The rollers about the cam form a roller bearing whose cage is the output
frame (speed 1) and whose outer race is the fixed ring; rolling at both
races turns the cage at ``omega_i (1 - gamma) / 2`` (Harris & Kotzalas), so
a floating cam spins at ``2 / (1 - gamma) = 2 L / R_j`` times the output
speed, written out here. The lives and the rated torque from life use that
speed and the frictionless loads: the same at mu = 0.05, 1e-6 and 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.mechanics.life import LifeSpec, rolling_speeds
from corr_cad.mechanics.losses.efficiency import (
    drive_friction,
    friction_figures,
    row_loads_from_forces,
)
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad

D = GearDesign()
T_R = 2.86e6  # N*mm
X = mesh_period_rad(D) * np.arange(6) / 6


def _mu(scale: float, mounting: str = "bearing") -> Friction:
    return Friction(0.05 * scale, 0.05 * scale, 0.05 * scale, 0.0025 * scale, mounting, 82.4)


def test_rolling_speeds_by_hand():
    L, Rj = D.cam_radius + D.roller_radius, D.cam_radius
    gamma = D.roller_radius / L
    cam = 2.0 / (1.0 - gamma)  # inner race speed for cage 1, outer race 0
    assert cam == pytest.approx(2.0 * L / Rj, rel=1e-15)
    s = rolling_speeds(D, "bearing")
    assert s["bearing"] == pytest.approx(D.roller_count - cam, rel=1e-14)
    assert s["cam"] == pytest.approx(cam - 1.0, rel=1e-14) and s["ring"] == 1.0
    fixed = rolling_speeds(D, "fixed")
    assert fixed == {"bearing": 0.0, "cam": D.tooth_count, "ring": 1.0}


def test_the_friction_balance_spins_the_cam_near_the_rolling_kinematics():
    """The kinematic spin is what the friction balance gives on average (within 3 %)."""
    w = Windup(D, X)
    rows = [row_loads_from_forces(D, w.forces(-T_R))]
    spin = drive_friction(D, rows, _mu(1.0))[0].cam_spin
    kin = 2.0 * (D.cam_radius + D.roller_radius) / D.cam_radius
    assert np.mean(spin) == pytest.approx(kin, rel=0.03)


@pytest.mark.parametrize("mounting", ["bearing", "fixed"])
def test_life_finite_and_continuous_as_mu_goes_to_zero(mounting):
    w = Windup(D, X)
    spec = LifeSpec()
    figs = [
        friction_figures(D, w, T_R, _mu(lam, mounting), [1.0], [1000.0], spec)
        for lam in (1.0, 1e-2, 1e-6, 0.0)
    ]
    ref = figs[0]
    assert all(math.isfinite(v) and v > 0.0 for v in ref.lives.values())
    assert math.isfinite(ref.rated_torque_from_life)
    for ff in figs[1:]:
        assert ff.lives == ref.lives
        assert ff.rated_torque_from_life == ref.rated_torque_from_life
    if mounting == "bearing":
        n = D.roller_count - 2.0 * (D.cam_radius + D.roller_radius) / D.cam_radius
        speed = figs[-1].bearing["relative_speed_rpm"]
        assert speed == pytest.approx(n * spec.rated_speed_rpm, rel=1e-14)
