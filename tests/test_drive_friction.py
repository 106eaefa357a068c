"""Friction, efficiency and life under ``[solver] model = "drive"``: both rows, both cams.

Expected values come from formulas written out here: ISO 281's
``L10 = (C/P)^(10/3) 1e6 / (60 n)`` with the cubic mean of exponent 10/3,
ISO 281's rating ``C ~ Z^(3/4)`` at a fixed needle size, and the limiting
case of two identical rows on rigid cams, which is the paper's one row at
a share of 0.5.
"""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive_windup import DriveWindup
from corr_cad.mechanics.life import LifeSpec
from corr_cad.mechanics.losses.efficiency import (
    drive_friction,
    friction_figures,
    rows_from_drive,
)
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad

D = GearDesign()
T_R = 2.86e6  # N*mm
X = mesh_period_rad(D) * np.arange(8) / 8
MU = Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4)
BEARING = EccentricBearing(needles=40, needle_diameter=6.0, needle_length=12.0)


def _figures(w, friction, life=None):
    return friction_figures(
        D,
        None,
        T_R,
        friction,
        [0.2, 0.6, 1.0],
        [1000.0],
        life,
        rows_at=lambda T: rows_from_drive(D, w.forces(T)),
    )


@pytest.mark.parametrize("mounting", ["bearing", "fixed"])
def test_identical_rigid_rows_give_the_paper_efficiency_at_share_one_half(mounting):
    """Two identical rows on rigid cams share 0.5 each: the paper's row at load_share 0.5."""
    friction = Friction(0.05, 0.03, 0.07, 0.0025, mounting, 82.4)
    drive = _figures(DriveWindup(D, X), friction)
    paper = friction_figures(
        D, Windup(D, X, load_share=0.5), T_R, friction, [0.2, 0.6, 1.0], [1000.0]
    )
    assert np.all(drive.forward < 1.0)
    assert np.allclose(drive.forward, paper.forward, rtol=1e-9, atol=0)
    assert np.allclose(drive.backdriving, paper.backdriving, rtol=1e-9, atol=0)


@pytest.mark.parametrize("mounting", ["bearing", "fixed"])
def test_drive_without_friction_has_efficiency_exactly_one(mounting):
    w = DriveWindup(D, X, bearing=BEARING)
    ff = _figures(w, Friction(0, 0, 0, 0, mounting, 82.4))
    assert np.all(ff.forward == 1.0) and np.all(ff.backdriving == 1.0)
    assert np.all(ff.losses_forward == 0.0)


def test_drive_power_balance_at_every_position_with_unequal_rows():
    """Row B's rollers 1 um small, cams on bearings: every row's power balances to 1e-9."""
    w = DriveWindup(D, X, bearing=BEARING, errors_b=ManufacturingErrors(roller_radius_error=-0.001))
    for T in (-T_R, 0.6 * T_R):
        res = w.forces(T)
        assert abs(res.row_a_share.mean() - 0.5) > 0.01  # the rows differ
        for fr in drive_friction(D, rows_from_drive(D, res), Friction(0.08, 0.03, 0.06, 0.003)):
            driver = np.where(fr.crank_power > 0, fr.crank_power, fr.frame_power)
            resid = fr.crank_power + fr.frame_power - fr.loss.sum(axis=1)
            assert np.all(np.abs(resid) <= 1e-9 * np.abs(driver))
    assert _figures(w, MU).balance <= 1e-9


def test_each_cams_bearing_is_rated_on_the_drives_bearing_load():
    """Unequal rows: each bearing's L10 is ISO 281 on its own cam's drive load."""
    w = DriveWindup(D, X, bearing=BEARING, errors_b=ManufacturingErrors(roller_radius_error=-0.001))
    C = 60000.0
    life = LifeSpec(dynamic_load_rating=C)
    ff = _figures(w, MU, life)
    res = w.forces(-T_R)
    # The rolling kinematics' relative speed: crank z + 1 less the cam's 2 L / R_j.
    n = D.roller_count - 2.0 * (D.cam_radius + D.roller_radius) / D.cam_radius
    for i, name in enumerate(("bearing_row1", "bearing_row2")):
        P = np.mean(res.bearing_load[i] ** (10 / 3)) ** 0.3
        L10 = (C / P) ** (10 / 3) * 1e6 / (60 * n * life.rated_speed_rpm)
        assert ff.lives[name] == pytest.approx(L10, rel=1e-12)
    assert ff.lives["bearing_row1"] != pytest.approx(ff.lives["bearing_row2"], rel=1e-3)
    e = 9 / 8
    parts = [v for k, v in ff.lives.items() if k != "system"]
    assert ff.lives["system"] == pytest.approx(sum(v**-e for v in parts) ** (-1 / e), rel=1e-12)


SCENE = """[load]
input_torque = 1.1e5
[export]
formats = ['forces', 'datasheet']
[solver]
model = "drive"
positions = 104
[datasheet]
positions_per_mesh = 4
transmission_error_positions_per_turn = 12
[friction]
positions_per_mesh = 4
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
"""


@pytest.mark.slow
def test_cam_a_bearing_l10_from_forces_csv_by_iso281(tmp_path):
    """forces.csv's bearing_load of row A, ISO 281 written here: the datasheet's L10."""
    from corr_cad.run.cli import main

    scene = tmp_path / "s.toml"
    scene.write_text(SCENE + "[life]\ndynamic_load_rating_N = 60000.0\n")
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    with open(out / "forces.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["row"] == "A"]
    by_angle = {r["crank_angle_deg"]: float(r["bearing_load"]) for r in rows}
    loads = np.array(list(by_angle.values()))
    assert len(loads) == 104
    P = np.mean(loads ** (10 / 3)) ** 0.3
    ds = json.loads((out / "datasheet.json").read_text())
    b = ds["rated_torque_from_life_Nm"]["bearing_at_rated_torque"]
    # The datasheet weights each position by the bearing's revolutions there; the load
    # barely varies over the positions, so the weighting moves P by at most its spread.
    spread = (loads.max() - loads.min()) / loads.min()
    assert b["equivalent_load_N"] == pytest.approx(P, rel=spread + 1e-9)
    L10_h = (60000.0 / P) ** (10 / 3) * 1e6 / (60 * b["relative_speed_rpm"])
    assert ds["life_h"]["bearing_row1"] == pytest.approx(L10_h, rel=10 / 3 * spread + 1e-9)
    assert ds["model"] == "drive"
    # The files and the console say where the friction figures come from.
    from corr_cad.export.report_tables import friction_rows as _friction_rows
    from corr_cad.run.console import friction_lines

    assert ds["friction"]["forces"].startswith("drive: both rows")
    assert "from the drive" in friction_lines(ds)[0]
    assert "both rows of the drive" in _friction_rows(ds)[0]["note"]


@pytest.mark.slow
def test_the_life_takes_the_needles_of_the_drives_bearing(tmp_path):
    """ISO 281: C ~ Z^(3/4) at one needle size; [life]'s needles contradicting it: exit 2."""
    from corr_cad.run.cli import main

    ratings = {}
    for z in (40, 30):
        scene = tmp_path / f"s{z}.toml"
        scene.write_text(SCENE.replace("needles = 40", f"needles = {z}") + "[life]\n")
        out = tmp_path / f"out{z}"
        assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
        ds = json.loads((out / "datasheet.json").read_text())
        ratings[z] = ds["rated_torque_from_life_Nm"]["bearing_rating_N"]
    assert ratings[30] / ratings[40] == pytest.approx((30 / 40) ** 0.75, rel=1e-12)
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENE + "[life]\nneedles = 30\n")
    assert main(["run", str(bad), "--out", str(tmp_path / "o"), "--quiet"]) == 2
    same = tmp_path / "same.toml"
    same.write_text(SCENE + "[life]\nneedles = 40\n")
    from corr_cad.run.scene.scene import load_scene

    assert load_scene(same).life["needles"] == 40
    assert math.isfinite(ratings[40])


def test_drive_hysteresis_of_identical_rigid_rows_is_the_papers_at_share_one_half():
    """Two alike rows on rigid cams: the drive's bench loop is the paper row's at 0.5."""
    from corr_cad.mechanics.losses.hysteresis import hysteresis_figures

    drive = hysteresis_figures(D, DriveWindup(D, X), T_R, MU)
    paper = hysteresis_figures(D, Windup(D, X, load_share=0.5), T_R, MU)
    assert np.all(drive["width_at_rated"] > 0.0)
    assert np.allclose(drive["width_at_rated"], paper["width_at_rated"], rtol=1e-6, atol=0)
    # No preload: Coulomb friction vanishes with the forces at zero torque.
    for k in ("loss", "starting_torque", "backdriving_torque"):
        assert np.all(drive[k] == 0.0) and np.all(paper[k] == 0.0)


def test_drive_hysteresis_grows_with_mu_slot_and_vanishes_without_friction():
    from corr_cad.mechanics.losses.hysteresis import hysteresis_figures

    w = DriveWindup(D, X, bearing=BEARING)
    width = [
        hysteresis_figures(D, w, T_R, Friction(0.05, mu, 0.05, 0.0025, "bearing", 82.4))
        for mu in (0.0, 0.02, 0.05)
    ]
    assert np.all(width[1]["width_at_rated"] > width[0]["width_at_rated"])
    assert np.all(width[2]["width_at_rated"] > width[1]["width_at_rated"])
    assert np.all(width[2]["loss"] == 0.0)  # no preload: no loss at zero torque
    none = hysteresis_figures(D, w, T_R, Friction(0, 0, 0, 0, "bearing", 82.4))
    assert np.all(none["width_at_rated"] == 0.0) and np.all(none["loss"] == 0.0)
