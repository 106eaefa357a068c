"""Bounds of the efficiency over the load range, with and without a preload, on the paper's
row and on the drive (corr_cad.mechanics.losses.operating, efficiency).

- forward: 0 < eta <= 1 at every torque from 1 % to 100 % of T_R;
- backdriving: in (0, 1] or self-locking (reported as 0, flagged), never
  above forward at the same torque;
- every mu -> 0: eta -> 1 continuously: with the coefficients scaled by
  lambda, Coulomb losses scale with lambda, so ``1 - eta <= lambda L_1 / T``
  with ``L_1 / T = (1 - eta_1) / eta_1`` (forward) at lambda = 1, and exactly 1
  at lambda = 0.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.drive.drive_windup import DriveWindup
from corr_cad.mechanics.losses.efficiency import friction_figures, rows_from_drive
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad

D = GearDesign()
T_R = 2.86e6  # N*mm
X = mesh_period_rad(D) * np.arange(6) / 6
SHARES = [0.01, 0.03, 0.1, 0.2, 0.5, 1.0]
PRELOAD = ManufacturingErrors(roller_radius_error=0.001)
BEARING = EccentricBearing(needles=40, needle_diameter=6.0, needle_length=12.0)


def _mu(scale: float) -> Friction:
    return Friction(0.05 * scale, 0.05 * scale, 0.05 * scale, 0.0025 * scale, "bearing", 82.4)


def _figures(model: str, errors, friction: Friction, shares=SHARES):
    if model == "paper":
        return friction_figures(D, Windup(D, X, errors=errors), T_R, friction, shares, [1000.0])
    w = DriveWindup(D, X, errors=errors, bearing=BEARING)
    return friction_figures(
        D, None, T_R, friction, shares, [1000.0], rows_at=lambda T: rows_from_drive(D, w.forces(T))
    )


def _check_bounds(ff) -> None:
    assert np.all(ff.forward > 0.0) and np.all(ff.forward <= 1.0)
    assert np.all(ff.backdriving >= 0.0) and np.all(ff.backdriving <= ff.forward)
    locked = ff.backdriving == 0.0
    fig = ff.figures()["efficiency_backdriving"]
    assert fig["self_locking"] is bool(np.any(locked))
    assert fig["self_locking_torque_shares"] == [float(s) for s in ff.shares[locked]]
    assert ff.balance <= 1e-9


@pytest.mark.parametrize("errors", [None, PRELOAD], ids=["free", "preload"])
def test_paper_row_bounds_over_the_load_range(errors):
    ff = _figures("paper", errors, _mu(1.0))
    _check_bounds(ff)
    if errors is None:  # Coulomb without preload: the same efficiency at every torque
        assert np.ptp(ff.forward) < 1e-6 and not np.any(ff.backdriving == 0.0)
    else:  # the preload's losses stay at no load: the efficiency falls at low torque
        assert np.all(np.diff(ff.forward) > 0.0)
        assert ff.backdriving[0] == 0.0  # self-locking at 1 % of T_R
        # efficiency.png's legend says what the backdriving curve's 0 means
        import matplotlib.pyplot as plt

        from corr_cad.export.friction_io import efficiency_figure

        fig = efficiency_figure(ff)
        labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
        plt.close(fig)
        assert "backdriving (0: self-locking)" in labels


@pytest.mark.slow
@pytest.mark.parametrize("errors", [None, PRELOAD], ids=["free", "preload"])
def test_drive_bounds_over_the_load_range(errors):
    _check_bounds(_figures("drive", errors, _mu(1.0)))


@pytest.mark.parametrize("model", ["paper", pytest.param("drive", marks=pytest.mark.slow)])
def test_efficiency_goes_to_one_continuously_with_every_mu(model):
    shares = [0.03, 1.0]
    one = _figures(model, PRELOAD, _mu(1.0), shares)
    bound = (1.0 - one.forward) / one.forward
    for lam in (0.1, 0.01, 1e-4):
        ff = _figures(model, PRELOAD, _mu(lam), shares)
        for eta in (ff.forward, ff.backdriving):
            assert np.all(1.0 - eta <= 1.2 * lam * bound)
    zero = _figures(model, PRELOAD, _mu(0.0), shares)
    assert np.all(zero.forward == 1.0) and np.all(zero.backdriving == 1.0)


@pytest.mark.slow
def test_preloaded_prototype_from_the_command_line(tmp_path):
    """The prototype, rollers 1 um oversize: no negative efficiency, self-locking reported,
    and efficiency.csv's powers balance (each computed on its own from the forces)."""
    scene = tmp_path / "s.toml"
    scene.write_text(
        "[load]\ninput_torque = 1.1e5\n[export]\nformats = ['datasheet']\n"
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 12\n"
        "[errors]\nroller_radius_error = 0.001\n"
        "[friction]\nmu_cam = 0.05\nmu_slot = 0.05\nmu_ring = 0.05\nmu_bearing = 0.0025\n"
        "positions_per_mesh = 2\nefficiency_speeds_rpm = [1000.0]\n[life]\n"
    )
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"]
    assert subprocess.run(cmd, capture_output=True, text=True).returncode == 0
    eff = np.genfromtxt(out / "efficiency.csv", delimiter=",", names=True, dtype=None)
    fwd, back = eff["efficiency_forward"], eff["efficiency_backdriving"]
    assert np.all(fwd > 0.0) and np.all(fwd <= 1.0) and np.all(back <= fwd)
    assert fwd[0] == pytest.approx(0.31, abs=0.02)  # 10 % of T_R
    locked = np.char.lower(eff["self_locking_backdriving"].astype(str)) == "true"
    assert locked[0] and np.all(back[locked] == 0.0) and not locked[-1]
    # docs: self-locking backwards up to 20 % of T_R, forward 0.80 at T_R
    assert locked[1] and not locked[2] and fwd[-1] == pytest.approx(0.80, abs=0.01)
    losses = sum(eff[c] for c in ("loss_cam_W", "loss_slot_W", "loss_ring_W", "loss_bearing_W"))
    resid = eff["input_power_W"] - losses - eff["output_power_W"]
    assert np.all(np.abs(resid) <= 1e-7 * eff["input_power_W"])
    w_out = 2 * np.pi * eff["input_speed_rpm"] / 60 / D.roller_count
    assert np.allclose(eff["output_power_W"], eff["output_torque_Nm"] * w_out, rtol=1e-8)
    ds = json.loads((out / "datasheet.json").read_text())
    b = ds["efficiency_backdriving"]
    assert b["self_locking"] is True
    lo, hi = b["self_locking_torque_range_Nm"]
    assert lo == pytest.approx(eff["output_torque_Nm"][0]) and hi < ds["rated_torque_Nm"]


def test_a_cam_fixed_on_the_crank_slides_and_self_locks_backwards():
    """docs/datasheet.md: about 0.32 forward with 0.05 everywhere, self-locking backwards."""
    fixed = Friction(0.05, 0.05, 0.05, 0.0025, "fixed", 82.4)
    ff = friction_figures(D, Windup(D, X), T_R, fixed, [0.1, 1.0], [1000.0])
    assert np.allclose(ff.forward, 0.32, atol=0.005)
    assert np.all(ff.backdriving == 0.0) and ff.figures()["efficiency_backdriving"]["self_locking"]
