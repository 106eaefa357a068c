"""The whole drive: crank moment from the pinion torque, mass and inertia against the STL,
first-stage loads by hand, the first stage's [checks]."""

from __future__ import annotations

import json
import math
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from corr_cad.errors import SceneError
from corr_cad.run.scene.scene import parse_scene

ROOT = Path(__file__).resolve().parents[1]
FS = dict(
    pinion_teeth=18,
    wheel_teeth=36,
    crank_gear_teeth=90,
    module=1.5,
    face_width=15.0,
    shift_pinion=0.5,
    shift_crank_gear=0.5,
    backlash_allowance=0.03,
)


def test_crank_moment_from_the_pinion_torque():
    s = parse_scene({"first_stage": FS, "load": {"input_torque_Nm": 22.0}})
    assert s.load.input_torque == pytest.approx(22.0 * 1000 * 90 / 18, rel=1e-15)


@pytest.mark.parametrize(
    "data,message",
    [
        ({"load": {"input_torque_Nm": 22.0}}, "[load] input_torque_Nm needs a [first_stage]"),
        ({"first_stage": FS, "load": {"input_torque_Nm": 22.0, "input_torque": 1e5}}, "not both"),
        (
            {"first_stage": FS, "checks": {"max_first_stage_contact_MPa": 900.0}},
            "[checks] max_first_stage_contact_MPa needs a torque",
        ),
    ],
)
def test_load_refusals(data, message):
    with pytest.raises(SceneError) as exc:
        parse_scene(data)
    assert message in str(exc.value)


def _stl_triangles(path: Path):
    data = path.read_bytes()
    (n,) = struct.unpack("<I", data[80:84])
    tris = []
    for k in range(n):
        v = struct.unpack("<12f", data[84 + 50 * k : 84 + 50 * k + 48])
        tris.append((v[3:6], v[6:9], v[9:12]))
    return tris


def _volume_and_jz(tris, shift=(0.0, 0.0)):
    """Divergence theorem on origin tetrahedra: volume and the integral of x^2 + y^2."""
    vol = jz = 0.0
    for a, b, c in tris:
        a = (a[0] + shift[0], a[1] + shift[1], a[2])
        b = (b[0] + shift[0], b[1] + shift[1], b[2])
        c = (c[0] + shift[0], c[1] + shift[1], c[2])
        det = (
            a[0] * (b[1] * c[2] - b[2] * c[1])
            - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
        )
        vol += det / 6.0
        # integral of x^2 over the tetrahedron (0, a, b, c): det/60 (sum of squares + pairs)
        for i in (0, 1):
            sq = a[i] ** 2 + b[i] ** 2 + c[i] ** 2 + a[i] * b[i] + a[i] * c[i] + b[i] * c[i]
            jz += det / 60.0 * sq
    return vol, jz


@pytest.fixture(scope="module")
def stl_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("drive")
    text = (ROOT / "templates" / "compound.toml").read_text()
    text = text.replace(text[text.index("formats = [") :].split("\n")[0], 'formats = ["stl"]')
    (out / "s.toml").write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(out / "s.toml"), "--out", str(out / "o")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return out / "o", json.loads((out / "o" / "manifest.json").read_text())


@pytest.mark.parametrize(
    "stem,part,shift",
    [
        ("pinion", "pinion", (0, 0)),
        ("wheel", "wheel", (0, 0)),
        ("crank_gear", "crank_gear", (0, 0)),
        ("crankshaft", "crankshaft", (0, 0)),
        ("crank_bearing", "crank_bearing", (0, 0)),
        ("disk_cam", "disk_cam", (0, 3.5)),  # about the crank axis: the bore at (0, -e)
        ("teeth_frame", "teeth_frame", (0, 0)),
    ],
)
def test_mass_and_inertia_against_the_stl(stl_run, stem, part, shift):
    out, manifest = stl_run
    vol, jz = _volume_and_jz(_stl_triangles(out / f"{stem}.stl"), shift)
    rho = 7.85e-6  # kg/mm^3
    got = manifest["drive"]["parts"][part]
    # the STL's circles are inscribed within the chord tolerance: its volume is short by at
    # most the bound the run states (tolerance x boundary length x thickness)
    bound = manifest["solids"][stem]["volume_error_bound_mm3"]
    r_max = max(
        math.hypot(v[0] + shift[0], v[1] + shift[1])
        for t in _stl_triangles(out / f"{stem}.stl")
        for v in t
    )
    assert abs(got["mass_kg"] - rho * vol) <= rho * bound + 1e-7 * got["mass_kg"]
    assert got["mass_kg"] == pytest.approx(rho * vol, rel=2e-4)
    assert abs(got["inertia_kg_m2"] - rho * jz * 1e-6) <= (
        rho * bound * r_max**2 * 1e-6 + 1e-7 * got["inertia_kg_m2"]
    )


def test_total_ratio_and_input_inertia_by_hand(stl_run):
    _, m = stl_run
    d = m["drive"]
    assert d["total_ratio"] == -130.0
    p = d["parts"]
    by_hand = (
        p["pinion"]["inertia_kg_m2"]
        + 3 * (p["wheel"]["inertia_kg_m2"] + p["wheel_bearing"]["inertia_kg_m2"]) * (18 / 36) ** 2
        + (
            p["crank_gear"]["inertia_kg_m2"]
            + p["crankshaft"]["inertia_kg_m2"]
            + 2 * p["crank_bearing"]["inertia_kg_m2"]
            + 2 * p["disk_cam"]["inertia_kg_m2"]
        )
        / 25
        + (52 * p["roller"]["inertia_kg_m2"] + 3 * p["teeth_frame"]["inertia_kg_m2"]) / 130**2
    )
    assert d["input_inertia_kg_m2"] == pytest.approx(by_hand, rel=1e-12)
    # a roller: m (r^2/2 + L^2) with L = Rj + r = 143 mm
    r = p["roller"]
    assert r["inertia_kg_m2"] == pytest.approx(r["mass_kg"] * (32 + 143**2) * 1e-6, rel=1e-12)


def test_first_stage_loads_by_hand(stl_run):
    _, m = stl_run
    ld = m["drive"]["first_stage_loads"]
    fs = m["first_stage"]
    aw = math.radians(fs["meshes"]["pinion_wheel"]["working_pressure_angle_deg"])
    rb = 0.5 * 1.5 * 18 * math.cos(math.radians(20))
    rw = rb / math.cos(aw)
    ft = 22000.0 / (3 * rw)
    w = ld["per_wheel"]
    assert w["pinion_mesh_tangential_N"] == pytest.approx(ft, rel=1e-12)
    assert w["pinion_mesh_radial_N"] == pytest.approx(ft * math.tan(aw), rel=1e-12)
    # equal working angles: the radial parts cancel, the tangential parts add
    assert w["bearing_load_N"] == pytest.approx(2 * ft, rel=1e-9)
    y = 0.154 - 0.912 / 18
    assert ld["root_bending_MPa"]["pinion"] == pytest.approx(ft / (15 * math.pi * 1.5 * y))
    e_prime = 2.06e5 / (2 * (1 - 0.3**2))
    rho1, rho2 = rw * math.sin(aw), 2 * rw * math.sin(aw)
    hertz = math.sqrt(ft / (15 * math.cos(aw)) * e_prime * (1 / rho1 + 1 / rho2) / math.pi)
    assert ld["contact_stress_MPa"]["pinion_wheel"] == pytest.approx(hertz, rel=1e-12)
    assert m["checks"]["max_first_stage_contact_MPa"]["passed"]
    assert m["checks"]["max_first_stage_contact_MPa"]["value"] == pytest.approx(hertz, rel=1e-12)


def test_a_failing_first_stage_check_exits_1(tmp_path):
    text = (ROOT / "templates" / "compound.toml").read_text()
    text = text.replace(text[text.index("formats = [") :].split("\n")[0], 'formats = ["png"]')
    text = text.replace("max_first_stage_bending_MPa = 300.0", "max_first_stage_bending_MPa = 50.0")
    (tmp_path / "s.toml").write_text(text)
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "corr_cad",
            "run",
            str(tmp_path / "s.toml"),
            "--out",
            str(tmp_path / "o"),
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 1
    assert "max_first_stage_bending_MPa (value 73.1, limit 50)" in r.stderr


def test_first_stage_backlash_at_the_crank_by_hand():
    """Equal working angles: each mesh's play is 2 j r_w / r (the thinning j on both gears);
    the wheel passes the pinion mesh's play on unchanged, so the crank turns (j1 + j2) / r_wc."""
    from corr_cad.geometry.first_stage import FirstStage, first_stage_geometry

    g = first_stage_geometry(FirstStage(**FS))
    a = g.centre_distance
    rw_over_r = a / (1.5 * 54 / 2)
    j = 2 * 0.03 * rw_over_r
    r_wc = 67.5 * rw_over_r  # the crank gear's working pitch radius
    assert g.crank_backlash_rad == pytest.approx(2 * j / r_wc, rel=1e-9)


@pytest.fixture(scope="module")
def sheet_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("sheet")
    text = (ROOT / "templates" / "compound.toml").read_text()
    text = text.replace(
        text[text.index("formats = [") :].split("\n")[0], 'formats = ["datasheet", "report"]'
    )
    (out / "s.toml").write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(out / "s.toml"), "--out", str(out / "o")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return out / "o"


def test_datasheet_has_the_whole_drive(sheet_run):
    d = json.loads((sheet_run / "datasheet.json").read_text())
    m = json.loads((sheet_run / "manifest.json").read_text())
    assert d["total_ratio"] == -130.0
    assert d["mass_kg"] == m["drive"]["mass_kg"] and d["mass_kg"] > 0
    assert d["input_inertia_kg_m2"] == m["drive"]["input_inertia_kg_m2"]
    fs = d["first_stage"]
    assert fs["backlash_arcmin"] == pytest.approx(fs["backlash_at_crank_arcmin"] / 26, rel=1e-15)
    # the lost motion adds the meshes' windup at +-3 % T_R: 2 (0.03 T_R) / K1, K1 the first
    # stage's rigidity at the output
    k1 = fs["torsional_rigidity_at_output_Nm_per_arcmin"]
    windup = 2 * 0.03 * d["rated_torque_Nm"] / k1
    assert fs["lost_motion_arcmin"] == pytest.approx(fs["backlash_arcmin"] + windup, rel=1e-12)
    assert fs["backlash_at_crank_arcmin"] == pytest.approx(
        m["first_stage"]["crank_backlash_arcmin"], rel=1e-15
    )
    assert fs["transmission_error_arcsec"] == 0.0
    # docs/datasheet.md: 0.235 arcmin, thirty times the second stage's lost motion
    assert fs["backlash_arcmin"] == pytest.approx(0.235, abs=5e-4)
    assert fs["lost_motion_arcmin"] == pytest.approx(0.2355, abs=5e-5)
    assert fs["lost_motion_arcmin"] > 30 * d["lost_motion_arcmin"]["max"]


def test_report_shows_the_whole_drive(sheet_run):
    html = (sheet_run / "report.html").read_text()
    assert 'id="drive"' in html
    for row in (
        "total ratio i = i1 (z + 1)",
        "inertia at the input",
        "contact stress, largest",
        "first-stage backlash at the crank",
        "18 / 36 / 90",
    ):
        assert row in html, row
    # the page names the whole drive, not the second stage alone
    assert "the whole drive: a first\ngear stage and the second stage" in html


def test_datasheet_html_shows_the_whole_drive(sheet_run):
    """The customer's page gives the total ratio, the first stage's backlash at the
    output, the mass and the inertia at the input: datasheet.json's exact values."""
    import re

    d = json.loads((sheet_run / "datasheet.json").read_text())
    html = (sheet_run / "datasheet.html").read_text()
    cells = dict(re.findall(r'data-key="([^"]+)" data-value="([^"]+)"', html))
    assert float(cells["total_ratio"]) == d["total_ratio"] == -130.0
    assert float(cells["first_stage.lost_motion_arcmin"]) == d["first_stage"]["lost_motion_arcmin"]
    assert float(cells["mass_kg"]) == d["mass_kg"]
    assert float(cells["input_inertia_kg_m2"]) == d["input_inertia_kg_m2"]
    assert "total ratio -130" in html
