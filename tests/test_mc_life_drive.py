"""Life percentiles under tolerances with ``[solver] model = "drive"`` (both rows, both cams).

The limiting case, derived: two identical rows on rigid cams (no bearing
compliance), the nominal design. Row B sits at crank angle ``phi + pi``;
with an even roller count its rollers there are row A's at ``phi`` turned
by half the rollers, so both rows answer the shared crank rotation alike
and each carries half the moment at every position: row by row the
paper's one row at ``load_share`` 0.5, so the raceways' lives are its.
The bearing differs by what it is rated on: the drive rates each cam's
frictionless ``|sum F_j n_k|`` (forces.csv's ``bearing_load``), the paper's
row the friction model's friction-loaded resultant. With no contact
friction (only ``mu_bearing``) the two are the same load, and every life,
bearing included, is the paper's at 0.5; with contact friction the paper's
bearing load is the larger, so the drive's bearing lives longer.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.drive.drive_windup import DriveWindup
from corr_cad.mechanics.life import LifeSpec
from corr_cad.mechanics.losses.efficiency import (
    drive_life,
    friction_figures,
    rows_from_drive,
)
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.tolerance.mc_life import life_percentiles, life_samples
from corr_cad.tolerance.montecarlo import Distribution

D = GearDesign()
T_R = 2.86e6
FR = Friction(0.05, 0.05, 0.05, 0.0025, "bearing", 82.4)
RIGID = {"errors_b": None, "bearing": None, "bearing_b": None, "contact_model": "nonlinear"}
ZERO = {"roller_radius": Distribution("normal", 0.0)}
# The nominal design over one tooth pitch at 4 positions per mesh period.
X = 2 * np.pi / D.tooth_count * np.arange(4 * D.roller_count) / (4 * D.roller_count)


@pytest.mark.slow
def test_zero_tolerance_drive_samples_reproduce_the_drives_nominal_life():
    lives = life_samples(D, ManufacturingErrors(), ZERO, 2, 1, LifeSpec(), FR, T_R, drive=RIGID)
    dw = DriveWindup(D, X)
    ff = friction_figures(
        D,
        None,
        T_R,
        FR,
        [1.0],
        [1.0],
        LifeSpec(),
        rows_at=lambda T: rows_from_drive(D, dw.forces(T)),
    )
    assert set(lives) == set(ff.lives)
    for name, v in lives.items():
        assert np.allclose(v, ff.lives[name], rtol=1e-9), name


@pytest.mark.slow
@pytest.mark.parametrize("mu_contact", [0.0, 0.05])
def test_identical_rigid_rows_give_the_paper_lives_at_share_one_half(mu_contact):
    assert D.roller_count % 2 == 0  # the derivation above needs an even roller count
    fr = Friction(mu_contact, mu_contact, mu_contact, 0.0025, "bearing", 82.4)
    drive = life_samples(D, ManufacturingErrors(), ZERO, 1, 3, LifeSpec(), fr, T_R, drive=RIGID)
    paper = life_samples(D, ManufacturingErrors(), ZERO, 1, 3, LifeSpec(), fr, T_R, load_share=0.5)
    # No friction coefficient enters a life (frictionless loads, rolling kinematics):
    # every component alike at any mu.
    for name in drive:
        assert drive[name][0] == pytest.approx(paper[name][0], rel=1e-9), name


@pytest.mark.slow
def test_row_b_draws_its_own_rollers():
    """Row A's draws are the seed's (the paper's), row B's its own: the rows' lives differ."""
    tol = {"roller_radius": Distribution("normal", 0.001)}
    lives = life_samples(D, ManufacturingErrors(), tol, 2, 7, LifeSpec(), FR, T_R, drive=RIGID)
    assert np.all(np.abs(lives["ring_row1"] / lives["ring_row2"] - 1.0) > 1e-3)
    assert np.all(np.abs(lives["bearing_row1"] / lives["bearing_row2"] - 1.0) > 1e-3)
    # Row B scatters too, from its own stream: its raceway leaves the nominal life.
    nominal = life_samples(D, ManufacturingErrors(), ZERO, 1, 7, LifeSpec(), FR, T_R, drive=RIGID)
    assert not np.allclose(lives["ring_row2"], nominal["ring_row2"][0], rtol=1e-6)
    # Sample 1 rebuilt from the streams by hand: draw_samples draws, kind by kind in
    # TOLERANCE_KINDS' order, every sample's normals then uniforms; roller_radius comes
    # after three scalar kinds. Row A: the seed's generator; row B: [seed, 1].
    R, n = D.roller_count, 2

    def rollers(rng):
        for _ in range(3):  # cam_radius, eccentricity, cam_phase: normal, uniform
            rng.standard_normal(n)
            rng.uniform(-1.0, 1.0, n)
        return tuple(0.001 * rng.standard_normal((n, R))[1])

    a = ManufacturingErrors(roller_radius_errors=rollers(np.random.default_rng(7)))
    b = ManufacturingErrors(roller_radius_errors=rollers(np.random.default_rng([7, 1])))
    rows = rows_from_drive(D, DriveWindup(D, X, errors=a, errors_b=b).forces(-T_R))
    by_hand = drive_life(D, rows, LifeSpec(), "bearing", 15.0)
    for name in ("ring_row1", "ring_row2", "bearing_row2", "system"):
        assert lives[name][1] == pytest.approx(by_hand[name], rel=1e-9), name
    p = life_percentiles(lives, model="drive")
    assert p["model"] == "drive" and "drive" in p["definition"]
    assert "model" not in life_percentiles(lives)


@pytest.mark.slow
def test_drive_montecarlo_run_reports_the_drives_life_percentiles(tmp_path):
    from corr_cad.run.cli import main

    scene = tmp_path / "s.toml"
    scene.write_text(
        "[load]\ninput_torque = 1.1e5\n[export]\nformats = ['montecarlo']\n"
        '[solver]\nmodel = "drive"\n'
        "[tolerances]\ncam_radius = { normal = 0.001 }\n"
        "[montecarlo]\nsamples = 8\npositions = 26\n[life]\nmontecarlo_samples = 3\n"
    )
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"]) == 0
    life = json.loads((out / "montecarlo_summary.json").read_text())["life_h"]
    assert life["samples"] == 3 and life["model"] == "drive"
    assert "drive" in life["definition"]
    for name in ("bearing_row1", "bearing_row2", "ring_row2", "system"):
        assert life[name]["p5"] <= life[name]["p50"] <= life[name]["p95"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["montecarlo"]["life_h"] == life
