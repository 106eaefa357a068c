"""The profile modification under ``[solver] model = "drive"``: its design (backlash, binding,
force candidates on the drive), its shop files and ``modified.toml``, through the real CLI.

References: the paper's row for the limiting case (identical rows, rigid cams, no
scatter: the drive's free rotation is the row's, z + 1 even), and hand values: a cam on a
bearing with diametral clearance ``Pd`` may shift ``Pd / 2`` either way, which turns the
crank by ``Pd / (2 e)`` each way, so the conjugate drive's free output rotation is
``Pd / (e (z + 1))``; a ring made uniformly small (negative equidistant) presses every
roller, and no crank rotation or cam shift of ``Pd / 2`` frees them all.
"""

import json
import math
import subprocess
import sys
import tomllib

import numpy as np
import pytest

from corr_cad.run.scene.scene import parse_scene

DESIGN = """
[export]
formats = ["modification"]
[load]
input_torque = 1.1e5
[solver]
model = "{model}"
{extra}
[tolerances]
{tolerances}
[modification.design]
target_backlash_arcmin = {target}
family = "{family}"
equidistant_range_mm = [{eq_lo}, 0.03]
shift_range_mm = [-0.01, 0.02]
steps = {steps}
samples = 20
positions = 16
force_candidates = 2
"""

BEARING = "[bearings.eccentric]\nneedles = 40\nneedle_diameter = 6.0\nneedle_length = 12.0\n"
#: A scatter of zero: the design needs [tolerances], the limiting case no scatter.
NO_SCATTER = "cam_radius = { normal = 0.0 }"


def _cli(cwd, *args):
    """``corr-cad run ARGS`` in a subprocess, in ``cwd``."""
    cmd = [sys.executable, "-m", "corr_cad", "run", *args]
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)


def _run(folder, scene, *args):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "s.toml").write_text(scene)
    return _cli(folder, "s.toml", "--out", "out", "--quiet", *args), folder / "out"


def _scene(model="drive", extra="", tolerances=NO_SCATTER, target=5.0, family="equidistant",
           eq_lo=0.0, steps=4):  # fmt: skip
    return DESIGN.format(
        model=model, extra=extra, tolerances=tolerances, target=target, family=family,
        eq_lo=eq_lo, steps=steps,
    )  # fmt: skip


def _backlash(out):
    res = json.loads((out / "modification.json").read_text())
    return res, [c["backlash_arcmin"]["p95"]["value"] for c in res["candidates"]]


@pytest.mark.slow
def test_drive_design_of_identical_rigid_rows_has_the_paper_row_s_backlash(tmp_path):
    """Identical rows, rigid cams, no scatter, z + 1 = 26 even: row B at phi + pi is row A
    turned by half a revolution, both rows' free intervals coincide, and the drive's
    backlash of every candidate is the paper row's free rotation."""
    # equidistant+shift: the shift's clearance varies along the flank, so each row must
    # take it at its own roll angles (an equidistant one is the same everywhere)
    kw = {"family": "equidistant+shift", "steps": 3}
    rp, paper = _run(tmp_path / "paper", _scene(model="paper", **kw))
    rd, drive = _run(tmp_path / "drive", _scene(**kw))
    assert rp.returncode == 0 and rd.returncode == 0, rp.stderr + rd.stderr
    res_p, bp = _backlash(paper)
    res_d, bd = _backlash(drive)
    assert min(bp) < 0.5 < max(bp)  # the grid spans a range of backlash
    np.testing.assert_allclose(bd, bp, rtol=1e-9, atol=1e-12)
    binds = [[c["binding_probability"]["value"] for c in r["candidates"]] for r in (res_p, res_d)]
    assert binds[0] == binds[1] and 0.0 in binds[1]
    # the force candidates come from the drive: both rows carry M0, no load share of 0.55
    solved = [c for c in res_d["candidates"] if c.get("force_solved")]
    solved_p = [c for c in res_p["candidates"] if c.get("force_solved")]
    assert solved and len(solved) == len(solved_p)
    for d, p in zip(solved, solved_p, strict=True):
        assert d["peak_pressure_MPa"]["p95"]["value"] < p["peak_pressure_MPa"]["p95"]["value"]


@pytest.mark.slow
def test_bearing_clearance_adds_pd_over_e_z1_and_a_small_ring_binds(tmp_path):
    """Hand values (module docstring): the conjugate candidate (equidistant 0) has the
    backlash Pd / (e (z + 1)); the candidates with a ring made small bind, with the cams
    fixed and with Pd / 2 of shift alike; the design picks a candidate that does not."""
    pd = 0.004
    e, z1 = 3.5, 26
    loose = BEARING + f"diametral_clearance = {pd}\n"
    r, out = _run(tmp_path / "loose", _scene(extra=loose, eq_lo=-0.01, steps=5))
    assert r.returncode == 0, r.stderr
    res, bl = _backlash(out)
    eqs = [c["equidistant_mm"] for c in res["candidates"]]
    assert eqs[0] == -0.01 and abs(eqs[1]) < 1e-15  # -0.01 to 0.03 in five steps
    hand = pd / (e * z1) * (180 * 60 / math.pi)
    assert bl[1] == pytest.approx(hand, rel=1e-6)
    assert res["candidates"][0]["binding_probability"]["value"] == 1.0
    assert all(c["binding_probability"]["value"] == 0.0 for c in res["candidates"][1:])
    assert res["chosen"]["equidistant_mm"] >= 0.0 and res["met"]
    r, rigid = _run(tmp_path / "rigid", _scene(eq_lo=-0.01, steps=5))
    res_r, bl_r = _backlash(rigid)
    assert res_r["candidates"][0]["binding_probability"]["value"] == 1.0
    assert bl_r[1] == pytest.approx(0.0, abs=1e-9)  # the conjugate drive: no free rotation
    # the cam's shift adds at least its own Pd / (e (z + 1)) to every candidate's free
    # rotation (more where the rows' clearance polygon is wider off the eccentric's axis)
    for a, b in zip(bl[1:], bl_r[1:], strict=True):
        assert a >= b + hand * (1 - 1e-6)


@pytest.mark.slow
def test_drive_design_writes_a_modified_toml_that_keeps_the_drive(tmp_path):
    """With scatter on both rows, Palmgren's law and needle bearings: the design runs on
    the drive, and modified.toml keeps model, law, row B's errors, the bearings and the
    slots' fit; run by the real CLI it writes the shop files without a warning."""
    extra = (
        'contact_law = "palmgren"\n[design]\nslot_clearance = 0.002\n'
        "[errors.row_b]\nroller_radius_error = -0.001\n" + BEARING
    )
    tol = "cam_radius = { uniform = 0.005 }\nroller_radius = { normal = 0.002 }"
    r, out = _run(
        tmp_path / "d", _scene(extra=extra, tolerances=tol, family="equidistant+shift", steps=3)
    )
    assert r.returncode == 0, r.stderr
    data = tomllib.loads((out / "modified.toml").read_text())
    assert data["solver"] == {"model": "drive", "contact_law": "palmgren"}
    assert data["design"] == {"slot_clearance": 0.002}
    assert data["errors"] == {"row_b": {"roller_radius_error": -0.001}}
    assert data["bearings"] == {
        "eccentric": {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}
    }
    assert set(data["modification"]) <= {"equidistant_mm", "shift_mm"}
    text = (out / "modified.toml").read_text().replace('"step",\n', "")  # no OCP needed
    (out / "modified.toml").write_text(text)
    r = _cli(out, "modified.toml", "--out", "../shop")
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr, r.stderr
    assert (tmp_path / "d" / "shop" / "inner_gear.dxf").is_file()
    nc = (tmp_path / "d" / "shop" / "inner_gear_edm.nc").read_text()
    assert "profile: modified" in nc


@pytest.mark.slow
def test_a_given_modification_reaches_every_file_under_the_drive(tmp_path):
    """Plain [modification] under the drive: the ring's DXF and EDM files, the clearance
    chart, the forces and the datasheet follow the modified profile; its backlash is the
    paper row's (identical rigid rows), which the manifest's clearance makes nonzero."""
    scene = (
        '[export]\nformats = ["forces", "datasheet", "dxf", "png", "edm"]\n'
        '[load]\ninput_torque = 1.1e5\n[solver]\nmodel = "{}"\npositions = 104\n'
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 4\n"
        "[modification]\nequidistant_mm = 0.01\n"
    )
    runs = {m: _run(tmp_path / m, scene.format(m)) for m in ("paper", "drive")}
    for r, _ in runs.values():
        assert r.returncode == 0, r.stderr
    (_, paper), (_, drive) = runs["paper"], runs["drive"]
    for name in ("inner_gear.dxf", "inner_gear_edm.nc", "modification.png"):
        assert (drive / name).read_bytes() == (paper / name).read_bytes(), name
    sheet = json.loads((drive / "datasheet.json").read_text())
    assert sheet["model"] == "drive" and sheet["ring"]["profile"] == "modified"
    b_p = json.loads((paper / "datasheet.json").read_text())["backlash_arcmin"]["max"]
    assert sheet["backlash_arcmin"]["max"] == pytest.approx(b_p, rel=1e-9)
    assert b_p > 0.1


def test_palmgren_on_the_paper_s_row_refuses_the_design_in_one_line():
    from corr_cad.errors import SceneError

    data = {
        "solver": {"contact_law": "palmgren"},
        "export": {"formats": ["modification"]},
        "tolerances": {"cam_radius": {"normal": 0.001}},
        "load": {"input_torque": 1e5},
        "modification": {"design": {"target_backlash_arcmin": 2.0}},
    }
    with pytest.raises(SceneError, match=r"formats lists 'modification', whose design solves"):
        parse_scene(data)
    data["solver"]["model"] = "drive"
    assert parse_scene(data).solver.drive  # the drive's design takes the law


def test_rigid_binding_in_interval_form_is_the_crossings_test():
    """For rigid cams the drive's binding (each row's free interval of its gaps less
    BINDING_EPS_MM, intersected) is chain_interference's test (the largest crossing of a
    rising and a falling gap line over both rows) at every position, bound or not."""
    from corr_cad import GearDesign
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.mechanics.row.solver_geometry import cycle_angles
    from corr_cad.tolerance.modification_design import (
        BINDING_EPS_MM,
        DriveGapMetrics,
        chain_interference,
    )
    from corr_cad.tolerance.montecarlo import Distribution

    tol = {
        "roller_radius": Distribution("normal", 0.003),
        "cam_radius": Distribution("normal", 0.003),
    }
    gaps = DriveGapMetrics(
        GearDesign(), tol, 12, 3, cycle_angles(9), ManufacturingErrors(), {}, math.pi
    )
    geo = gaps.solver.geo_joined
    seen = []
    for shift in (-0.1, -0.03, -0.012, -0.004, 0.004):  # from all free to all bound
        g = geo.gap + shift
        got = gaps._binds(gaps.solver, type(geo)(**{**geo.__dict__, "gap": g}))
        want = chain_interference(g, geo.advance, geo.loadable) > BINDING_EPS_MM
        assert np.array_equal(got, want)
        seen.append(want.mean())
    assert seen[0] == 0.0 and seen[-1] == 1.0 and any(0 < v < 1 for v in seen), seen


def test_transmission_error_objective_is_the_drive_s_datasheet():
    """objective = "transmission_error" on the drive: each force-solved candidate's nominal
    transmission error is that of the drive's datasheet of the modified rings (row B's own
    rollers modified too), not the paper row's."""
    from corr_cad import GearDesign
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.geometry.modification import (
        Modification,
        modification_gap,
        modified_profile,
        with_modification,
    )
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
    from corr_cad.tolerance.modification_design import design_modification
    from corr_cad.tolerance.montecarlo import Distribution

    d = GearDesign()
    spec = DatasheetSpec(
        rated_torque=26 * 1.1e5, positions_per_mesh=2, transmission_error_positions_per_turn=4
    )
    eb = ManufacturingErrors(roller_radius_error=-0.001)
    needles = EccentricBearing(40, 6.0, 12.0)
    drive = {"errors_b": eb, "bearing": needles, "bearing_b": None, "contact_model": "palmgren"}
    res = design_modification(
        d, {"cam_radius": Distribution("normal", 0.0)}, family="equidistant",
        objective="transmission_error", target_backlash_arcmin=5.0, max_binding_probability=0.5,
        crank_moment=1.1e5, equidistant_mm=(0.01, 0.02, 2), shift_mm=(0.0, 0.0, 1), samples=10,
        positions=8, force_candidates=2, datasheet_spec=spec, drive=drive,
    )  # fmt: skip
    solved = [c for c in res["candidates"] if c.get("force_solved")]
    assert len(solved) == 2 and res["chosen"] in solved
    for c in solved:
        gap = modification_gap(d, modified_profile(d, Modification(c["equidistant_mm"])))
        kw = {"errors": with_modification(ManufacturingErrors(), gap), "contact_model": "palmgren"}
        rows = {"errors_b": with_modification(eb, gap), "bearing": needles, "bearing_b": None}
        sheet = datasheet(d, spec, **kw, drive=rows)
        want = max(sheet.transmission_error_peak_to_peak().values())
        assert c["transmission_error_arcsec_nominal"] == pytest.approx(want, rel=1e-12)
        paper = datasheet(d, spec, errors=kw["errors"])
        te_paper = max(paper.transmission_error_peak_to_peak().values())
        assert te_paper != pytest.approx(want, rel=1e-3)


@pytest.mark.parametrize("model", ["paper", "drive"])
def test_errors_take_effect_in_the_design(model):
    """The design's samples start from the scene's [errors] (each row's, the frame's slots,
    cam B's phase), so none of them is called without effect with formats = modification."""
    data = {
        "solver": {"model": model},
        "export": {"formats": ["modification"]},
        "load": {"input_torque": 1.1e5},
        "tolerances": {"roller_radius": {"normal": 0.001}},
        "errors": {"roller_radius_error": -0.001, "cam_phase_error_deg": 0.002},
        "modification": {"design": {"target_backlash_arcmin": 2.0}},
    }
    assert not [w for w in parse_scene(data).warnings if w.startswith("[errors]")]
