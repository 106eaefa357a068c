"""Hysteresis loss and starting torque of a drive with free play at zero torque.

With free play (undersize rollers, a slot clearance, a bearing clearance) no
contact carries a force at zero torque, so the zero-torque dissipation and the
no-load losses are zero there by the model's own statement, and the drive is
not solved at the tiny torques (where every Palmgren law starts from zero
stiffness and the cams float in their clearances). A preload keeps its loss.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.errors import SolverError
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive_windup import DriveWindup
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.losses.hysteresis import hysteresis_figures, hysteresis_loop
from corr_cad.mechanics.row.windup import mesh_period_rad

D = GearDesign()
T_R = 2.86e6  # N*mm
X = mesh_period_rad(D) * np.arange(4) / 4
MU = Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4)
LOOSE = EccentricBearing(
    needles=30, needle_diameter=4.0, needle_length=10.0, diametral_clearance=0.002
)


def _refuse_tiny_torques(w: DriveWindup) -> list:
    """Make ``w`` raise on any solve below 1e-3 T_R; returns the torques it was asked for."""
    asked = []
    solve = w._solve

    def guarded(T: float):
        asked.append(float(T))
        if abs(T) < 1e-3 * T_R:
            raise SolverError(f"tiny-torque solve at {T!r} N*mm")
        return solve(T)

    w._solve = guarded
    return asked


def test_free_play_gives_zero_loss_without_a_tiny_torque_solve():
    w = DriveWindup(
        D,
        X,
        errors=ManufacturingErrors(roller_radius_error=-0.002),
        errors_b=ManufacturingErrors(roller_radius_error=-0.001),
        bearing=LOOSE,
    )
    assert np.all(w.backlash() > 0.0) and np.all(w.slack())
    asked = _refuse_tiny_torques(w)
    h = hysteresis_figures(D, w, T_R, MU)
    for k in ("loss", "starting_torque", "backdriving_torque"):
        assert np.all(h[k] == 0.0), k
    assert np.all(h["width_at_rated"] > 0.0)  # the loop opens under load
    assert asked and min(abs(t) for t in asked) >= 1e-3 * T_R
    # The loop at the +-0 levels: both branches on the free ends, no tiny solve either.
    loop = hysteresis_loop(D, w, np.array([-T_R, -0.0, 0.0, T_R]), T_R, MU)
    for b in ("rising", "falling"):
        assert np.all(loop[b][1:3] == 0.0) and np.all(loop[b][[0, 3]] > 0.0)


def test_a_preloaded_drive_keeps_its_loss_and_starting_torque():
    # Cam 2 um oversize in both rows, rigid cams: every roller pressed at zero torque.
    w = DriveWindup(D, X, errors=ManufacturingErrors(cam_radius_error=0.002))
    assert not np.any(w.slack())
    h = hysteresis_figures(D, w, T_R, MU)
    for k in ("loss", "starting_torque", "backdriving_torque"):
        assert np.all(h[k] > 0.0), k


def test_only_the_preloaded_positions_are_solved_at_zero_torque():
    """Positions marked slack get zero; the others keep the full bench's value."""
    w = DriveWindup(D, X, errors=ManufacturingErrors(cam_radius_error=0.002))
    full = hysteresis_figures(D, w, T_R, MU)
    mixed = DriveWindup(D, X, errors=ManufacturingErrors(cam_radius_error=0.002))
    slack = np.array([True, False, True, False])
    mixed.slack = lambda: slack
    h = hysteresis_figures(D, mixed, T_R, MU)
    for k in ("loss", "starting_torque", "backdriving_torque"):
        assert np.all(h[k][slack] == 0.0), k
        np.testing.assert_allclose(h[k][~slack], full[k][~slack], rtol=1e-9, err_msg=k)


SCENE = """\
[design]
tooth_count = 9
cam_radius = 45.0
roller_radius = 4.0
eccentricity = 1.5
slot_clearance = 0.004
[export]
formats = ["datasheet"]
[load]
input_torque = 2.0e4
[solver]
positions = 40
model = "drive"
contact_law = "palmgren"
[checks]
max_lost_motion_arcmin = 30.0
[datasheet]
positions_per_mesh = 4
transmission_error_positions_per_turn = 36
[bearings.eccentric]
needles = 30
needle_diameter = 4.0
needle_length = 10.0
diametral_clearance = 0.002
[errors]
roller_radius_error = -0.002
[errors.row_b]
roller_radius_error = -0.001
[friction]
mu_cam = 0.05
mu_ring = 0.05
mu_slot = 0.05
[life]
rated_life_h = 6000.0
"""


@pytest.mark.slow
def test_a_drive_with_backlash_and_friction_runs_through_the_cli(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE)
    out = tmp_path / "out"
    run = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0, run.stderr
    ds = json.loads((out / "datasheet.json").read_text())
    assert ds["backlash_arcmin"]["min"] > 0.0
    assert ds["hysteresis_loss_arcmin"] == 0.0
    assert ds["starting_torque_Nm"]["max"] == 0.0
    assert ds["hysteresis_width_at_rated_arcmin"]["min"] > 0.0
    rows = (out / "hysteresis.csv").read_text().splitlines()
    zero = [r.split(",") for r in rows[1:] if r.split(",")[1] in ("-0", "0")]
    assert len(zero) == 2
    for r in zero:  # both branches on the frictionless free end
        assert r[3] == r[2] == r[4]
