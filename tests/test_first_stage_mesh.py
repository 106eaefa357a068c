"""The first stage in the whole drive: mesh losses, mesh stiffness, and the checks that read
the whole drive's figures (corr_cad.mechanics.gears.first_stage_mesh, the checks stage).

Expected values: the sliding loss integrated along the path of contact here
(sliding speed from the gears' angular speeds, load halved where two pairs
mesh), the ISO 6336-1 mesh stiffness carried through three wheels by hand,
and the compound template run from the command line.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from corr_cad.geometry.first_stage import FirstStage, first_stage_geometry
from corr_cad.mechanics.gears.first_stage_mesh import addendum_contact_ratios, first_stage_mesh

ROOT = Path(__file__).resolve().parents[1]
FS = dict(
    pinion_teeth=18,
    wheel_teeth=36,
    crank_gear_teeth=90,
    module=1.5,
    pressure_angle_deg=20.0,
    shift_pinion=0.5,
    shift_wheel=0.0,
    shift_crank_gear=0.5,
    face_width=15.0,
    addendum=1.0,
    dedendum=1.25,
    backlash_allowance=0.03,
)


def _sliding_loss(rb1, rb2, internal, eps1, eps2, pb):
    """Loss over transmitted power per unit mu: integral of share(x) v_slide / v_t over the
    path of contact, over one base pitch; x from the pitch point along the line of action
    (recess towards tip 1). Piecewise: the sliding speed is linear in |x| between the
    pitch point and the ends of the two-pair zones, so the trapezoid rule is exact there."""
    w = abs(1.0 / rb1 - 1.0 / rb2) if internal else 1.0 / rb1 + 1.0 / rb2  # v_t = 1
    ends = sorted({-eps2 * pb, (eps1 - 1.0) * pb, 0.0, (1.0 - eps2) * pb, eps1 * pb})
    total = 0.0
    for a, b in zip(ends[:-1], ends[1:], strict=True):
        mid = 0.5 * (a + b)
        double = mid < (eps1 - 1.0) * pb or mid > (1.0 - eps2) * pb
        share = 0.5 if double else 1.0
        total += share * w * 0.5 * (abs(a) + abs(b)) * (b - a)
    return total / pb


def test_gear_loss_factors_against_the_sliding_integral():
    g = first_stage_geometry(FirstStage(**FS))
    (e1p, e1w), (e2w, e2c) = addendum_contact_ratios(g)
    # Each mesh's tips share its contact ratio.
    assert e1p + e1w == pytest.approx(g.contact_ratio[0], rel=1e-12)
    assert e2w + e2c == pytest.approx(g.contact_ratio[1], rel=1e-12)
    pb = math.pi * 1.5 * math.cos(math.radians(20.0))
    mu = 0.06
    m = first_stage_mesh(g, 26, mu)
    rbp, rbw, rbc = g.pinion.base_radius, g.wheel.base_radius, g.crank_gear.base_radius
    h1 = _sliding_loss(rbp, rbw, False, e1p, e1w, pb)
    h2 = _sliding_loss(rbw, rbc, True, e2w, e2c, pb)
    assert m.loss_factors[0] == pytest.approx(h1, rel=1e-8)
    assert m.loss_factors[1] == pytest.approx(h2, rel=1e-8)
    assert m.efficiency == pytest.approx((1 - mu * h1) * (1 - mu * h2), rel=1e-8)
    # The internal mesh slides less: (u + 1) / u is 1 - 1/|u| there.
    assert m.loss_factors[1] < m.loss_factors[0]
    assert m.efficiency == pytest.approx(0.986, abs=5e-4)  # docs/physics.md
    # Limiting case: no friction, no loss.
    assert first_stage_mesh(g, 26, 0.0).efficiency == 1.0


def test_mesh_stiffness_through_three_wheels_by_hand():
    g = first_stage_geometry(FirstStage(**FS))
    m = first_stage_mesh(g, 26, 0.05)
    k = 20.0 * 1000.0 * 15.0  # c_gamma 20 N/(mm um) times the face width: N/mm
    # A crank moment M: F = M / (3 r_bc) on each wheel's crank mesh; the wheel passes
    # the same force to the pinion mesh (one base radius); both deflections add.
    M = 1.0e5
    F = M / (3 * g.crank_gear.base_radius)
    theta = (F / k + F / k) / g.crank_gear.base_radius
    assert m.crank_stiffness == pytest.approx(M / theta, rel=1e-12)
    assert m.output_stiffness == pytest.approx(26**2 * M / theta, rel=1e-12)
    assert m.output_backlash == pytest.approx(g.crank_backlash_rad / 26, rel=1e-15)
    # docs/physics.md: about 356,000 N*m/arcmin at the output
    assert m.output_stiffness * math.pi / 10800 / 1000 == pytest.approx(356000, rel=2e-3)


@pytest.mark.slow
def test_compound_lost_motion_limit_fails_naming_the_first_stages_share(tmp_path):
    """templates/compound.toml with max_lost_motion_arcmin = 0.1: the second stage alone
    (0.007 arcmin) passes; the whole drive, with the first stage's 0.235, fails."""
    text = (ROOT / "templates" / "compound.toml").read_text()
    text = text.replace(text[text.index("formats = [") :].split("\n")[0], 'formats = ["forces"]')
    text = text.replace(
        "[checks]\n", "[checks]\nmax_lost_motion_arcmin = 0.1\nmax_backlash_arcmin = 0.1\n"
    )
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "o"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(tmp_path / "s.toml"), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 1, r.stderr
    checks = json.loads((out / "manifest.json").read_text())["checks"]
    lm = checks["max_lost_motion_arcmin"]
    assert lm["passed"] is False and lm["second_stage"] < 0.1 < lm["first_stage"]
    assert lm["value"] == pytest.approx(lm["second_stage"] + lm["first_stage"], rel=1e-15)
    assert lm["first_stage"] == pytest.approx(0.2355, abs=5e-4)
    assert lm["figure"].startswith("whole drive at the output")
    bl = checks["max_backlash_arcmin"]
    assert bl["passed"] is False and bl["first_stage"] == pytest.approx(0.235, abs=5e-4)
    share = f"first stage {lm['first_stage']:.4g}"
    assert share in r.stderr and "check failed: max_lost_motion_arcmin" in r.stderr
    # The second stage's search for a passing change is not offered for a whole-drive figure.
    assert "passes with" not in r.stderr


def test_loss_factor_is_ohlendorfs_closed_form_where_both_tips_share_at_most_one():
    from corr_cad.mechanics.gears.first_stage_mesh import gear_loss_factor

    for e1, e2 in ((0.7, 0.6), (0.9, 0.95), (0.5, 0.99)):
        closed = math.pi * (2 + 1) / (18 * 2) * (1 - e1 - e2 + e1**2 + e2**2)
        assert gear_loss_factor(18, 2.0, e1, e2) == pytest.approx(closed, rel=1e-14)


def test_whole_drive_values_add_backlash_and_put_rigidities_in_series():
    from corr_cad.run.stages.stages_first_stage import whole_drive_values

    second = {"backlash_arcmin": 0.01, "torsional_rigidity_Nm_per_arcmin": 1000.0}
    first = {"backlash_arcmin": 0.2, "torsional_rigidity_Nm_per_arcmin": 3000.0, "efficiency": 0.9}
    out = whole_drive_values(second, first)
    assert out["backlash_arcmin"]["value"] == pytest.approx(0.21, rel=1e-15)
    assert out["torsional_rigidity_Nm_per_arcmin"]["value"] == pytest.approx(750.0, rel=1e-15)
    assert "efficiency" not in out  # no second-stage figure: nothing to combine
    eff = whole_drive_values({"efficiency": 0.8}, first)["efficiency"]
    assert eff["value"] == pytest.approx(0.72, rel=1e-15) and eff["first_stage"] == 0.9


@pytest.mark.slow
def test_monte_carlo_gates_the_whole_drives_backlash(tmp_path):
    """Under [first_stage] a Monte Carlo gate on max_backlash_arcmin judges each sample's
    second-stage backlash plus the first stage's (nominal gears): recounted from the CSV."""
    text = (ROOT / "templates" / "compound.toml").read_text()
    formats = text[text.index("formats = [") :].split("\n")[0]
    text = text.replace(formats, 'formats = ["montecarlo"]')
    text = text.replace(
        "[checks]\n", "[checks]\nmax_backlash_arcmin = 0.3\nmax_failure_probability = 0.5\n"
    )
    text += "\n[tolerances]\ncam_radius = { uniform = 0.01 }\n"
    text += "[montecarlo]\nsamples = 16\npositions = 52\nseed = 1\n"
    (tmp_path / "s.toml").write_text(text)
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "corr_cad", "run", str(tmp_path / "s.toml"), "--out", str(out)]
    r = subprocess.run(cmd + ["--quiet"], capture_output=True, text=True)
    assert r.returncode in (0, 1), r.stderr
    summary = json.loads((out / "montecarlo_summary.json").read_text())
    lim = summary["whole_drive_limits"]["max_backlash_arcmin"]
    assert lim["limit"] == 0.3 and lim["first_stage"] == pytest.approx(0.2351, abs=1e-4)
    assert lim["second_stage_limit"] == pytest.approx(0.3 - lim["first_stage"], rel=1e-15)
    with open(out / "montecarlo.csv", newline="") as fh:
        backlash = [float(row["backlash_arcmin"]) for row in csv.DictReader(fh)]
    whole = [b + lim["first_stage"] for b in backlash]
    p = sum(w > 0.3 for w in whole) / len(whole)
    assert 0.0 < p < 1.0  # the case separates samples: the first stage's share decides
    assert summary["failure_probability"]["max_backlash_arcmin"] == pytest.approx(p, rel=1e-15)


def test_the_solids_of_the_whole_drive_are_cut_at_the_chord_tolerance(tmp_path):
    """With ``[first_stage]`` the drive's stage makes the part outlines at ``tolerance``;
    the solids reuse them only where ``chord_tolerance`` is the same: at a coarser chord
    the ring's STL is the one of outlines made at the chord tolerance."""
    from corr_cad.export import mesh
    from corr_cad.geometry.design import GearDesign
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import working_profile

    root = Path(__file__).resolve().parents[1]
    text = (root / "templates" / "compound.toml").read_text()
    text = text.replace(
        text[text.index("formats = ") : text.index("\n", text.index("formats = "))],
        'formats = ["stl"]\nchord_tolerance = 0.05',
    )
    (tmp_path / "s.toml").write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    design = GearDesign()  # the template's second stage is the prototype's
    ring = part_outlines(design, working_profile(design), 0.05)["ring"]
    want = mesh.write_mesh(mesh.to_trimesh(mesh.solid(ring)), tmp_path / "ring.stl", "stl")
    assert (tmp_path / "out" / "inner_gear.stl").read_bytes() == want.read_bytes()
