"""Measured profiles: registration, round trips through CSV and DXF, bad data."""

import json

import ezdxf
import numpy as np
import pytest

from corr_cad import GearDesign, ProfileError, working_profile
from corr_cad import kinematics as kin
from corr_cad.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.export.measured_io import read_measured_points
from corr_cad.measured import register, validate_points
from corr_cad.outputs import StagingDir
from corr_cad.pipeline import run_scene
from corr_cad.scene import load_scene
from corr_cad.solver import solve_forces

DEV = harmonic_deviation([(3, 0.004, 20.0), (25, 0.002, 0.0)])
ROT, SHIFT = np.radians(0.3), np.array([0.05, -0.02])


@pytest.fixture(scope="module")
def measured():
    """The nominal profile with a known deviation, placed off-centre and turned."""
    design = GearDesign()
    w = working_profile(design)
    t = np.linspace(0, 2 * np.pi, 6000, endpoint=False)
    pts = w.points(t) - DEV(t)[:, None] * w.normals(t)  # + = material added = inwards
    return design, w, kin.rotate_by_polar_angle(pts, ROT) + SHIFT


def test_registration_recovers_placement_and_deviation(measured):
    _, w, pts = measured
    reg = register(w, pts)
    assert reg.rotation_deg == pytest.approx(0.3, abs=1e-6)
    np.testing.assert_allclose(reg.centre_mm, SHIFT, atol=1e-6)
    t = np.linspace(0, 2 * np.pi, 997)
    np.testing.assert_allclose(reg.deviation(t), DEV(t), atol=2e-6)


def _write_csv(path, pts):
    path.write_text("x,y\n" + "\n".join(f"{x:.12f},{y:.12f}" for x, y in pts) + "\n")


def _write_dxf(path, pts):
    doc = ezdxf.new("R2018")
    doc.header["$INSUNITS"] = 4  # the points are mm (ezdxf.new says metres)
    doc.modelspace().add_lwpolyline(
        pts.tolist(), close=True, dxfattribs={"layer": "MEASURED_PROFILE"}
    )
    doc.saveas(path)


@pytest.mark.parametrize("kind", ["csv", "dxf"])
def test_round_trip_to_forces(measured, tmp_path, kind):
    design, w, pts = measured
    src = tmp_path / f"measured.{kind}"
    (_write_csv if kind == "csv" else _write_dxf)(src, pts)
    scene = tmp_path / "s.toml"
    scene.write_text(
        f'[export]\nformats = ["forces", "dxf"]\n[load]\ninput_torque = 1.1e5\n'
        "[solver]\ncrank_angles_deg = [0.0, 7.0, 33.0]\n"
        f'[errors]\nmeasured_profile = "{src.name}"\n'
    )
    out = tmp_path / "o"
    with StagingDir(out) as stage:
        m = run_scene(load_scene(scene), stage)
    reg = m["measured_profile"]
    assert reg["rotation_deg"] == pytest.approx(0.3, abs=1e-5)
    assert reg["max_abs_deviation_mm"] == pytest.approx(0.006, abs=2e-4)
    direct = solve_forces(
        design,
        1.1e5,
        np.radians([0.0, 7.0, 33.0]),
        errors=ManufacturingErrors(profile_deviation=DEV),
    )
    rows = np.loadtxt(out / "forces.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(rows[:, 5].reshape(3, 26), direct.F_n, rtol=2e-3, atol=1.0)
    # The comparison picture: nominal, measured, exaggerated, each closed.
    doc = ezdxf.readfile(out / "measured_profile.dxf")
    layers = {e.dxf.layer for e in doc.modelspace()}
    assert {"WORKING_PROFILE", "MEASURED_PROFILE", "DEVIATION_EXAGGERATED"} <= layers
    assert json.loads((out / "manifest.json").read_text())["files"]["measured_profile.dxf"]


def test_bad_measured_data(measured, tmp_path):
    _, w, pts = measured
    with pytest.raises(ProfileError, match="too few"):
        validate_points(pts[::100], w, "m")
    bad = pts.copy()
    bad[10, 0] = np.nan
    with pytest.raises(ProfileError, match="1 points are NaN"):
        validate_points(bad, w, "m")
    with pytest.raises(ProfileError, match="looks like inches"):
        validate_points(pts / 25.4, w, "m")
    with pytest.raises(ProfileError, match="looks like metres"):
        validate_points(pts / 1000.0, w, "m")
    ang = np.mod(np.arctan2(pts[:, 0], pts[:, 1]), 2 * np.pi)
    with pytest.raises(ProfileError, match="not closed"):
        validate_points(pts[(ang < 1.0) | (ang > 1.5)], w, "m")
    crossed = pts.copy()
    crossed[[100, 2000]] = crossed[[2000, 100]]
    f = tmp_path / "x.csv"
    _write_csv(f, crossed)
    with pytest.raises(ProfileError, match="intersects itself"):
        read_measured_points(f)
    f.write_text("a,b\n1,2\n")
    with pytest.raises(ProfileError, match="columns x,y"):
        read_measured_points(f)
    f.write_text("x,y\n1,abc\n")
    with pytest.raises(ProfileError, match="not a number"):
        read_measured_points(f)
    with pytest.raises(ProfileError, match="does not exist"):
        read_measured_points(tmp_path / "nope.csv")
