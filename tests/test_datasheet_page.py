"""The customer page of the whole drive as it will be built: ``datasheet.html`` carries
every number of ``datasheet.json`` (efficiency, starting and backdriving torque, life and
rated torque from life, the whole drive's backlash and lost motion, the first stage, the
Monte Carlo's as-built figures), every number in its sentences is one of the file's, and
a short life is said on the page and in the console. The real CLI in a subprocess."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.page_check import Page, check_cells, check_every_number_is_a_cell, check_sentence_numbers

ROOT = Path(__file__).resolve().parents[1]
FORMULAS = ("z + 1", "1 - losses", "3.84e-5 Q^0.9 / l^0.8", "0 -> +T_R -> 0 -> -T_R -> 0")
#: templates/compound.toml's second stage and first stage (the Drive and First stage rows)
DESIGN = (25, 26, 135, 8, 3.5, 12)

DRIVE = """[first_stage]
pinion_teeth = 18
wheel_teeth = 36
crank_gear_teeth = 90
module = 1.5
shift_pinion = 0.5
shift_crank_gear = 0.5
face_width = 15.0
backlash_allowance = 0.03
[load]
input_torque_Nm = 22.0
[export]
formats = ['datasheet', 'interference', 'report']
interference_method = 'exact'
interference_positions = 360
[solver]
model = "drive"
positions = 52
[datasheet]
positions_per_mesh = 2
transmission_error_positions_per_turn = 6
[friction]
positions_per_mesh = 2
[life]
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
diametral_clearance = 0.002
"""


def _run(tmp: Path, text: str):
    (tmp / "s.toml").write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(tmp / "s.toml"), "--out", str(tmp / "o")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert r.returncode == 0, r.stderr
    out = tmp / "o"
    sheet = json.loads((out / "datasheet.json").read_text())
    import html

    return out, sheet, html.unescape((out / "datasheet.html").read_text()), r


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("page"), DRIVE)


@pytest.mark.slow
def test_the_drive_page_holds_every_number_of_datasheet_json(drive):
    out, sheet, html, _ = drive
    page = Page(html)
    keys = check_cells(page, sheet)
    check_every_number_is_a_cell(page, sheet)
    # the figures a buyer reads first, in the catalogue table with their conventions
    for key in (
        "whole_drive.backlash_arcmin.value",
        "whole_drive.lost_motion_arcmin.value",
        "efficiency_forward.min",
        "efficiency_backdriving.min",
        "starting_torque_Nm.max",
        "backdriving_torque_Nm.max",
        "life_h.system",
        "rated_torque_from_life_Nm.value",
        "first_stage.lost_motion_arcmin",
    ):
        assert key in keys, key
    n = check_sentence_numbers(page, sheet, DESIGN, FORMULAS)
    assert n > 30
    for words in (
        "Backlash, whole drive",
        "Lost motion, second stage",
        "Efficiency, backdriving",
        "Rated torque from life",
        "at 2,860 N*m and 15 rpm at the output",
    ):
        assert words in html, words


@pytest.mark.slow
def test_the_whole_drives_play_adds_the_first_stage_and_is_labelled(drive):
    out, sheet, html, r = drive
    w, fs = sheet["whole_drive"], sheet["first_stage"]
    back, lost = w["backlash_arcmin"]["value"], w["lost_motion_arcmin"]["value"]
    assert back == pytest.approx(sheet["backlash_arcmin"]["max"] + fs["backlash_arcmin"], rel=1e-12)
    # the first stage's lost motion: its backlash and its meshes' windup at +-band T_R
    assert fs["lost_motion_arcmin"] > fs["backlash_arcmin"]
    assert lost == pytest.approx(
        sheet["lost_motion_arcmin"]["max"] + fs["lost_motion_arcmin"], rel=1e-12
    )
    # the first stage's 0.235 arcmin of backlash dwarfs the second stage's play
    assert fs["backlash_arcmin"] == pytest.approx(0.235, abs=5e-4)
    assert lost > 2 * sheet["lost_motion_arcmin"]["max"]
    # docs/datasheet.md: second stage 0.0756 and 0.120, whole drive 0.311 and 0.356 arcmin
    assert sheet["backlash_arcmin"]["max"] == pytest.approx(0.0756, abs=5e-5)
    assert sheet["lost_motion_arcmin"]["max"] == pytest.approx(0.120, abs=5e-4)
    assert back == pytest.approx(0.311, abs=5e-4)
    assert lost == pytest.approx(0.356, abs=5e-4)
    from corr_cad.figure_text import figure

    line = next(ln for ln in r.stdout.splitlines() if ln.startswith("  whole drive"))
    assert f"backlash {figure(back)} arcmin" in line
    assert f"lost motion {figure(lost)} arcmin" in line
    assert "(second stage, crank locked)" in r.stdout
    report = (out / "report.html").read_text()
    assert report.index("backlash, whole drive (pinion held)") < report.index(
        "backlash, second stage (crank locked)"
    )
    from corr_cad.export.report_tables import fmt

    for key in ("backlash_arcmin", "lost_motion_arcmin"):
        assert f'<td class="num">{fmt(w[key]["value"])}</td>' in report


@pytest.mark.slow
def test_a_short_life_is_said_with_the_rated_torque_from_life(drive):
    out, sheet, html, r = drive
    life, rt = sheet["life_h"], sheet["rated_torque_from_life_Nm"]
    assert life["system"] < rt["rated_life_h"] == 6000.0
    assert rt["value"] < sheet["rated_torque_Nm"]
    from corr_cad.export.datasheet_html import catalogue_number as n

    warned = [ln for ln in r.stderr.splitlines() + r.stdout.splitlines() if "short of" in ln]
    assert warned and f"the rated torque from life is {n(rt['value'])} N*m" in warned[0]
    assert "Short life" in html and f"{n(life['system'])} h, short of the rated 6,000 h" in html


@pytest.mark.slow
def test_a_scene_without_errors_is_nominal_and_says_so(drive):
    """The drive's slot fit of 0 is no error: the page says nominal parts, and that its
    figures are a perfect drive's."""
    _, sheet, html, _ = drive
    assert sheet["ring"]["errors_applied"] == [] and sheet["ring"]["other_parts"] == "nominal"
    assert "none (nominal parts)" in html and "slot_clearance" not in html
    assert "a perfect drive's" in html
    rig = sheet["torsional_rigidity_Nm_per_arcmin"]
    assert rig["headline"] == rig["contact_only"]["min"] == rig["catalogue"]
    assert rig["headline_basis"].startswith("the contacts only")


@pytest.mark.slow
def test_row_a_share_by_direction(drive):
    _, sheet, html, _ = drive
    both, by = sheet["row_a_share"], sheet["row_a_share_by_direction"]
    assert both["min"] == min(by["positive"]["min"], by["negative"]["min"])
    assert both["max"] == max(by["positive"]["max"], by["negative"]["max"])
    assert "of the crank moment at +T_R" in html and "at -T_R" in html
    from corr_cad.figure_text import figure

    line = next(ln for ln in drive[3].stdout.splitlines() if ln.startswith("  row A share"))
    p, n = by["positive"], by["negative"]
    assert f"{figure(p['min'], 4)}-{figure(p['max'], 4)} at +T_R" in line
    assert f"{figure(n['min'], 4)}-{figure(n['max'], 4)} at -T_R" in line


MC = """[load]
input_torque = 1.1e5
[export]
formats = ['montecarlo', 'datasheet']
[errors]
roller_radius_error = -0.002
[datasheet]
positions_per_mesh = 2
transmission_error_positions_per_turn = 6
[tolerances]
roller_radius = { uniform = 0.001 }
[montecarlo]
samples = 20
positions = 26
datasheet_positions_per_mesh = 2
seed = 1
"""


@pytest.mark.slow
@pytest.mark.parametrize("first", ["montecarlo", "datasheet"])
def test_the_page_gives_the_as_built_figures_beside_the_nominal(tmp_path, first):
    """Either stage first: datasheet.json's as_built is montecarlo_summary.json's
    percentiles, and the page shows them beside the nominal figures."""
    text = (
        MC
        if first == "montecarlo"
        else MC.replace("['montecarlo', 'datasheet']", "['datasheet', 'montecarlo']")
    )
    out, sheet, html, _ = _run(tmp_path, text)
    mc = json.loads((out / "montecarlo_summary.json").read_text())
    ab = sheet["as_built"]
    assert ab["samples"] == 20
    for m in (
        "lost_motion_arcmin",
        "transmission_error_arcsec",
        "torsional_rigidity_Nm_per_arcmin",
    ):
        assert ab[m] == mc["percentiles"][m]
    page = Page(html)
    keys = check_cells(page, sheet)
    check_every_number_is_a_cell(page, sheet)
    assert {
        "as_built.lost_motion_arcmin.p95",
        "as_built.torsional_rigidity_Nm_per_arcmin.p5",
    } <= keys
    check_sentence_numbers(page, sheet, DESIGN + (0.55,), FORMULAS)
    assert 'id="as-built"' in html


@pytest.mark.slow
def test_the_drives_clearance_agrees_with_the_datasheets_backlash(drive):
    """clearance.png's and manifest.json's statement of the drive's free rotation is the
    datasheet's backlash, and each cam's free play is half its bearing's clearance."""
    out, sheet, _, r = drive
    c = json.loads((out / "manifest.json").read_text())["clearance"]
    assert c["bearing_free_play_mm"] == {"A": 0.001, "B": 0.001}
    assert c["drive_backlash_arcmin"]["value"] == sheet["backlash_arcmin"]["max"]
    assert set(c["rows"]) == {"A", "B"}
    from corr_cad.figure_text import figure

    line = next(ln for ln in r.stdout.splitlines() if "eccentric bearings (not in" in ln)
    assert "each cam moves 1 um" in line
    assert f"{figure(sheet['backlash_arcmin']['max'])} arcmin at the output" in line


def test_a_sheet_with_every_kind_of_figure_renders_every_number_fast(tmp_path):
    """Without a run: a datasheet of the prototype (the mechanics API) with friction, life,
    whole-drive and as-built figures added, and one more figure the page has never heard of
    (``future_figure``): every number is a cell, every number in a sentence is the file's,
    the short-life note and the as-built table are there."""
    import base64

    from corr_cad import GearDesign
    from corr_cad.export.datasheet_html import render_datasheet_html
    from corr_cad.export.datasheet_sheet import as_built
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet

    d = GearDesign()
    spec = DatasheetSpec(
        rated_torque=2.86e6, positions_per_mesh=2, transmission_error_positions_per_turn=4
    )
    sheet = {
        "rated_torque_source": "(z + 1) * [load] input_torque",
        "ring": {"profile": "nominal", "errors_applied": [], "other_parts": "nominal"},
        "conventions": {"windup": "output rotation under output torque T"},
        "load_share": 0.55,
        "total_ratio": -130.0,
        "mass_kg": 29.78,
        "input_inertia_kg_m2": 0.00442,
        "first_stage": {
            "backlash_arcmin": 0.2351,
            "lost_motion_arcmin": 0.2356,
            "backlash_at_crank_arcmin": 6.112,
        },
        **datasheet(d, spec).figures(),
    }
    stats = {"min": 0.87, "mean": 0.874, "max": 0.88}
    sheet.update(
        efficiency_forward=stats,
        efficiency_backdriving={**stats, "self_locking": False},
        starting_torque_Nm={"min": 1.0, "mean": 1.5, "max": 2.0},
        backdriving_torque_Nm={"min": 26.0, "mean": 39.0, "max": 52.0},
        hysteresis_width_at_rated_arcmin={"min": 0.01, "mean": 0.012, "max": 0.015},
        life_h={
            "at_torque_Nm": 2860.0,
            "at_output_speed_rpm": 15.0,
            "bearing_row1": 3546.0,
            "cam_row1": 5.3e6,
            "ring_row1": None,
            "system": 1912.0,
            "definition": "L10 (90 % reliability)",
        },
        rated_torque_from_life_Nm={
            "value": 2030.0,
            "rated_life_h": 6000.0,
            "rated_speed_rpm": 15.0,
            "bearing_rating_N": 65223.0,
            "bearing_rating_source": "ISO 281",
        },
        future_figure={"value": 12.5, "per_row": [1.25, 2.5]},
    )
    from corr_cad.run.stages.stages_first_stage import whole_drive_values

    second = {k: sheet[k]["max"] for k in ("backlash_arcmin", "lost_motion_arcmin")}
    shares = {"backlash_arcmin": 0.2351, "lost_motion_arcmin": 0.2356}
    sheet["whole_drive"] = whole_drive_values(second, shares)
    pct = {"p5": 0.3, "p50": 0.38, "p95": 0.47, "p99": 0.49}
    metrics = (
        "lost_motion_arcmin",
        "transmission_error_arcsec",
        "torsional_rigidity_Nm_per_arcmin",
    )
    mc = {"samples": 40, "percentiles": dict.fromkeys(metrics, pct)}
    sheet.update(as_built(mc))
    png = base64.b64decode(
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAQAAAC1HAwCAAAAC0lEQVR42mNkYAAAAAYAAjCB0C8AAAAASUVORK5CYII="
    )
    for name in ("hysteresis.png", "transmission_error.png"):
        (tmp_path / name).write_bytes(png)
    import html as h

    text = h.unescape(render_datasheet_html(sheet, d, tmp_path, "t", "", "0"))
    page = Page(text)
    keys = check_cells(page, sheet)
    check_every_number_is_a_cell(page, sheet)
    assert {"future_figure.value", "future_figure.per_row.1", "life_h.system"} <= keys
    assert "life_h.ring_row1" not in keys  # None: no number
    check_sentence_numbers(page, sheet, DESIGN + (0.55,), FORMULAS)
    assert "Short life: the system L10 at the rated torque 2,860 N*m is 1,912 h" in text
    assert "the rated torque from life is 2,030 N*m" in text
    assert 'id="as-built"' in text and "Backlash, whole drive" in text
    assert "a perfect drive's" in text
