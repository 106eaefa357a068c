"""Tests aimed at kinds of mistake that passed the suite before, one test (or more) per
kind, each against a value computed here independently of the code under test:

1. a constant factor in a rating or capacity formula: the raceways' Lundberg-Palmgren
   capacity against ISO 281 Table 7's tabulated f_c of the same rollers;
2. the reference frame of a relative speed that sets a revolution count: each raceway's
   speed relative to the roller set written by hand (the ring 1, a cam fixed on the crank
   z, per unit output speed), at two speeds;
3. a figure reflected through a ratio: the starting torque at the crank times (z + 1)
   against the backdriving torque at the output it reflects;
4. a setting not forwarded when a solver is rebuilt for a subset of positions (the
   restart path) under each contact law, not the default one only;
5. a term that reaches the tested figures only through differences: the drive's absolute
   windup with a series rigidity against the contacts' windup plus T / K by hand;
6. numbers in the sentences of the customer page: ``tests/page_check.py`` (used by
   ``test_datasheet.py`` and ``test_datasheet_page.py``);
7. the geometry that feeds a computed rating: the needles' pitch diameter from the cam
   bore and the needle size, and the ISO 281 rating it gives (``test_datasheet_page.py``
   for the run, here for the formula).

docs/development.md ("How the tests catch mistakes") lists the mistakes made to check them.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.mechanics.life import LifeSpec, needle_dynamic_rating, raceway_capacity
from corr_cad.mechanics.losses.efficiency import drive_friction, drive_life, row_loads_from_forces
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad

ROOT = Path(__file__).resolve().parents[1]
D = GearDesign()
T_R = 2.86e6  # N*mm
X = mesh_period_rad(D) * np.arange(4) / 4

#: ISO 281:2007 Table 7, radial roller bearings: f_c at gamma = D_we cos(alpha) / D_pw.
TABLE_7 = [(0.01, 52.1), (0.05, 74.1), (0.10, 84.2), (0.20, 88.7), (0.30, 83.8)]


# --- 1. a constant factor in a capacity formula ----------------------------------------


@pytest.mark.parametrize(("gamma", "fc"), TABLE_7)
def test_raceway_capacities_give_iso_281s_tabulated_rating(gamma, fc):
    """Lundberg-Palmgren: a bearing of Z rollers rates C = (207.9 / 552) Z Q_ci
    [1 + (1.04 Q_ci / Q_co)^(9/2)]^(-2/9) (ISO/TR 1281-1: the inner and outer raceways'
    capacities combined, 1.04 the outer ring's lambda); ISO 281 tabulates the same
    bearing's C = f_c (l)^(7/9) Z^(3/4) D^(29/27) (b_m = 1). Table 7's f_c is rounded to
    0.05: the two agree within 0.1 %. A wrong constant in raceway_capacity (552, its
    lambda nu, an exponent) moves the capacity of every raceway life."""
    Z, Dw, lw = 26, 16.0, 12.0
    q_in = float(raceway_capacity(1.0 - gamma, False, Z, Dw, lw, gamma))
    q_out = float(raceway_capacity(1.0 + gamma, True, Z, Dw, lw, gamma))
    combined = 207.9 / 552.0 * Z * q_in * (1.0 + (1.04 * q_in / q_out) ** 4.5) ** (-2.0 / 9.0)
    iso = fc * lw ** (7.0 / 9.0) * Z**0.75 * Dw ** (29.0 / 27.0)
    assert combined == pytest.approx(iso, rel=1e-3)


# --- 2. the reference frame of a relative speed ----------------------------------------


@pytest.fixture(scope="module")
def rows():
    w = Windup(D, X)
    return [row_loads_from_forces(D, w.forces(-T_R))]


@pytest.mark.parametrize("rpm", [15.0, 45.0])
def test_raceway_lives_count_revolutions_relative_to_the_roller_set(rows, rpm):
    """The rollers ride in the frame (the output, 1 per unit output speed); the ring stands
    still, so it passes them once per output turn; a cam fixed on the crank turns z + 1
    times an output turn, z relative to the rollers. L = (Q_c / Q_e)^p 10^6 / (60 n_rel)."""
    fixed = Friction(0.05, 0.05, 0.05, 0.0, "fixed", 82.4)
    fr = drive_friction(D, rows, fixed)
    assert np.allclose(fr[0].cam_spin, D.roller_count)  # fixed on the crank: z + 1
    lives = drive_life(D, rows * 2, LifeSpec(), "fixed", rpm)
    z, R = D.tooth_count, D.roller_count
    gamma = D.roller_radius / D.link_length
    row = rows[0]
    q_cam = raceway_capacity(row.conformity_cam, False, R, 2 * D.roller_radius, 12.0, gamma)
    q_ring = raceway_capacity(row.conformity_ring, True, R, 2 * D.roller_radius, 12.0, gamma)
    # a cam fixed on the crank stands still relative to its load: exponent 4.5
    cam = np.mean(np.mean((row.cam_force / q_cam) ** 4.5, axis=1)) ** (-4.0 / 4.5)
    ring = np.mean(np.mean((row.ring_force / q_ring) ** 4.0, axis=1)) ** -1.0
    assert lives["cam_row1"] == pytest.approx(cam * 1e6 / (60.0 * z * rpm), rel=1e-12)
    assert lives["ring_row1"] == pytest.approx(ring * 1e6 / (60.0 * 1.0 * rpm), rel=1e-12)


# --- 3. a figure reflected through a ratio ---------------------------------------------


def test_starting_torque_reflects_the_backdriving_torque_through_z_plus_1(tmp_path):
    """Rollers 0.2 um oversize (a preload) with friction: running at no load dissipates
    the same per output radian whichever member drives, so the crank needs 1 / (z + 1) of
    the output's torque: starting * (z + 1) = backdriving at every position."""
    scene = tmp_path / "s.toml"
    scene.write_text(
        "[load]\ninput_torque = 1.1e5\n[export]\nformats = ['datasheet']\n"
        "[errors]\nroller_radius_error = 0.0002\n"
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 6\n"
        "[friction]\npositions_per_mesh = 2\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert r.returncode == 0, r.stderr
    d = json.loads((tmp_path / "o" / "datasheet.json").read_text())
    s, b = d["starting_torque_Nm"], d["backdriving_torque_Nm"]
    assert s["max"] == pytest.approx(5.307, abs=1e-3)  # docs/datasheet.md: a preload
    assert b["max"] == pytest.approx(138.0, abs=0.05)
    for k in ("min", "mean", "max"):
        assert s[k] * D.roller_count == pytest.approx(b[k], rel=1e-9)
    assert f"starting torque     {s['max']:.4g} N*m at the crank" in r.stdout.replace(",", "")


# --- 4. a setting forwarded when a solver is rebuilt ------------------------------------


@pytest.mark.parametrize("law", ["palmgren", "linear", "nonlinear"])
def test_a_subset_solver_keeps_the_contact_law_bearings_and_tolerance(law):
    """The restart path rebuilds the drive's solver for the positions it solves again
    (drive_restart.subset_solver): the same law, bearings and tolerance, so a position
    solved in the subset equals the position solved with all the others."""
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.drive.drive import DriveSolver
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver
    from corr_cad.mechanics.drive.drive_restart import subset_solver
    from corr_cad.mechanics.row.solver_geometry import cycle_angles

    needles = EccentricBearing(40, 6.0, 12.0, 0.002)
    idx = np.array([1, 4, 5])
    for cls in (DriveSolver, CompiledDriveSolver):
        full = cls(D, cycle_angles(7), bearing=needles, contact_model=law, rtol=1e-11)
        sub = subset_solver(full, idx)
        assert type(sub) is cls and type(sub.comp) is type(full.comp)
        assert sub.bearings == full.bearings and sub.rtol == full.rtol
        a, b = full.solve(1.1e5), sub.solve(1.1e5)
        np.testing.assert_allclose(b[0], a[0][idx], rtol=1e-9, atol=0)  # tau
        np.testing.assert_allclose(b[1], a[1][idx], rtol=1e-8, atol=1e-6)  # roller forces
    other = "linear" if law != "linear" else "palmgren"
    c = DriveSolver(D, cycle_angles(7), bearing=needles, contact_model=other).solve(1.1e5)
    assert not np.allclose(c[0][idx], a[0][idx], rtol=1e-6)  # the law shows in tau


# --- 5. a term reached only through differences -----------------------------------------


def test_the_drives_absolute_windup_adds_t_over_k_to_the_contacts():
    """Drive datasheet with a series rigidity K: at every torque level and position the
    windup is the contacts' windup (the same drive without K) plus T / K, K converted by
    hand (1 N*m/arcmin = 1000 N*mm per pi / 10800 rad); at zero torque nothing added."""
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet

    K = 1200.0
    drive = {"bearing": EccentricBearing(40, 6.0, 12.0, 0.002)}
    spec = dict(rated_torque=T_R, positions_per_mesh=2, transmission_error_positions_per_turn=4)
    a = datasheet(D, DatasheetSpec(**spec), drive=drive)
    b = datasheet(D, DatasheetSpec(**spec, series_rigidity_Nm_per_arcmin=K), drive=drive)
    k_rad = K * 1000.0 / (math.pi / 10800.0)  # N*mm per rad
    want = a.windup + a.torques[:, None] / k_rad
    np.testing.assert_allclose(b.windup, want, rtol=0, atol=1e-15)
    np.testing.assert_allclose(b.contact_windup, a.windup, rtol=0, atol=1e-15)
    at = int(np.argmax(a.torques))  # +T_R: 2,860 N*m over 1,200 N*m/arcmin = 2.383 arcmin
    extra = (b.windup[at] - a.windup[at]) * 10800.0 / math.pi
    assert extra == pytest.approx(2860.0 / 1200.0, rel=1e-12)
    assert b.figures()["torsional_rigidity_Nm_per_arcmin"]["headline"] < K


# --- 7. the geometry that feeds a computed rating ---------------------------------------


def test_the_needles_pitch_diameter_is_the_bore_less_one_needle():
    """The prototype's cam bore is 94.4 mm (2 x 47.2); its 40 needles of 6 x 12 mm run on
    a pitch circle of 94.4 - 6 = 88.4 mm, gamma = 6 / 88.4: C_r = b_m f_c l^(7/9) Z^(3/4)
    D^(29/27) = 65,223 N (docs/datasheet.md), f_c between Table 7's 0.05 and 0.10."""
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.stages_datasheet import _life_spec

    assert D.cam_bore_radius == 47.2
    scene = parse_scene({"load": {"input_torque": 1.1e5}, "life": {}})
    spec = _life_spec(scene, None)
    assert spec.pitch_diameter == pytest.approx(2 * 47.2 - 6.0, abs=1e-12)
    C, _ = spec.rating()
    assert C == pytest.approx(needle_dynamic_rating(40, 6.0, 12.0, 88.4), rel=1e-12)
    fc = C / (1.1 * 12.0 ** (7 / 9) * 40**0.75 * 6.0 ** (29 / 27))
    assert 74.1 < fc < 84.2  # gamma = 0.0679, between Table 7's rows 0.05 and 0.10
    assert round(C) == 65223
