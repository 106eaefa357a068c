"""``[crankshaft]`` and ``[bearings.crank]`` as a user runs them: the CLI in a subprocess,
the console, ``datasheet.json``'s ``compliance_budget``, ``compliance.png`` and the page;
refusals in one line; a scene without the sections writes the bytes it wrote before."""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from corr_cad.errors import SceneError
from corr_cad.run.scene.scene import parse_scene

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"

DRIVE = """
[export]
formats = ['forces', 'datasheet']
[load]
input_torque = 1.1e5
[solver]
model = 'drive'
contact_law = 'palmgren'
positions = 52
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
diametral_clearance = 0.005
[datasheet]
positions_per_mesh = 4
transmission_error_positions_per_turn = 4
"""


def run(tmp_path, text, name="scene", root=ROOT):
    scene = tmp_path / f"{name}.toml"
    scene.write_text(text)
    out = tmp_path / f"out_{name}"
    env = {**os.environ, "PYTHONPATH": str(root)}
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--workers", "1"],
        capture_output=True,
        text=True,
        env=env,
    )
    return r, out


def _drive(**extra):
    data = {"solver": {"model": "drive"}, "load": {"input_torque": 1.1e5}}
    for k, v in extra.items():
        data.setdefault(k, {}).update(v)
    return data


@pytest.mark.slow
def test_crank_scene_reports_its_compliances_and_budget(tmp_path):
    text = DRIVE.replace("'datasheet']", "'datasheet', 'report']")
    text += "[bearings.crank]\ntype = 'tapered_pair'\nclearance = -0.002\n[life]\n"
    r, out = run(tmp_path, text)
    assert r.returncode == 0, r.stderr
    # The console: what was derived, which compliances are in the figure, the budget.
    assert "drive: derived from the design (not in the scene): " in r.stdout
    assert "[crankshaft] shaft_diameter" in r.stdout
    assert "rigidity, model" in r.stdout and "not in it: ring body (rigid)" in r.stdout
    assert "compliance budget   windup" in r.stdout
    assert "support bearing 1   radial load up to" in r.stdout
    sheet = json.loads((out / "datasheet.json").read_text())
    assert sheet["crank"]["crankshaft"]["shaft_diameter_mm"] == 60.0
    assert sheet["crank"]["support_bearings"][0]["type"] == "tapered_pair"
    assert "frame (rigid)" in sheet["compliances"]["not_in_figure"]
    b = sheet["compliance_budget"]
    comps = b["components"]
    total = sum(c["windup_arcmin"] for c in comps.values())
    assert total == pytest.approx(b["windup_arcmin"], rel=1e-6)
    branch = sum(c["rigidity_range_arcmin"] for c in comps.values())
    assert branch == pytest.approx(b["rigidity_range_windup_arcmin"], rel=1e-6)
    assert b["sum_relative_residual"] < 1e-9
    for c in comps.values():
        assert c["share"] == pytest.approx(c["windup_arcmin"] / b["windup_arcmin"], rel=1e-12)
    assert sum(c["share"] for c in comps.values()) == pytest.approx(1.0, rel=1e-6)
    for name in ("contact_cam", "contact_ring", "contact_slot", "needle_bearings"):
        assert comps[name]["windup_arcmin"] > 0 and comps[name]["in_model"]
    for name in ("crankshaft_bending", "crankshaft_shear", "crankshaft_torsion"):
        assert comps[name]["windup_arcmin"] > 0
    assert comps["support_bearings"]["windup_arcmin"] > 0
    for name in ("ring_body", "frame", "first_stage"):
        assert not comps[name]["in_model"] and comps[name]["windup_arcmin"] == 0.0
    sup = b["support_bearings"]
    assert len(sup) == 2 and all(s["L10_h"] > 0 for s in sup)
    # The rigidity is the model's: the budget's range over its windup.
    rig = sheet["torsional_rigidity_Nm_per_arcmin"]["contact_only"]["mean"]
    lo, hi = b["rigidity_range_Nm"]
    assert rig == pytest.approx((hi - lo) / b["rigidity_range_windup_arcmin"], rel=1e-9)
    assert (out / "compliance.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (out / "datasheet.html").read_text()
    assert 'data-key="compliance_budget.components.support_bearings.windup_arcmin"' in page
    assert "compliance.png" in page
    report = (out / "report.html").read_text()
    assert "torsional rigidity, model" in report and "Compliance budget" in report


@pytest.mark.parametrize(
    "data,pattern",
    [
        (
            {"crankshaft": {"shaft_diameter": 60.0}},
            r'^\[crankshaft\] acts under \[solver\] model = "drive" only',
        ),
        (
            _drive(crankshaft={"shaft_diameter": -1.0}),
            r"^\[crankshaft\] shaft_diameter = -1",
        ),
        (
            _drive(bearings={"crank": {"type": "ball"}}),
            r"^\[bearings.crank\] type = 'ball'",
        ),
        (
            _drive(bearings={"crank": {"contact_angle_deg": 15.0}}),
            r"^\[bearings.crank\] contact_angle_deg = 15: a cylindrical roller bearing",
        ),
        (
            _drive(crankshaft={"support_positions": [50.0, -20.0]}),
            r"^\[crankshaft\] support_positions = \[50.0, -20.0\]: the second must lie beyond",
        ),
    ],
)
def test_refusals_are_one_line(data, pattern):
    with pytest.raises(SceneError, match=pattern) as err:
        parse_scene(data)
    assert "\n" not in str(err.value)


def test_either_section_puts_the_crank_in_and_neither_keeps_it_rigid():
    assert parse_scene(_drive()).crank is None
    a = parse_scene(_drive(crankshaft={"shaft_diameter": 50.0})).crank
    assert a.shaft.shaft_diameter == 50.0 and a.bearing.type == "cylindrical"
    assert a.shaft_source == "scene, the rest derived"
    assert a.bearing_source == "derived from the design"
    needles = {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}
    b = parse_scene(_drive(bearings={"crank": {"type": "rigid"}, "eccentric": needles})).crank
    # The prototype's defaults: a 60 mm shaft in an 82.4 mm eccentric (the bore less two
    # needles), the eccentrics at the rows' mid-planes; without needles the cam sits on
    # the eccentric (94.4 mm) and the shaft is 0.8 (94.4 - 7) = 69 mm.
    assert b.bearing is None and b.shaft.shaft_diameter == 60.0
    assert b.shaft.eccentric_diameter == pytest.approx(82.4)
    assert b.shaft.eccentric_positions == (6.0, 26.0)
    assert b.shaft.support_positions == (-27.0, 59.0)
    assert a.shaft.eccentric_diameter == pytest.approx(94.4)


def test_cli_refusal_exit_2_and_one_line(tmp_path):
    r, out = run(tmp_path, DRIVE + "[crankshaft]\nshaft_diameter = -5.0\n")
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "[crankshaft] shaft_diameter = -5" in r.stderr
    assert not out.exists()


@pytest.mark.parametrize("section", ["crankshaft", "bearings.crank"])
def test_elastic_bodies_with_the_crank_load_together(section):
    """[solver] bodies = "elastic" beside a crank section: the scene loads with both (the
    drive couples them: tests/test_crank_bodies.py)."""
    extra = {"crankshaft": {"shaft_diameter": 50.0}} if section == "crankshaft" else {}
    data = _drive(solver={"bodies": "elastic"}, **extra)
    if not extra:
        data["bearings"] = {"crank": {}}
    s = parse_scene(data)
    assert s.crank is not None and s.solver.bodies == "elastic"


def _hashes(out: Path) -> dict:
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(out.iterdir())
        if p.name != "manifest.json"
    }


def scene_text(name: str) -> str:
    """The byte test's scenes: the drive with needles, and the paper's row."""
    if name == "drive":
        return DRIVE
    text = DRIVE.replace("model = 'drive'", "model = 'paper'").split("[bearings.eccentric]")[0]
    return text + "[datasheet]\npositions_per_mesh = 4\ntransmission_error_positions_per_turn = 4\n"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["drive", "paper"])
def test_without_the_sections_the_files_are_the_bytes_they_were(tmp_path, name):
    """The drive and the paper's row without [crankshaft] / [bearings.crank]: every file
    the hashes recorded before the sections existed (``tests/data/crank_bytes_golden.json``,
    written by the commit before them; written again, with a CHANGELOG line, when a
    deliberate change of the datasheet's or the forces' files lands)."""
    text = scene_text(name)
    r, out = run(tmp_path, text, name)
    assert r.returncode == 0, r.stderr
    golden = json.loads((DATA / "crank_bytes_golden.json").read_text())[name]
    assert _hashes(out) == golden


@pytest.mark.parametrize(
    "section", [{"crankshaft": {"shaft_diameter": 60.0}}, {"bearings": {"crank": {}}}]
)
def test_all_formats_keep_the_studies_on_samples_with_the_crank(section):
    """The studies on samples solve on the crankshaft too: ``all`` keeps them."""
    data = _drive(export={"formats": ["all"]}, tolerances={"cam_radius": {"normal": 0.001}})
    data.update(section)
    scene = parse_scene(data)
    assert scene.crank is not None
    for f in ("montecarlo", "sweeps", "datasheet", "forces"):
        assert f in scene.formats, f


@pytest.mark.slow
def test_support_bearings_modified_life_beside_the_needles(tmp_path):
    """[lubrication] with [bearings.crank]: each support bearing's ISO 281 L10m at the
    crank speed, by hand from the datasheet's own geometry and load, on console and page."""
    import math

    text = DRIVE + "[bearings.crank]\ntype = 'tapered_pair'\nclearance = -0.002\n[life]\n"
    text += "[friction]\npositions_per_mesh = 2\nefficiency_torques = [0.5, 1.0]\n"
    text += "efficiency_speeds_rpm = [500]\n[lubrication]\niso_vg = 68\n"
    r, out = run(tmp_path, text)
    assert r.returncode == 0, r.stderr
    sheet = json.loads((out / "datasheet.json").read_text())
    ml = sheet["modified_life"]
    assert {"bearing_row1", "support_bearing_1", "support_bearing_2"} <= set(ml)
    for i in (1, 2):
        b = sheet["crank"]["support_bearings"][i - 1]
        row = sheet["compliance_budget"]["support_bearings"][i - 1]
        m = ml[f"support_bearing_{i}"]
        n = 15.0 * 26  # [life] rated_speed_rpm 15 at the output, z + 1 = 26 crank turns
        assert m["speed_rpm"] == pytest.approx(n)
        d, dm, ca = b["roller_diameter_mm"], b["pitch_diameter_mm"], math.cos(math.radians(15))
        c0 = 44.0 * (1 - d * ca / dm) * 2 * 18 * b["roller_length_mm"] * d * ca
        nu1 = 45000.0 * n**-0.83 * dm**-0.5
        kappa = 68.0 / nu1
        x = 0.5 * c0 / 8.2 / row["equivalent_load_N"]
        base = 1.0 - (1.5859 - 1.2348 / kappa**0.071739) ** 0.83 * x**0.4
        a = 50.0 if base <= 0 else min(0.1 * base**-9.185, 50.0)
        assert m["static_rating_N"] == pytest.approx(c0, rel=1e-12)
        assert m["kappa"] == pytest.approx(kappa, rel=1e-12)
        assert m["a_ISO"] == pytest.approx(a, rel=1e-12)
        assert m["L10m_h"] == pytest.approx(a * row["L10_h"], rel=1e-12)
        assert f"life L10m support_bearing_{i} " in r.stdout
        assert f"Modified life L10m, support bearing {i}" in (out / "datasheet.html").read_text()
    assert "support bearings ([bearings.crank])" in ml["definition"]


@pytest.mark.parametrize(
    "crank,words",
    [
        ({"type": "cylindrical", "clearance": 0.01}, "diametral clearance 10 um)"),
        ({"type": "cylindrical", "clearance": -0.004}, "diametral clearance -4 um: a preload)"),
        ({"type": "tapered_pair", "clearance": -0.002}, "axial end play of the pair -2 um: a "),
        ({"type": "tapered_pair"}, "axial end play of the pair 0 um)"),
    ],
)
def test_console_crank_line_says_the_support_bearings_fit(crank, words):
    """The console's crank line says the support bearings' clearance, and a preload as one."""
    from corr_cad.run.console import crank_lines

    scene = parse_scene(_drive(bearings={"crank": crank}))
    line = crank_lines(scene.crank.as_dict())[0]
    assert words in line, line
    assert "e-0" not in line and "e+0" not in line
