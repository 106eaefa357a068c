"""Measured profiles: registration, round trips through CSV and DXF, bad data."""

import json
import math

import ezdxf
import numpy as np
import pytest

from corr_cad import GearDesign, ProfileError, working_profile
from corr_cad.export.measured_io import read_measured_points
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.run.folder.outputs import StagingDir
from corr_cad.run.pipeline import run_scene
from corr_cad.run.scene.scene import load_scene
from corr_cad.tolerance.measured import register, validate_points

DEV = harmonic_deviation([(3, 0.004, 20.0), (25, 0.002, 0.0)])
ROT, SHIFT = 0.3 * math.pi / 180.0, np.array([0.05, -0.02])


def dev_by_hand(t):
    """The deviation DEV, written out (phase 20 deg = 20 pi / 180 rad)."""
    return 0.004 * np.cos(3 * t - 20.0 * math.pi / 180.0) + 0.002 * np.cos(25 * t)


def closed_form(t, z=25, e=3.5, Rj=135.0, r=8.0):
    """Roller-centre locus point and its outward unit normal, from the closed form.

    s = e cos(psi) + sqrt(L^2 - e^2 sin^2 psi), L = Rj + r, psi = z t, point
    s (sin t, cos t); the normal is the tangent turned a quarter, outwards.
    """
    L = Rj + r
    psi = z * t
    W = np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    s = e * np.cos(psi) + W
    ds = z * (-e * np.sin(psi) - e * e * np.sin(psi) * np.cos(psi) / W)
    tx, ty = ds * np.sin(t) + s * np.cos(t), ds * np.cos(t) - s * np.sin(t)
    n = np.stack([ty, -tx], axis=1) / np.hypot(tx, ty)[:, None]
    n *= np.sign(n[:, 0] * np.sin(t) + n[:, 1] * np.cos(t))[:, None]
    return s[:, None] * np.stack([np.sin(t), np.cos(t)], axis=1), n


def place(pts):
    """Turn every polar angle by ROT (from +y towards +x), then shift: by hand."""
    c, s = math.cos(ROT), math.sin(ROT)
    x, y = pts[:, 0], pts[:, 1]
    return np.stack([x * c + y * s, -x * s + y * c], axis=1) + SHIFT


@pytest.fixture(scope="module")
def measured():
    """The nominal profile with a known deviation, placed off-centre and turned.

    Built from the closed-form curve here, not from the package's normals or
    deviation function: working profile = locus + r n; + deviation = material
    added = inwards.
    """
    design = GearDesign()
    w = working_profile(design)
    t = np.linspace(0, 2 * np.pi, 6000, endpoint=False)
    P, n = closed_form(t)
    pts = P + (8.0 - dev_by_hand(t))[:, None] * n
    return design, w, place(pts)


@pytest.mark.slow
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


@pytest.mark.slow
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
    check_deviation_dxf(out / "measured_profile.dxf")
    assert json.loads((out / "manifest.json").read_text())["files"]["measured_profile.dxf"]


def _layer_points(doc, layer):
    """The closed contour on ``layer``, flattened by ezdxf's own path code (bulges too)."""
    from ezdxf import path

    (e,) = [x for x in doc.modelspace() if x.dxf.layer == layer]
    assert e.closed
    return np.array([(v.x, v.y) for v in path.make_path(e).flattening(1e-5)])


def _distance_to(points, curve):
    """Distance of each point to a dense closed polyline ``curve`` (segments)."""
    from scipy.spatial import cKDTree

    a, b = curve, np.roll(curve, -1, axis=0)
    _, idx = cKDTree(curve).query(points, k=4)
    best = np.full(len(points), np.inf)
    for j in range(4):
        for seg in (idx[:, j], (idx[:, j] - 1) % len(curve)):
            d = b[seg] - a[seg]
            u = np.clip(np.sum((points - a[seg]) * d, 1) / np.sum(d * d, 1), 0, 1)
            best = np.minimum(best, np.hypot(*(points - a[seg] - u[:, None] * d).T))
    return best


def check_deviation_dxf(path, exaggeration=200.0):
    """Each layer of measured_profile.dxf against the closed form written out here."""
    doc = ezdxf.readfile(path)
    assert float(doc.header.custom_vars.get("corr_cad.exaggeration")) == exaggeration
    t = np.linspace(0, 2 * np.pi, 400_000, endpoint=False)
    P, n = closed_form(t)
    nominal = P + 8.0 * n
    measured = P + (8.0 - dev_by_hand(t))[:, None] * n
    exaggerated = P + (8.0 - exaggeration * dev_by_hand(t))[:, None] * n
    assert _distance_to(_layer_points(doc, "WORKING_PROFILE"), nominal).max() < 1.1e-3
    assert _distance_to(_layer_points(doc, "MEASURED_PROFILE"), measured).max() < 1e-5
    # Registration recovers the deviation to ~2e-6 mm; x200 that is 4e-4 mm.
    far = _distance_to(_layer_points(doc, "DEVIATION_EXAGGERATED"), exaggerated).max()
    assert far < 2e-3  # a sign or scale error would miss by > 0.5 mm


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


#: DXF ``$INSUNITS`` code -> mm per drawing unit, from the DXF reference (written
#: here by hand: exact definitions of the inch, foot, yard, mil and microinch).
INSUNITS_BY_HAND = {
    0: 1.0,  # unitless: read as mm
    1: 25.4,  # inch
    2: 12 * 25.4,  # foot
    3: 5280 * 12 * 25.4,  # mile
    4: 1.0,  # millimetre
    5: 10.0,  # centimetre
    6: 1000.0,  # metre
    7: 1e6,  # kilometre
    8: 25.4 / 1e6,  # microinch
    9: 25.4 / 1000,  # mil (thousandth of an inch)
    10: 3 * 12 * 25.4,  # yard
    11: 1e-7,  # angstrom
    12: 1e-6,  # nanometre
    13: 1e-3,  # micrometre
    14: 100.0,  # decimetre
    15: 1e4,  # decametre
    16: 1e5,  # hectometre
    17: 1e12,  # gigametre
}
#: Codes a measurement can come in: they must be read, not refused.
INSUNITS_READ = {0, 1, 2, 4, 5, 6, 8, 9, 10, 13, 14}


@pytest.mark.parametrize("code", sorted(INSUNITS_BY_HAND))
def test_measured_dxf_scaled_by_every_insunits_code(tmp_path, code):
    """The same numbers under each ``$INSUNITS``: read as those numbers times the unit in mm,
    or refused in one ProfileError naming the code (never read in another unit)."""
    t = np.arange(12) * 2 * np.pi / 12
    numbers = np.stack([(3 + np.cos(3 * t)) * np.sin(t), (3 + np.cos(3 * t)) * np.cos(t)], 1)
    doc = ezdxf.new("R2018")
    doc.header["$INSUNITS"] = code
    doc.modelspace().add_lwpolyline(
        numbers.tolist(), close=True, dxfattribs={"layer": "MEASURED_PROFILE"}
    )
    doc.saveas(tmp_path / "m.dxf")
    if code not in INSUNITS_READ:
        try:
            got = read_measured_points(tmp_path / "m.dxf")
        except ProfileError as exc:
            assert f"$INSUNITS = {code} " in str(exc)
            return
    else:
        got = read_measured_points(tmp_path / "m.dxf")
    np.testing.assert_allclose(got, numbers * INSUNITS_BY_HAND[code], rtol=1e-12, atol=0)
