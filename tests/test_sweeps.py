"""The paper's parametric sweeps."""

import csv
import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.tolerance.montecarlo import SerialExecutor
from corr_cad.tolerance.sweeps import PAPER_SWEEPS, comparison_rows, run_sweeps, sweep_point

M0 = 1.1e5


def test_points_in_undercut_are_reported_not_computed():
    p = sweep_point(GearDesign(), "roller_radius", 13.5, M0, 52, 0.55)
    assert p["status"].startswith("undercut") and "10.05" in p["status"]
    assert "F_j_mean" not in p
    q = sweep_point(GearDesign(), "roller_radius", 20.0, M0, 52, 0.55)
    assert q["status"].startswith("invalid: roller_radius = 20: adjacent rollers collide")


def test_sweep_point_equals_a_direct_solve():
    p = sweep_point(GearDesign(), "eccentricity_error", 0.01, M0, 104, 0.55)
    res = solve_forces(
        GearDesign(), M0, positions=104, errors=ManufacturingErrors(eccentricity_error=0.01)
    )
    assert p["F_n_peak"] == pytest.approx(res.summary()["F_n_peak"], rel=1e-14)
    d = sweep_point(GearDesign(), "cam_radius", 150.0, M0, 104, 0.55)
    res = solve_forces(GearDesign(cam_radius=150.0), M0, positions=104)
    assert d["F_j_mean"] == pytest.approx(res.summary()["F_j_mean"], rel=1e-14)


def test_sweeps_cover_the_paper_ranges_and_compare():
    res = run_sweeps(GearDesign(), M0, 3, 52, executor=SerialExecutor())
    assert set(res) == set(PAPER_SWEEPS)
    for name, pts in res.items():
        _, lo, hi = PAPER_SWEEPS[name]
        if name == "roller_radius":  # clipped at the undercut limit 10.053 mm
            hi = 10.05298
        np.testing.assert_allclose([p["value"] for p in pts], [lo, 0.5 * (lo + hi), hi], rtol=1e-6)
    rows = comparison_rows(res)
    cam = [r for r in rows if r["sweep"] == "cam_radius" and r["metric"] == "F_s_mean"][0]
    assert cam["paper_change_pct"] == pytest.approx(100 * (180 - 245) / 245)
    # Our F_s falls with the cam radius like the paper's (about -25 %).
    assert -35 < cam["ours_change_pct"] < -15


# --- sweeps around the user's design ---------------------------------------------

Z39 = """
[design]
tooth_count = 39
cam_radius = 135.0
roller_radius = 6.0
eccentricity = 2.0
[export]
formats = ["sweeps"]
[load]
input_torque = 1.1e5
[sweeps]
points = 3
positions = 40
"""


def _run(tmp_path, text, name="design"):
    scene = tmp_path / f"{name}.toml"
    scene.write_text(text)
    out = tmp_path / f"out_{name}"
    p = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"]
        + ["--executor", "serial"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    return p, out


def _undercut_free(d: GearDesign, name: str, v: float) -> bool:
    """Independent of the sweep code: the locus curvature from the closed form."""
    d = replace(
        d,
        **{name: v},
        ring_outer_radius=None,
        cam_bore_radius=None,
        frame_inner_radius=None,
        frame_outer_radius=None,
    )
    z, e, L, r = d.tooth_count, d.eccentricity, d.link_length, d.roller_radius
    t = np.linspace(0, 2 * np.pi / z, 20001)
    psi = z * t
    s = e * np.cos(psi) + np.sqrt(L**2 - (e * np.sin(psi)) ** 2)
    ds = np.gradient(s, t)
    d2s = np.gradient(ds, t)
    k = (s**2 + 2 * ds**2 - s * d2s) / (s**2 + ds**2) ** 1.5  # polar-curve curvature
    return bool(np.min(1 + r * k) > 0)


@pytest.mark.slow
def test_z39_sweeps_run_around_the_design_clipped_at_the_undercut(tmp_path):
    p, out = _run(tmp_path, Z39)
    assert p.returncode == 0, p.stderr
    assert not (out / "sweeps_vs_paper.csv").exists()  # not the paper's design
    with open(out / "sweep_roller_radius.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows] == ["ok"] * 3
    assert rows[0]["range_source"] == "default"
    assert (float(rows[0]["requested_min"]), float(rows[0]["requested_max"])) == (4.8, 7.2)
    assert rows[0]["clipped_high"] == "undercut" and rows[0]["clipped_low"] == ""
    lo, hi = float(rows[0]["value"]), float(rows[-1]["value"])
    assert lo == pytest.approx(4.8)
    d = GearDesign(tooth_count=39, roller_radius=6.0, eccentricity=2.0)
    # The clipped end is the undercut limit: valid just below, undercut just above.
    assert _undercut_free(d, "roller_radius", hi * (1 - 1e-4))
    assert not _undercut_free(d, "roller_radius", hi * (1 + 1e-4))
    js = json.loads((out / "sweeps.json").read_text())
    assert js["ranges"]["roller_radius"]["swept"][1] == pytest.approx(hi, rel=1e-5)
    assert "vs_paper" not in js
    # Errors: +-0.02 mm around the scene's (zero) error, stated.
    with open(out / "sweep_cam_radius_error.csv", newline="") as fh:
        err = list(csv.DictReader(fh))
    assert [float(r["value"]) for r in err] == [-0.02, 0.0, 0.02]
    # Design parameters: +-20 % around the design, where valid.
    with open(out / "sweep_eccentricity.csv", newline="") as fh:
        ecc = list(csv.DictReader(fh))
    assert float(ecc[0]["value"]) == pytest.approx(1.6) and ecc[0]["clipped_high"] == "undercut"
    assert _undercut_free(d, "eccentricity", float(ecc[-1]["value"]) * (1 - 1e-4))
    assert not _undercut_free(d, "eccentricity", float(ecc[-1]["value"]) * (1 + 1e-4))


@pytest.mark.slow
def test_scene_ranges_and_the_paper_comparison_only_for_table_1(tmp_path):
    text = Z39.replace("points = 3", "points = 2\neccentricity = [1.9, 2.1]")
    p, out = _run(tmp_path, text, "ranged")
    assert p.returncode == 0, p.stderr
    with open(out / "sweep_eccentricity.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["value"]) for r in rows] == [1.9, 2.1]
    assert rows[0]["range_source"] == "scene" and rows[0]["clipped_high"] == ""
    table1 = Z39.replace("tooth_count = 39", "tooth_count = 25")
    table1 = table1.replace("roller_radius = 6.0", "roller_radius = 8.0")
    table1 = table1.replace("eccentricity = 2.0", "eccentricity = 3.5").replace("= 3\n", "= 2\n")
    p, out = _run(tmp_path, table1, "table1")
    assert p.returncode == 0, p.stderr
    with open(out / "sweeps_vs_paper.csv", newline="") as fh:
        cmp_rows = list(csv.DictReader(fh))
    assert {r["sweep"] for r in cmp_rows} == set(PAPER_SWEEPS)
    rr = [r for r in cmp_rows if r["sweep"] == "roller_radius"][0]
    assert rr["paper_range"] == "7 .. 20" and rr["ours_range"].startswith("7 .. 10.05")


@pytest.mark.parametrize(
    "line,msg",
    [
        ("eccentricity = [3.0]", "[sweeps] eccentricity = [3.0]: must be [min, max]"),
        ("cam_radius = [150.0, 120.0]", "[sweeps] cam_radius = [150.0, 120.0]: must be [min, max]"),
        ("roller_radius = [0.0, 5.0]", "[sweeps] roller_radius = [0.0, 5.0]: allowed range"),
    ],
)
def test_bad_sweep_ranges_exit_2_with_one_line(tmp_path, line, msg):
    p, out = _run(tmp_path, Z39.replace("points = 3", f"points = 3\n{line}"), "bad")
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and msg in p.stderr
    assert not out.exists()


@pytest.mark.slow
def test_sweeps_use_the_scene_s_load_share(tmp_path):
    """Every other sweep test runs at the default 0.55: here the scene says 0.8.

    At zero error the three error sweeps solve the nominal design; its forces
    must be the solver's at the scene's load share, which for this design are
    the 0.55 forces scaled by 0.8 / 0.55 (the cam carries ``load_share * M0``).
    """
    p, out = _run(tmp_path, Z39 + "[solver]\nload_share = 0.8\n", "share")
    assert p.returncode == 0, p.stderr
    js = json.loads((out / "sweeps.json").read_text())
    d = GearDesign(tooth_count=39, roller_radius=6.0, eccentricity=2.0)
    at_08 = solve_forces(d, 1.1e5, positions=40, load_share=0.8).summary()
    at_055 = solve_forces(d, 1.1e5, positions=40, load_share=0.55).summary()
    for name in ("cam_radius_error", "eccentricity_error", "roller_radius_error"):
        (zero,) = [q for q in js["points"][name] if q["value"] == 0.0]
        for k in ("F_j_mean", "F_n_mean", "F_j_peak", "F_n_peak"):
            assert zero[k] == pytest.approx(at_08[k], rel=1e-9), (name, k)
            assert zero[k] == pytest.approx(at_055[k] * 0.8 / 0.55, rel=1e-4), (name, k)
    # A design point too: roller radius at the low end of its range (4.8 mm).
    low = js["points"]["roller_radius"][0]
    assert low["value"] == pytest.approx(4.8)
    ref = solve_forces(replace(d, roller_radius=4.8), 1.1e5, positions=40, load_share=0.8)
    assert low["F_j_peak"] == pytest.approx(ref.summary()["F_j_peak"], rel=1e-9)
