"""Friction, efficiency and rated life (mechanics.losses.friction, .efficiency, mechanics.life).

Expected values come from formulas written out here: the catalogue bearing
moment M = 0.5 mu P d, ISO 281's L10 = (C/P)^(10/3), the catalogue life rule
(N0/N)(T0/T)^(10/3), ISO 281 Table 7's f_c values, and the roller centre
and cam centre placed from s = e cos(psi) + sqrt(L^2 - e^2 sin^2 psi).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.mechanics.life import LifeSpec, iso281_fc, system_life_h
from corr_cad.mechanics.losses.efficiency import (
    drive_life,
    friction_figures,
    row_loads_from_forces,
)
from corr_cad.mechanics.losses.friction import (
    Friction,
    _weighted_median,
    roller_equilibrium,
    row_contacts,
    row_friction,
)
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad

D = GearDesign()
T_R = 2.86e6  # N*mm
X = mesh_period_rad(D) * np.arange(8) / 8
MU = Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4)


@pytest.fixture(scope="module")
def windup():
    return Windup(D, X)


def _contacts(res):
    return row_contacts(
        D.tooth_count, D.eccentricity, D.cam_radius, D.roller_radius, res.crank_angles, res.F_s
    )


def _hand_bearing_load(res) -> np.ndarray:
    """|sum F_j n_k|, n_k from the cam centre to the roller centre, placed by hand."""
    e, L = D.eccentricity, D.link_length
    out = []
    for p, phi in enumerate(res.crank_angles):
        total = np.zeros(2)
        for k in range(D.roller_count):
            th = 2 * math.pi * k / D.roller_count
            psi = phi - th
            s = e * math.cos(psi) + math.sqrt(L * L - (e * math.sin(psi)) ** 2)
            n = (
                np.array([s * math.cos(th), s * math.sin(th)])
                - e * np.array([math.cos(phi), math.sin(phi)])
            ) / L
            total += res.F_j[p, k] * n
        out.append(np.linalg.norm(total))
    return np.array(out)


def test_frictionless_roller_balance_gives_the_solvers_slot_and_ring_forces(windup):
    res = windup.forces(-T_R)
    eq = roller_equilibrium(_contacts(res), res.F_j, np.zeros(3), np.full(len(X), 26.0))
    assert np.allclose(eq["N"][..., 1], np.abs(res.F_s), rtol=0, atol=1e-9 * res.F_n.max())
    assert np.allclose(eq["N"][..., 2], res.F_n, rtol=0, atol=1e-9 * res.F_n.max())
    # Virtual work: the crank's power is (z + 1) times the cam moment, per unit output speed.
    assert np.allclose(eq["power"][:, 0], D.roller_count * res.cam_moment, rtol=1e-12)
    assert np.allclose(eq["power"][:, 1], -eq["power"][:, 0], rtol=1e-12)


@pytest.mark.parametrize("mounting", ["bearing", "fixed"])
def test_all_coefficients_zero_efficiency_is_exactly_one(windup, mounting):
    ff = friction_figures(
        D, windup, T_R, Friction(0, 0, 0, 0, mounting, 82.4), [0.1, 1.0], [1000.0]
    )
    assert np.all(ff.forward == 1.0) and np.all(ff.backdriving == 1.0)
    assert np.all(ff.losses_forward == 0.0)


@pytest.mark.parametrize("mounting", ["bearing", "fixed"])
@pytest.mark.parametrize("sign", [-1.0, 1.0])
def test_power_balance_at_every_position(windup, mounting, sign):
    res = windup.forces(sign * 0.6 * T_R)
    fr = row_friction(_contacts(res), res.F_j, Friction(0.08, 0.03, 0.06, 0.003, mounting, 82.4))
    driver = np.where(fr.crank_power > 0, fr.crank_power, fr.frame_power)
    resid = fr.crank_power + fr.frame_power - fr.loss.sum(axis=1)
    assert np.all(np.abs(resid) <= 1e-9 * np.abs(driver))
    assert np.all(fr.loss >= 0.0)


def test_bearing_loss_is_the_catalogue_moment_times_the_relative_speed(windup):
    res = windup.forces(-T_R)
    mu_b, d = 0.003, 82.4
    fr = row_friction(_contacts(res), res.F_j, Friction(0.05, 0.05, 0.05, mu_b, "bearing", d))
    crank = D.roller_count  # crank speed per unit output speed
    expected = sum(
        0.5 * mu_b * P * d * abs(crank - w)
        for P, w in zip(fr.bearing_load, fr.cam_spin, strict=True)
    )
    assert expected > 0
    assert fr.loss[:, 3].sum() == pytest.approx(expected, rel=1e-12)
    # Without cam friction the bearing carries exactly the rollers' resultant sum F_k n_k.
    fr0 = row_friction(_contacts(res), res.F_j, Friction(0.0, 0.05, 0.05, mu_b, "bearing", d))
    assert np.allclose(fr0.bearing_load, _hand_bearing_load(res), rtol=1e-9)


def test_fixed_cam_has_no_bearing(windup):
    res = windup.forces(-T_R)
    fr = row_friction(_contacts(res), res.F_j, Friction(0.05, 0.05, 0.05, 0.003, "fixed", 82.4))
    assert np.all(fr.loss[:, 3] == 0.0) and np.all(fr.cam_spin == D.roller_count)


def test_backdriving_below_forward_and_self_locking_detected(windup):
    ff = friction_figures(D, windup, T_R, MU, [0.2, 1.0], [1000.0])
    assert np.all(ff.backdriving < ff.forward) and np.all(ff.forward < 1.0)
    assert not ff.figures()["efficiency_backdriving"]["self_locking"]
    # A cam rubbing on the rollers with a high coefficient cannot be driven from the output.
    locked = friction_figures(
        D, windup, T_R, Friction(0.3, 0.3, 0.3, 0, "fixed", 82.4), [1.0], [1.0]
    )
    assert locked.backdriving[0] <= 0.0
    assert locked.figures()["efficiency_backdriving"]["self_locking"] is True


def test_one_contact_sticks_the_weighted_median():
    x = np.array([[-1.0, 0.0, 2.0]])
    # One weight above the sum of the others sticks whatever the speeds.
    assert _weighted_median(x, np.array([[5.0, 1.0, 1.0]]))[0] == 0
    assert _weighted_median(x, np.array([[1.0, 1.0, 5.0]]))[0] == 2
    assert _weighted_median(x, np.array([[1.0, 1.0, 1.0]]))[0] == 1
    # No friction at all: no contact takes any force.
    assert _weighted_median(x, np.zeros((1, 3)))[0] == 0


def test_one_contact_sticks_the_others_slide_at_the_coulomb_limit(windup):
    res = windup.forces(-T_R)
    fr = row_friction(_contacts(res), res.F_j, MU)
    slip, stick = fr.roller["slip"], fr.roller["stick"]
    f, N = fr.roller["f"], fr.roller["N"]
    k = stick[..., None] == np.arange(3)
    assert np.all(np.take_along_axis(slip, stick[..., None], axis=2) == 0.0)
    # Sliding: the Coulomb limit against the slip (a floating cam's spin can sit where a
    # second contact of one roller has no slip either: it takes no force there).
    sliding = ~k & (res.F_j > 0)[..., None] & (slip != 0.0)
    assert np.all(np.sign(f)[sliding] == -np.sign(slip)[sliding])
    assert np.allclose(np.abs(f)[sliding], (MU.mu * np.abs(N))[sliding], rtol=1e-12)
    # The sticking contact's force stays within its cone (the roller's moment balance).
    fk = np.take_along_axis(np.abs(f), stick[..., None], axis=2)[..., 0]
    nk = np.take_along_axis(MU.mu * np.abs(N), stick[..., None], axis=2)[..., 0]
    assert np.all(fk <= nk * (1 + 1e-9) + 1e-9)
    # Each roller's friction moment balances: r sum f = 0.
    assert np.allclose(f.sum(axis=2), 0.0, atol=1e-9 * res.F_j.max())


def test_iso281_fc_against_table_7():
    # ISO 281:2007 Table 7 (radial roller bearings), f_c at D_we cos(alpha) / D_pw.
    for g, fc in [(0.01, 52.1), (0.05, 74.1), (0.10, 84.2), (0.20, 88.7), (0.30, 83.8)]:
        assert iso281_fc(g) == pytest.approx(fc, abs=0.05)


def _lives(windup, T, rpm, spec):
    rows = [row_loads_from_forces(D, windup.forces(-T))]
    return drive_life(D, rows * 2, spec, "bearing", rpm), rows


def test_bearing_l10_by_iso281_from_the_bearing_loads(windup):
    """ISO 281 on the frictionless resultant |sum F_j n_k| at the rolling kinematics' speed."""
    spec = LifeSpec(dynamic_load_rating=60000.0)
    lives, _ = _lives(windup, T_R, 15.0, spec)
    P_k = _hand_bearing_load(windup.forces(-T_R))
    # Rolling bearing kinematics, ring fixed, frame as the cage: the cam spins at 2 L / R_j.
    n = D.roller_count - 2.0 * (D.cam_radius + D.roller_radius) / D.cam_radius
    P = np.mean(P_k ** (10 / 3)) ** 0.3
    L10_h = (60000.0 / P) ** (10 / 3) * 1e6 / (60.0 * n * 15.0)
    assert lives["bearing_row1"] == pytest.approx(L10_h, rel=1e-12)
    # Two rows of three components: the Weibull sum with slope 9/8.
    parts = [v for k, v in lives.items() if k != "system"]
    assert lives["system"] == pytest.approx(sum(x**-1.125 for x in parts) ** (-1 / 1.125))


def test_rated_torque_from_life_inverts(windup):
    spec = LifeSpec()
    ff = friction_figures(D, windup, T_R, MU, [1.0], [1000.0], spec)
    T = ff.rated_torque_from_life
    lives, _ = _lives(windup, T, 15.0, spec)
    assert lives["system"] == pytest.approx(6000.0, rel=1e-3)
    assert ff.lives_at_rated_from_life["system"] == pytest.approx(6000.0, rel=1e-3)


def test_life_at_another_point_follows_the_catalogue_rule(windup):
    """Bearing: (N0/N)(T0/T)^(10/3) where its load is proportional to the torque.

    The raceways follow exponent 4 (Lundberg-Palmgren line contact), so the
    system departs from the rule: measured here for T/2 at 2 N.
    """
    spec = LifeSpec()
    l0, _ = _lives(windup, T_R, 15.0, spec)
    l1, _ = _lives(windup, 0.5 * T_R, 30.0, spec)
    rule = (15.0 / 30.0) * (1.0 / 0.5) ** (10 / 3)
    # The Hertz contacts are not linear: the load shares shift slightly with the torque.
    assert l1["bearing_row1"] / l0["bearing_row1"] == pytest.approx(rule, rel=5e-3)
    assert l1["cam_row1"] / l0["cam_row1"] == pytest.approx(0.5 * 2.0**4, rel=2e-2)
    ratio = l1["system"] / l0["system"]
    assert rule < ratio < 0.5 * 2.0**4


def test_clearance_breaks_the_catalogue_rule():
    """Rollers 5 um undersize: fewer rollers carry the load, more so at part load."""
    from corr_cad.geometry.deviations import ManufacturingErrors

    w = Windup(D, X, errors=ManufacturingErrors(roller_radius_error=-0.005))
    spec = LifeSpec()
    l0, _ = _lives(w, T_R, 15.0, spec)
    l1, _ = _lives(w, 0.25 * T_R, 15.0, spec)
    assert abs(l1["cam_row1"] / l0["cam_row1"] / 4.0**4 - 1.0) > 0.05


def test_system_life_of_equal_parts():
    assert system_life_h([1000.0, 1000.0]) == pytest.approx(1000.0 * 2 ** (-8 / 9))
    assert system_life_h([math.inf]) == math.inf


@pytest.mark.slow
def test_datasheet_run_writes_efficiency_and_life(tmp_path):
    from corr_cad.run.cli import main

    scene = tmp_path / "s.toml"
    scene.write_text(
        "[load]\ninput_torque = 1.1e5\n[export]\nformats = ['datasheet']\n"
        "[datasheet]\npositions_per_mesh = 4\ntransmission_error_positions_per_turn = 12\n"
        "[friction]\nmu_cam = 0.05\nhousing_area_m2 = 0.25\n[life]\n"
        "[checks]\nmin_efficiency = 0.95\nmin_life_h = 100.0\n"
    )
    out = tmp_path / "out"
    rc = main(["run", str(scene), "--out", str(out), "--quiet"])
    assert rc == 1  # min_efficiency fails (about 0.87), min_life_h passes
    ds = json.loads((out / "datasheet.json").read_text())
    for key in (
        "efficiency_forward",
        "efficiency_backdriving",
        "life_h",
        "rated_torque_from_life_Nm",
    ):
        assert key in ds
    eff = np.genfromtxt(out / "efficiency.csv", delimiter=",", names=True)
    assert len(eff) == 30  # 10 torques x 3 speeds
    assert ds["efficiency_forward"]["min"] == pytest.approx(eff["efficiency_forward"].min())
    # Input power = output power / efficiency, output power T * omega_out.
    w_out = 2 * np.pi * eff["input_speed_rpm"] / 60 / D.roller_count
    assert np.allclose(
        eff["input_power_W"] * eff["efficiency_forward"], eff["output_torque_Nm"] * w_out
    )
    life = (out / "life.csv").read_text()
    assert "bearing_row1" in life and "system" in life
    # The loop: torque rising left of the frictionless windup, falling right of it, as
    # wide at +-T_R (mean of both signs) as datasheet.json's widest.
    h = np.genfromtxt(out / "hysteresis.csv", delimiter=",", names=True)
    w = np.genfromtxt(out / "windup.csv", delimiter=",", names=True)
    assert len(h) == np.sum(w["output_angle_deg"] == w["output_angle_deg"][0])  # every level
    assert len(set(h["output_angle_deg"])) == 1
    assert np.all(h["windup_rising_arcmin"] <= h["windup_frictionless_arcmin"])
    assert np.all(h["windup_falling_arcmin"] >= h["windup_frictionless_arcmin"])
    ends = np.abs(np.abs(h["output_torque_Nm"]) - ds["rated_torque_Nm"]) < 1e-6
    width = np.mean(h["windup_falling_arcmin"][ends] - h["windup_rising_arcmin"][ends])
    assert width == pytest.approx(ds["hysteresis_width_at_rated_arcmin"]["max"], rel=1e-9)
    m = json.loads((out / "manifest.json").read_text())
    assert m["checks"]["min_efficiency"]["passed"] is False
    assert m["checks"]["min_life_h"]["passed"] is True
    assert (out / "efficiency.png").stat().st_size > 0
    # Thermal limit: at that input speed the losses of efficiency.csv (proportional to the
    # speed) equal k A dT = 18 W/(m^2 K) * 0.25 m^2 * 40 K = 180 W.
    th = ds["thermal_limit"]
    assert th["heat_dissipated_W"] == pytest.approx(180.0)
    at = eff[eff["input_speed_rpm"] == 1000.0]
    loss_W = sum(at[c] for c in ("loss_cam_W", "loss_slot_W", "loss_ring_W", "loss_bearing_W"))
    assert np.allclose(loss_W * np.asarray(th["input_speed_rpm"]) / 1000.0, 180.0, rtol=1e-6)


def test_rows_given_by_a_drive_model_are_taken_as_they_are(windup):
    """Two rows, as a drive model gives them (row B at phi + pi): both rows' lives."""
    from types import SimpleNamespace

    from corr_cad.mechanics.losses.efficiency import rows_from_drive

    wb = Windup(D, X + np.pi / D.tooth_count)  # crank angle z x + pi: row B

    def rows_at(T):
        return rows_from_drive(D, SimpleNamespace(rows=(windup.forces(T), wb.forces(T))))

    spec = LifeSpec()
    a = friction_figures(D, windup, T_R, MU, [0.5, 1.0], [1000.0], spec)
    b = friction_figures(D, None, T_R, MU, [0.5, 1.0], [1000.0], spec, rows_at=rows_at)
    # Alike rows half a crank turn apart: the same efficiency and lives as two copies.
    assert np.allclose(a.forward, b.forward, rtol=1e-6)
    assert b.lives["bearing_row2"] == pytest.approx(b.lives["bearing_row1"], rel=1e-3)
    assert b.lives["system"] == pytest.approx(a.lives["system"], rel=1e-3)


def test_floating_cam_moment_balance_closes(windup):
    """The rollers' friction moments on the cam equal the bearing's 0.5 mu P d, signed."""
    res = windup.forces(-T_R)
    mu_b, d = 0.0025, 82.4
    fr = row_friction(_contacts(res), res.F_j, Friction(0.05, 0.05, 0.05, mu_b, "bearing", d))
    moment = D.cam_radius * fr.roller["f"][:, :, 0].sum(axis=1)
    bearing = 0.5 * mu_b * fr.bearing_load * d * np.sign(fr.cam_spin - D.roller_count)
    scale = D.cam_radius * np.abs(fr.roller["f"][:, :, 0]).sum(axis=1)
    assert np.all(np.abs(moment - bearing) <= 1e-9 * scale)


@pytest.mark.slow
def test_zero_friction_leaves_the_windup_and_makes_efficiency_one(tmp_path):
    from corr_cad.run.cli import main

    base = (
        "[load]\ninput_torque = 1.1e5\n[export]\nformats = ['datasheet']\n"
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 12\n"
        "[errors]\ncam_radius_error = 0.002\n"
    )
    zero = "[friction]\nmu_cam = 0.0\nmu_slot = 0.0\nmu_ring = 0.0\nmu_bearing = 0.0\n"
    outs = []
    for i, extra in enumerate(("", zero)):
        scene = tmp_path / f"s{i}.toml"
        scene.write_text(base + extra)
        out = tmp_path / f"out{i}"
        assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
        outs.append(out)
    assert (outs[0] / "windup.csv").read_bytes() == (outs[1] / "windup.csv").read_bytes()
    ds = json.loads((outs[1] / "datasheet.json").read_text())
    assert ds["efficiency_forward"]["min"] == 1.0 and ds["efficiency_backdriving"]["max"] == 1.0
    assert ds["hysteresis_loss_arcmin"] == 0.0
    assert ds["starting_torque_Nm"]["max"] == 0.0


@pytest.mark.slow
def test_bearing_l10_from_forces_csv_by_iso281(tmp_path):
    """The run's forces.csv gives the bearing's loads; ISO 281 written here gives its L10."""
    from corr_cad.run.cli import main

    scene = tmp_path / "s.toml"
    scene.write_text(
        "[load]\ninput_torque = 1.1e5\n[export]\nformats = ['forces', 'datasheet']\n"
        "[solver]\npositions = 104\n"
        "[datasheet]\npositions_per_mesh = 4\ntransmission_error_positions_per_turn = 12\n"
        "[life]\ndynamic_load_rating_N = 60000.0\n"
    )
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    f = np.genfromtxt(out / "forces.csv", delimiter=",", names=True)
    e, L = D.eccentricity, D.link_length
    loads = []
    for phi_deg in np.unique(f["crank_angle_deg"]):
        rows = f[f["crank_angle_deg"] == phi_deg]
        phi = math.radians(phi_deg)
        total = np.zeros(2)
        for k, F in zip(rows["roller"].astype(int) - 1, rows["F_j"], strict=True):
            th = 2 * math.pi * k / D.roller_count
            psi = phi - th
            s = e * math.cos(psi) + math.sqrt(L * L - (e * math.sin(psi)) ** 2)
            n = (
                s * np.array([math.cos(th), math.sin(th)])
                - e * np.array([math.cos(phi), math.sin(phi)])
            ) / L
            total += F * n
        loads.append(np.linalg.norm(total))
    P_free = np.mean(np.asarray(loads) ** (10 / 3)) ** 0.3
    ds = json.loads((out / "datasheet.json").read_text())
    b = ds["rated_torque_from_life_Nm"]["bearing_at_rated_torque"]
    # The cam's friction (0.05 by default) adds about 3 % to the frictionless resultant.
    assert 1.0 < b["equivalent_load_N"] / P_free < 1.05
    L10_h = (60000.0 / b["equivalent_load_N"]) ** (10 / 3) * 1e6 / (60 * b["relative_speed_rpm"])
    assert ds["life_h"]["bearing_row1"] == pytest.approx(L10_h, rel=1e-9)
