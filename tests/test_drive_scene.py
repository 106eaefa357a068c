"""The drive's scene keys and files: ``[solver] model``, ``contact_law``, ``[errors.row_b]``,
``[bearings.eccentric(_b)]``, and what ``forces`` and ``datasheet`` write under them."""

import csv
import json
import math

import numpy as np
import pytest

from corr_cad.errors import SceneError
from corr_cad.geometry.deviations import ManufacturingErrors as ME
from corr_cad.run.scene.scene import parse_scene

BEARING = {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}


def _drive(**extra):
    data = {"solver": {"model": "drive"}, "load": {"input_torque": 1.1e5}}
    for k, v in extra.items():
        data.setdefault(k, {}).update(v)
    return data


@pytest.mark.parametrize(
    "data,pattern",
    [
        (
            _drive(solver={"load_share": 0.55}),
            r'^\[solver\] load_share = 0.55: has no meaning under model = "drive"',
        ),
        (
            {"bearings": {"eccentric": BEARING}},
            r'^\[bearings.eccentric\] acts under \[solver\] model = "drive" only',
        ),
        (_drive(bearings={"needle": BEARING}), r"unknown table 'needle' in \[bearings\]"),
        (
            _drive(bearings={"eccentric": {"needles": 40}}),
            r"\[bearings.eccentric\] needle_diameter is not set",
        ),
        (
            _drive(bearings={"eccentric": {**BEARING, "needles": 2}}),
            r"\[bearings.eccentric\] needles = 2: allowed range is \[3, 1000\]",
        ),
        (
            _drive(bearings={"eccentric_b": BEARING}),
            r"\[bearings.eccentric_b\] overrides \[bearings.eccentric\] for cam B",
        ),
        (
            _drive(errors={"row_b": {"roller_radius_errors": [0.0]}}),
            r"\[errors.row_b\] roller_radius_errors has 1 values",
        ),
        (
            _drive(errors={"row_b": {"slot_angle_errors_deg": [0.0] * 26}}),
            r"unknown key 'slot_angle_errors_deg' in \[errors.row_b\]",
        ),
        (_drive(solver={"variants": ["eq3_printed"]}), r"\[solver\] variants = \['eq3_printed'\]"),
        ({"solver": {"model": "both"}}, r"\[solver\] model = 'both': must be one of paper, drive"),
        (
            {
                "solver": {"contact_law": "palmgren"},
                "export": {"formats": ["montecarlo"]},
                "tolerances": {"cam_radius": {"normal": 0.001}},
                "load": {"input_torque": 1e5},
            },
            r"formats lists montecarlo or allocation, which solve the paper's contact law only",
        ),
        (
            {"tolerances": {"slot_clearance": {"normal": 0.001}}},
            r"\[tolerances\] slot_clearance: the slots' fit acts under",
        ),
        ({"design": {"slot_clearance": 0.01}}, r"\[design\] slot_clearance = 0.01: acts under"),
    ],
)
def test_refusals_are_one_line(data, pattern):
    with pytest.raises(SceneError, match=pattern) as info:
        parse_scene(data)
    assert "\n" not in str(info.value)


def test_sections_reach_the_scene_and_cam_b_overrides_its_bearing():
    scene = parse_scene(
        _drive(
            errors={"cam_phase_error_deg": 0.01, "row_b": {"roller_radius_error": -0.001}},
            bearings={"eccentric": BEARING, "eccentric_b": {"diametral_clearance": 0.004}},
        )
    )
    assert scene.solver.drive and scene.solver.contact_model == "nonlinear"
    assert scene.errors_b.roller_radius_error == -0.001
    assert scene.bearing.needles == scene.bearing_b.needles == 40
    assert scene.bearing.diametral_clearance == 0.0
    assert scene.bearing_b.diametral_clearance == 0.004
    assert scene.source["bearings.eccentric_b"] == {"diametral_clearance": 0.004}
    plain = parse_scene({"load": {"input_torque": 1.1e5}})
    assert plain.errors_b is None and plain.bearing is None
    assert not any(s.startswith(("bearings", "errors.row_b")) for s in plain.source)


def test_drive_run_writes_both_rows_and_the_share(tmp_path):
    from corr_cad.run.cli import main

    scene = tmp_path / "drive.toml"
    scene.write_text(
        "[export]\nformats = ['forces', 'datasheet', 'report']\n[load]\ninput_torque = 1.1e5\n"
        "[solver]\nmodel = 'drive'\ncontact_law = 'palmgren'\npositions = 52\n"
        "[errors]\ncam_phase_error_deg = 0.005\n[errors.row_b]\nroller_radius_error = -0.0005\n"
        "[bearings.eccentric]\nneedles = 40\nneedle_diameter = 6.0\nneedle_length = 12.0\n"
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 4\n"
    )
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet", "--workers", "1"]) == 0
    with open(out / "forces.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 * 52 * 26
    assert {r["row"] for r in rows} == {"A", "B"}
    for r in rows[:3]:
        assert float(r["needle_load_max"]) > 0 and float(r["bearing_load"]) > 0
    share = np.array([float(r["row_share"]) for r in rows if r["roller"] == "1"])
    np.testing.assert_allclose(share[:52] + share[52:], 1.0, rtol=1e-12)
    summary = json.loads((out / "forces_summary.json").read_text())
    assert summary["model"] == "drive" and summary["contact_law"] == "palmgren"
    assert set(summary["rows"]) == {"A", "B"}
    assert summary["rows"]["B"]["needle_load_max_N"]["max"] > 0
    # Row B's rollers are small and cam B leads: row A carries more than half.
    assert 0.5 < summary["row_a_share"]["min"] <= summary["row_a_share"]["max"] < 1.0
    sheet = json.loads((out / "datasheet.json").read_text())
    assert sheet["model"] == "drive" and sheet["bearing"]["needles"] == 40
    assert 0.5 < sheet["row_a_share"]["mean"] < 1.0
    with open(out / "windup.csv") as f:
        header = f.readline().strip().split(",")
    assert header == ["output_torque_Nm", "output_angle_deg", "windup_arcmin", "row_a_share"]
    report = (out / "report.html").read_text()
    assert "share of M0 on row A" in report and "palmgren" in report
    assert "both rows&#39; contacts and the cams&#39; eccentric bearings" in report or (
        "both rows' contacts and the cams' eccentric bearings" in report
    )
    # The customer's page names the model that made its figures.
    page = (out / "datasheet.html").read_text()
    assert "Palmgren steel line contacts" in page
    assert "both rows solved together, cams on 40-needle bearings" in page
    assert "one row carrying" not in page


def test_prototype_rigidity_table_of_the_physics_page():
    from corr_cad import GearDesign
    from corr_cad.mechanics.crank.bearing import EccentricBearing
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet

    spec = DatasheetSpec(
        rated_torque=2.86e6, positions_per_mesh=2, transmission_error_positions_per_turn=4
    )
    needles = EccentricBearing(40, 6.0, 12.0)
    table = {
        ("nonlinear", None): 26000,
        ("nonlinear", needles): 7300,
        ("palmgren", None): 5300,
        ("palmgren", needles): 3500,
    }
    for (law, bearing), quoted in table.items():
        drive = {"errors_b": None, "bearing": bearing, "bearing_b": None}
        ds = datasheet(GearDesign(), spec, contact_model=law, drive=drive)
        rig = ds.figures()["torsional_rigidity_Nm_per_arcmin"]["contact_only"]["min"]
        assert rig == pytest.approx(quoted, rel=0.02)
        np.testing.assert_allclose(ds.row_a_share, 0.5, atol=1e-12)


def test_drive_monte_carlo_draws_row_b_on_its_own_stream():
    """Row A's draws are the seed's own (as for one row); row B's come from [seed, 1]; each
    sample equals a direct drive solve of the errors rebuilt from the draws by hand."""
    from corr_cad import GearDesign
    from corr_cad.mechanics.drive.drive import DriveSolver
    from corr_cad.mechanics.row.solver import cycle_angles
    from corr_cad.tolerance.montecarlo import Distribution, draw_samples, monte_carlo
    from corr_cad.tolerance.montecarlo_drive import drive_metrics

    tol = {
        "roller_radius": Distribution("normal", 0.001),
        "slot_clearance": Distribution("uniform", 0.002),
    }
    only_a = draw_samples({"roller_radius": tol["roller_radius"]}, 3, 7, 26)
    both = draw_samples(tol, 3, 7, 26)
    np.testing.assert_array_equal(only_a["roller_radius"], both["roller_radius"])
    design = GearDesign()
    mc = monte_carlo(design, 1.1e5, tol, 3, 7, 13, drive={"contact_model": "palmgren"})
    assert mc.success and set(mc.magnitudes) == {
        "roller_radius",
        "slot_clearance",
        "roller_radius_row_b",
    }
    # Row B's generator, in the fixed order of the kinds (cam_radius, eccentricity,
    # cam_phase, roller_radius), a normal and a uniform draw of each.
    rng_b = np.random.default_rng([7, 1])
    for _ in range(3):
        rng_b.standard_normal(3)
        rng_b.uniform(-1.0, 1.0, 3)
    b_normal = rng_b.standard_normal((3, 26))
    for k in range(3):
        from corr_cad.geometry.deviations import ManufacturingErrors as ME

        ea = ME(
            roller_radius_errors=tuple(0.001 * both["roller_radius"][k]),
            slot_clearance=0.002 * float(both["slot_clearance"][k]),
        )
        eb = ME(roller_radius_errors=tuple(0.001 * b_normal[k]))
        solver = DriveSolver(
            design, cycle_angles(13), errors=ea, errors_b=eb, contact_model="palmgren"
        )
        m = drive_metrics(solver.result(1.1e5), solver.free_interval(), 26.0)
        for name, v in m.items():
            assert mc.metrics[name][k] == pytest.approx(v, rel=1e-12, abs=1e-12)


def test_drive_monte_carlo_streams_its_rows_to_the_sink_in_order():
    """montecarlo.csv is written by the sink: the drive's chunks go to it in order, each
    with its own magnitudes (row B's too), and together they are the result's table."""
    from corr_cad import GearDesign
    from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

    tol = {"roller_radius": Distribution("uniform", 0.001)}
    got = []
    mc = monte_carlo(
        GearDesign(), 1.1e5, tol, 5, 3, 13, chunk=2, drive={"contact_model": "palmgren"},
        sink=lambda lo, mags, metrics: got.append((lo, mags, metrics)),
    )  # fmt: skip
    assert [lo for lo, _, _ in got] == [0, 2, 4]
    for key, table in ((1, mc.magnitudes), (2, mc.metrics)):
        assert set(got[0][key]) == set(table)
        for name, v in table.items():
            np.testing.assert_array_equal(np.concatenate([g[key][name] for g in got]), v)
    assert set(mc.magnitudes) == {"roller_radius", "roller_radius_row_b"}


def test_sweeps_run_on_the_drive_and_under_palmgren():
    from corr_cad import GearDesign
    from corr_cad.mechanics.drive.drive import solve_drive
    from corr_cad.mechanics.row.solver import solve_forces
    from corr_cad.tolerance.sweeps import sweep_point

    d = GearDesign()
    rec = sweep_point(d, "roller_radius_error", -0.001, 1.1e5, 26, 0.55, {"model": "drive"})
    row_a = solve_drive(d, 1.1e5, positions=26, errors=ME(roller_radius_error=-0.001)).rows[0]
    assert rec["F_j_peak"] == pytest.approx(row_a.summary()["F_j_peak"], rel=1e-12)
    rec = sweep_point(
        d,
        "roller_radius_error",
        0.0,
        1.1e5,
        26,
        0.55,
        {"model": "paper", "contact_model": "palmgren"},
    )
    one = solve_forces(d, 1.1e5, positions=26, load_share=0.55, contact_model="palmgren")
    assert rec["F_j_peak"] == pytest.approx(one.summary()["F_j_peak"], rel=1e-12)


def test_selective_assembly_on_the_drive_fits_both_rows():
    """Rollers 3 um small in both rows (the ring as made); the class fitted to both rows.
    +7 um presses both rows (binds); +3 um closes the gap exactly (no binding); -2 um
    leaves play, more than +3 um."""
    from corr_cad import GearDesign
    from corr_cad.mechanics.datasheet import DatasheetSpec
    from corr_cad.tolerance.assembly import selective_assembly

    spec = DatasheetSpec(
        rated_torque=2.86e6, positions_per_mesh=2, transmission_error_positions_per_turn=4
    )
    out = selective_assembly(
        GearDesign(),
        spec,
        ME(roller_radius_error=-0.003),
        [-2.0, 3.0, 7.0],
        5.0,
        contact_model="palmgren",
        drive={"errors_b": None, "bearing": None, "bearing_b": None},
    )
    rows = {r["class_um"]: r for r in out["classes"]}
    assert rows[7.0]["binds"] and not rows[3.0]["binds"] and not rows[-2.0]["binds"]
    assert rows[-2.0]["backlash_arcmin"]["max"] > rows[3.0]["backlash_arcmin"]["max"]
    assert out["chosen_class_um"] == 3.0


def test_allocation_runs_on_the_drive():
    """A tighter roller tolerance is allocated for a tighter pressure limit, on the drive."""
    from corr_cad import GearDesign
    from corr_cad.tolerance.allocation import allocate
    from corr_cad.tolerance.checks import Checks

    kw = {"samples": 8, "positions": 13, "drive": {"contact_model": "palmgren"}}
    loose = allocate(
        GearDesign(), 1.1e5, {}, Checks(max_contact_pressure=2000.0), "roller_radius", **kw
    )
    tight = allocate(
        GearDesign(), 1.1e5, {}, Checks(max_contact_pressure=1600.0), "roller_radius", **kw
    )
    assert 0 < tight["tolerance"] < loose["tolerance"]


def test_paper_rigidity_check_says_it_is_one_row_upper_bound(tmp_path, capsys):
    from corr_cad.run.cli import main

    scene = tmp_path / "paper.toml"
    scene.write_text(
        "[export]\nformats = ['forces']\n[load]\ninput_torque = 1.1e5\n[solver]\n"
        "positions = 52\n[checks]\nmin_torsional_rigidity_Nm_per_arcmin = 1000.0\n"
        "[datasheet]\npositions_per_mesh = 2\ntransmission_error_positions_per_turn = 4\n"
    )
    assert main(["run", str(scene), "--out", str(tmp_path / "out"), "--workers", "1"]) == 0
    text = capsys.readouterr()
    lines = [ln for ln in (text.out + text.err).splitlines() if "one row only" in ln]
    assert len(lines) == 1 and "upper bound" in lines[0]


ALLOC_SCENE = """[design]
tooth_count = 9
cam_radius = 45.0
roller_radius = 4.0
eccentricity = 1.5
[export]
formats = ["allocation"]
[load]
input_torque = 2.0e4
[solver]
positions = 20
model = "drive"
contact_law = "palmgren"
[tolerances]
roller_radius = { uniform = 0.001 }
cam_radius = { uniform = 0.002 }
[montecarlo]
positions = 20
allocation_samples = 8
seed = 1
[checks]
max_contact_pressure = 4000.0
[modification]
equidistant_mm = 0.002
[errors]
roller_radius_error = -0.002
[errors.row_b]
roller_radius_error = -0.001
[bearings.eccentric]
needles = 30
needle_diameter = 4.0
needle_length = 10.0
"""


def test_allocation_on_the_drive_through_the_cli_settles_preloaded_samples(tmp_path, capsys):
    """Samples of this allocation preload the rows (needles without clearance) with a loaded
    roller at zero arm: the drive's free rotation solves them at M0 = 0 and must settle,
    without an overflow warning."""
    from corr_cad.run.cli import main

    scene = tmp_path / "alloc.toml"
    scene.write_text(ALLOC_SCENE)
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--workers", "1"]) == 0
    err = capsys.readouterr().err
    assert "RuntimeWarning" not in err and "error:" not in err
    alloc = json.loads((out / "allocation.json").read_text())
    assert alloc["rows"] and all(r["tolerance"] > 0 for r in alloc["rows"])
    assert scene.read_text() == ALLOC_SCENE


def test_the_datasheet_estimate_follows_row_b_s_span_and_the_drive_s_cost():
    """Row B's own rollers make the drive's datasheet span a tooth pitch: the estimate counts
    those positions, at the drive's cost per cell (DRIVE_CELLS times the row's)."""
    from corr_cad.run.budget.costs import DRIVE_CELLS, ESTIMATORS
    from corr_cad.run.budget.costs_datasheet import datasheet_size as _datasheet_size

    rr = [0.001 * math.sin(k) for k in range(26)]
    base = {
        "export": {"formats": ["datasheet"]},
        "load": {"input_torque": 1.1e5},
        "datasheet": {"positions_per_mesh": 2},
    }
    paper = parse_scene(base)
    drive = parse_scene(
        {**base, "solver": {"model": "drive"}, "errors.row_b": {"roller_radius_errors": rr}}
    )
    assert _datasheet_size(paper)[0] == 2
    assert _datasheet_size(drive)[0] == 2 * 26  # a tooth pitch of z + 1 mesh periods
    t_paper = ESTIMATORS["datasheet"](paper, None).seconds - 0.05
    t_drive = ESTIMATORS["datasheet"](drive, None).seconds - 0.05
    assert t_drive > DRIVE_CELLS * 26 * t_paper * 0.9


def _ring_points(deviation):
    """Ring points from the closed form written out (roller-centre locus plus r along its
    outward normal, less the deviation: + = material added), 6000 a revolution."""
    z, e, L, r = 25, 3.5, 143.0, 8.0
    t = np.linspace(0, 2 * np.pi, 6000, endpoint=False)
    psi = z * t
    W = np.sqrt(L * L - (e * np.sin(psi)) ** 2)
    s = e * np.cos(psi) + W
    ds = z * (-e * np.sin(psi) - e * e * np.sin(psi) * np.cos(psi) / W)
    tx, ty = ds * np.sin(t) + s * np.cos(t), ds * np.cos(t) - s * np.sin(t)
    n = np.stack([ty, -tx], axis=1) / np.hypot(tx, ty)[:, None]
    n *= np.sign(n[:, 0] * np.sin(t) + n[:, 1] * np.cos(t))[:, None]
    P = s[:, None] * np.stack([np.sin(t), np.cos(t)], axis=1)
    return P + (r - deviation(t))[:, None] * n


def _flat(d, prefix=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict) and k not in ("ring", "units", "positions"):
            out.update(_flat(v, f"{prefix}{k}."))
        elif isinstance(v, (int, float)) and not isinstance(v, bool) and k != "positions_solved":
            out[prefix + k] = v
    return out


@pytest.mark.slow
def test_row_b_measured_ring_gives_the_datasheet_of_its_deviation(tmp_path):
    """Through the CLI: ring B measured equal to the nominal contour gives the nominal drive's
    datasheet (over a revolution, where the nominal one spans a mesh period); measured with a
    third harmonic of 2 um, the datasheet of the same harmonic
    given as profile_deviation_harmonics. Tolerance: the registered deviation is sampled
    at the 6000 points of a revolution and interpolated between them, an error of at most
    A (k dt)^2 / 8 = 2.5e-9 mm (A = 2 um, k = 3, dt = 2 pi / 6000), 1.2e-6 of A; each
    figure moves by at most that fraction of the largest change the whole deviation makes
    in its family (min, mean, max), here within 100 times (the registration's own fit of
    centre and rotation, and rigidities that are quotients of windup differences)."""
    import subprocess
    import sys

    for name, dev in (("nominal", lambda t: 0 * t), ("h3", lambda t: 0.002 * np.cos(3 * t))):
        pts = _ring_points(dev)
        (tmp_path / f"{name}.csv").write_text(
            "x,y\n" + "\n".join(f"{x:.12f},{y:.12f}" for x, y in pts) + "\n"
        )
    base = (
        '[export]\nformats = ["datasheet"]\n[load]\ninput_torque = 1.1e5\n'
        '[solver]\nmodel = "drive"\n'
        "[datasheet]\npositions_per_mesh = 1\ntransmission_error_positions_per_turn = 4\n"
    )
    forces = base.replace('["datasheet"]', '["datasheet", "forces"]').replace(
        'model = "drive"\n', 'model = "drive"\ncrank_angles_deg = [0.0, 7.0, 33.0]\n'
    )
    scenes = {
        "plain": base,
        "mnom": base + '[errors.row_b]\nmeasured_profile = "nominal.csv"\n',
        "mh3": forces + '[errors.row_b]\nmeasured_profile = "h3.csv"\n',
        "hh3": forces + "[errors.row_b]\nprofile_deviation_harmonics = [[3, 0.002, 0]]\n",
    }
    sheets = {}
    for name, text in scenes.items():
        (tmp_path / f"{name}.toml").write_text(text)
        r = subprocess.run(
            [sys.executable, "-m", "corr_cad", "run", f"{name}.toml", "--out", name, "--quiet"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
        )
        assert r.returncode == 0, r.stderr
        sheets[name] = json.loads((tmp_path / name / "datasheet.json").read_text())
    ring_b = sheets["mh3"]["ring"]["ring_b"]
    assert ring_b["profile"] == "measured" and ring_b["file"] == "h3.csv"
    assert "ring_b" not in sheets["hh3"]["ring"]
    f = {k: _flat(v) for k, v in sheets.items()}
    assert f["plain"].keys() == f["mnom"].keys() == f["mh3"].keys()
    for k, v in f["plain"].items():
        assert f["mnom"][k] == pytest.approx(v, rel=1e-6, abs=1e-9), k
    family = {}
    for k, v in f["plain"].items():
        fam = k.rsplit(".", 1)[0]
        family[fam] = max(family.get(fam, 0.0), abs(f["hh3"][k] - v))
    bound = 100 * 0.002 * (3 * 2 * math.pi / 6000) ** 2 / 8 / 0.002
    for k, v in f["hh3"].items():
        effect = family[k.rsplit(".", 1)[0]]
        assert abs(f["mh3"][k] - v) <= bound * effect + 1e-12 * abs(v), (k, f["mh3"][k], v)
    assert f["hh3"]["transmission_error_arcsec.catalogue"] > 0.1  # the deviation shows
    # The forces (row B's ring in the scene's errors): a contact's stiffness is about
    # 2e6 N/mm at 2 kN (1.2 um), so the 2.5e-9 mm of discretization moves a force by
    # about 5e-3 N; within 100 times that.
    tables = []
    for k in ("mh3", "hh3"):
        with open(tmp_path / k / "forces.csv") as fh:
            rows = list(csv.reader(fh))
        tables.append(rows)
    assert tables[0][0] == tables[1][0] and len(tables[0]) == len(tables[1])

    def number(v):
        try:
            return math.isfinite(float(v))
        except ValueError:
            return False

    numeric = [j for j, v in enumerate(tables[1][1]) if number(v)]
    meas, harm = (np.array([[float(r[j]) for j in numeric] for r in t[1:]]) for t in tables)
    np.testing.assert_allclose(meas, harm, atol=0.5)
    assert [r[j] for r in tables[0] for j in range(len(r)) if j not in numeric] == [
        r[j] for r in tables[1] for j in range(len(r)) if j not in numeric
    ]
    assert np.ptp(harm, axis=0).max() > 100.0  # the forces vary


def test_row_b_measured_ring_is_estimated_and_refused_beside_harmonics():
    """The measured_profile stage's estimate reads and registers ring B as it does ring A
    (the same file size costs the same, without measured_profile.dxf's picture); ring B
    measured and given as harmonics at once is refused in one line."""
    from corr_cad.run.budget.costs import ESTIMATORS, Env

    base = {"export": {"formats": ["forces"]}, "load": {"input_torque": 1.1e5}}
    drive = {**base, "solver": {"model": "drive"}}
    a = parse_scene({**drive, "errors": {"measured_profile": "a.csv"}})
    both = parse_scene(
        {
            **drive,
            "errors": {"measured_profile": "a.csv"},
            "errors.row_b": {"measured_profile": "b.csv"},
        }
    )
    assert both.measured_profile_b.name == "b.csv"
    env = Env(measured_bytes=1_600_000, measured_b_bytes=1_600_000)
    one, two = ESTIMATORS["measured_profile"](a, env), ESTIMATORS["measured_profile"](both, env)
    assert two.seconds == pytest.approx(2 * one.seconds)
    assert two.keeps == pytest.approx(2 * one.keeps)
    assert "[errors.row_b] measured_profile" in two.knobs
    with pytest.raises(SceneError, match=r"^\[errors.row_b\] measured_profile and profile_dev"):
        parse_scene(
            {
                **drive,
                "errors.row_b": {
                    "measured_profile": "b.csv",
                    "profile_deviation_harmonics": [[3, 0.002, 0]],
                },
            }
        )


@pytest.mark.parametrize(
    "content,message",
    [
        (None, "[errors.row_b] measured_profile: measured profile 'b.csv' does not exist"),
        (
            "x,y\n0,1\n1,0\n",
            "[errors.row_b] measured_profile: b.csv: 2 points are too few; need at least 500 "
            "(20 per tooth)",
        ),
    ],
)
def test_a_bad_row_b_measured_ring_is_refused_as_row_a_s(tmp_path, content, message):
    """Ring B's file goes through row A's reader and checks: one line, exit 2."""
    import subprocess
    import sys

    if content is not None:
        (tmp_path / "b.csv").write_text(content)
    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        '[solver]\nmodel = "drive"\ncrank_angles_deg = [0.0]\n'
        '[errors.row_b]\nmeasured_profile = "b.csv"\n'
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2
    assert r.stderr.splitlines() == [f"corr-cad: error: {message}"]
