"""Per-tooth inspection report and the design-family fit (issue 12).

Measured profiles are synthesised here from the closed form (roller centre
``s = e cos psi + sqrt(L^2 - e^2 sin^2 psi)``, ``psi = z t``, working profile
= outer offset by ``r``), written as CSV into a folder with other files and
run through the CLI.
"""

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

Z, E, RJ, R = 25, 3.5, 135.0, 8.0
L = RJ + R
PITCH = 2 * math.pi / Z
AS = math.radians(1 / 3600)  # one arcsec in rad
TURNED, TURN_AS = 5, 10.0  # tooth space 5 turned by +10 arcsec
BUMPED, BUMP_UM = 12, 4.0  # tooth space 12: a 4 um bump on one flank
M = 60  # points per tooth


def working(t, e=E, ll=L):
    psi = Z * t
    w = np.sqrt(ll * ll - (e * np.sin(psi)) ** 2)
    s = e * np.cos(psi) + w
    ds = -Z * e * np.sin(psi) * s / w
    ur = np.stack([np.sin(t), np.cos(t)], -1)
    ut = np.stack([np.cos(t), -np.sin(t)], -1)
    n = s[:, None] * ur - ds[:, None] * ut
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return s[:, None] * ur + R * n, n


def turn(p, a):
    """Turn points so that their polar angle (from +y towards +x) grows by ``a``."""
    c, s = math.cos(a), math.sin(a)
    return np.stack([p[:, 0] * c + p[:, 1] * s, -p[:, 0] * s + p[:, 1] * c], 1)


def synthetic(noise_um=0.0, turned=True, bump=True, seed=3):
    t_loc = (np.arange(M) + 0.5) / M * PITCH - PITCH / 2
    out = []
    for k in range(Z):
        t = t_loc + k * PITCH
        p, n = working(t)
        if bump and k + 1 == BUMPED:
            psi = Z * t_loc
            dev = BUMP_UM * 1e-3 * np.exp(-(((psi - math.radians(60)) / math.radians(12)) ** 2))
            p = p - dev[:, None] * n  # + = material added = into the opening
        if turned and k + 1 == TURNED:
            p = turn(p, TURN_AS * AS)
        out.append(p)
    pts = np.vstack(out)
    if noise_um:
        pts = pts + np.random.default_rng(seed).normal(0, noise_um * 1e-3, pts.shape)
    return pts


LIMITS = """
[inspection]
profile_tolerance = 0.003
position_tolerance_arcsec = 5.0
single_pitch_tolerance_arcsec = 8.0
cumulative_pitch_tolerance_arcsec = 30.0
runout_tolerance = 0.005
"""


def run(folder, pts, extra="", limits=LIMITS):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "readme.txt").write_text("other file\n")
    (folder / "cmm.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.10f},{y:.10f}" for x, y in pts) + "\n"
    )
    (folder / "s.toml").write_text(
        '[export]\nformats = ["inspection"]\n[errors]\nmeasured_profile = "cmm.csv"\n'
        + limits
        + extra
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=folder,
        capture_output=True,
        text=True,
    )
    out = folder / "out"
    with open(out / "inspection.csv") as f:
        rows = list(csv.DictReader(f))
    table = {
        k: (
            np.array([float(r[k]) for r in rows])
            if not k.endswith("pass")
            else [r[k] for r in rows]
        )
        for k in rows[0]
    }
    return r, table, json.loads((out / "inspection.json").read_text())


@pytest.fixture(scope="module")
def turned(tmp_path_factory):
    """Only tooth space 5 turned; with forces."""
    folder = tmp_path_factory.mktemp("turned")
    return run(
        folder, synthetic(bump=False), "[load]\ninput_torque = 1.1e5\n[solver]\npositions = 104\n"
    )


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    """Tooth space 5 turned and a bump on tooth space 12."""
    return run(tmp_path_factory.mktemp("clean"), synthetic())


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    return run(tmp_path_factory.mktemp("noisy"), synthetic(noise_um=0.5))


@pytest.mark.slow
def test_csv_columns_and_files(clean):
    r, table, summary = clean
    assert list(table)[:7] == [
        "tooth",
        "profile_deviation_mm",
        "form_deviation_mm",
        "position_arcsec",
        "single_pitch_arcsec",
        "cumulative_pitch_arcsec",
        "runout_mm",
    ]
    assert table["tooth"].tolist() == list(range(1, Z + 1))
    assert summary["teeth"] == Z


@pytest.mark.slow
def test_turned_tooth_position_and_pitches(turned):
    _, table, summary = turned
    pos, sp = table["position_arcsec"], table["single_pitch_arcsec"]
    k = TURNED - 1
    assert pos[k] == pytest.approx(TURN_AS, abs=1.0)
    others = np.delete(pos, k)
    assert np.abs(others).max() < 1.0
    assert sp[k] > TURN_AS - 1.0 and sp[k + 1] < -(TURN_AS - 1.0)  # opposite signs
    assert np.abs(np.delete(sp, [k, k + 1])).max() < 1.0
    # single pitches close the circle; cumulative from tooth 1 is their running sum
    assert sp.sum() == pytest.approx(0.0, abs=1e-6)  # 9 significant digits in the CSV
    np.testing.assert_allclose(table["cumulative_pitch_arcsec"], pos - pos[0], atol=1e-6)
    assert summary["cumulative_pitch_total_arcsec"] == pytest.approx(pos.max() - pos.min())


@pytest.mark.slow
def test_bump_appears_in_profile_and_form(clean):
    _, table, _ = clean
    k = BUMPED - 1
    prof, form = table["profile_deviation_mm"], table["form_deviation_mm"]
    assert prof[k] == pytest.approx(BUMP_UM * 1e-3, rel=0.1)
    assert form[k] > 0.8 * BUMP_UM * 1e-3
    assert table["profile_max_mm"][k] == pytest.approx(BUMP_UM * 1e-3, rel=0.1)  # added
    rest = np.delete(np.arange(Z), [k, TURNED - 1])
    # the others only see the whole-gear fit leaning ~TURN_AS/z towards the turned tooth
    # (0.4 arcsec = 0.3 um at the flank); their form stays clean
    assert prof[rest].max() < 0.5e-3 and form[rest].max() < 0.1e-3
    # the turned tooth has a profile deviation but (almost) no form deviation
    assert prof[TURNED - 1] > 1e-3 and form[TURNED - 1] < 0.1e-3


@pytest.mark.slow
def test_failing_limits_exit_1_naming_tooth_and_value(clean):
    r, table, summary = clean
    assert r.returncode == 1
    lim = summary["limits"]
    assert not lim["profile_tolerance"]["passed"]
    # the turned tooth leaves the band too (10 arcsec = 7 um at 147 mm, tilted by the flank)
    assert lim["profile_tolerance"]["failing_teeth"] == [TURNED, BUMPED]
    assert lim["position_tolerance_arcsec"]["failing_teeth"] == [TURNED]
    assert lim["single_pitch_tolerance_arcsec"]["failing_teeth"] == [TURNED, TURNED + 1]
    assert lim["cumulative_pitch_tolerance_arcsec"]["passed"]
    assert lim["runout_tolerance"]["passed"]
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and "inspection failed" in err[0]
    assert "profile_tolerance tooth " in err[0]
    assert (
        f"position_tolerance_arcsec tooth {TURNED} value {table['position_arcsec'][4]:.6g}"
        in (err[0])
    )


@pytest.mark.slow
def test_noise_does_not_move_verdicts(clean, noisy):
    _, _, a = clean
    _, _, b = noisy
    for key, v in a["limits"].items():
        assert b["limits"][key]["passed"] == v["passed"], key
        assert b["limits"][key].get("failing_teeth") == v.get("failing_teeth"), key


@pytest.mark.slow
def test_forces_side_by_side(turned):
    _, _, summary = turned
    f = summary["forces"]
    assert f["computed"] and f["positions"] == 104
    rows = f["roller_1_and_all"]
    for key in ("F_j_mean", "F_n_peak", "p_max", "F_n_peak_any_roller"):
        assert rows[key]["nominal"] > 0 and rows[key]["measured"] > 0
    # a turned tooth adds material on one flank: it preloads some contacts
    assert rows["F_n_peak_any_roller"]["measured"] > rows["F_n_peak_any_roller"]["nominal"]


@pytest.mark.slow
def test_predicted_play_of_the_measured_ring(clean, turned):
    """With [load], backlash, lost motion and transmission error; without, backlash only."""
    _, _, summary = turned
    p = summary["predicted"]
    assert p["ring"]["profile"] == "measured" and p["ring"]["other_parts"] == "nominal"
    m, n = p["measured"], p["nominal"]
    assert m["backlash_arcmin"]["max"] == 0.0 == n["backlash_arcmin"]["max"]  # preloaded
    # tooth 5 turned by 10 arcsec: a feature of the transmission error the nominal lacks
    te = m["transmission_error_arcsec"]
    assert (
        te["forward_peak_to_peak"]
        > 1.0
        > 1e-3
        > n["transmission_error_arcsec"]["forward_peak_to_peak"]
    )
    assert te["forward_peak_to_peak"] < 10.0 * 25 / 26  # at most the kinematic d z / (z + 1)
    # T_R = (z + 1) [load] input_torque = 26 * 1.1e5 N*mm = 2860 N*m
    assert p["rated_torque_Nm"] == pytest.approx(2860.0, rel=1e-12)
    p = clean[2]["predicted"]
    assert set(p["measured"]) == {"backlash_arcmin"} and "rated torque" in p["not_computed"]


@pytest.mark.slow
def test_design_fit_recovers_known_parameter_errors(tmp_path):
    de, dl, ph, c = 0.01, -0.02, math.radians(0.02), np.array([0.004, -0.003])
    t = (np.arange(Z * M) + 0.5) / (Z * M) * 2 * math.pi
    p, _ = working(t, E + de, L + dl)
    p = turn(p, ph) + c
    p = p + np.random.default_rng(7).normal(0, 0.5e-3, p.shape)
    _, _, summary = run(tmp_path, p)
    fit = summary["design_fit"]
    assert fit["success"]
    for val, sig, true in (
        (fit["eccentricity_error_mm"], fit["eccentricity_sigma_mm"], de),
        (fit["link_length_error_mm"], fit["link_length_sigma_mm"], dl),
        (fit["phase_deg"], fit["phase_sigma_deg"], math.degrees(ph)),
        (fit["centre_mm"][0], fit["centre_sigma_mm"][0], c[0]),
        (fit["centre_mm"][1], fit["centre_sigma_mm"][1], c[1]),
    ):
        assert abs(val - true) <= 3 * sig, (val, true, sig)
        assert sig < 0.05 * max(abs(true), 1e-3)  # and the uncertainty is meaningful
    assert fit["rms_residual_mm"] == pytest.approx(0.5e-3, rel=0.1)
    assert fit["rms_nominal_mm"] > 5 * fit["rms_residual_mm"]
    # runout is about the CMM origin (the datum axis): teeth 5 um off-centre -> 2 x 5 um
    assert summary["runout_mm"] == pytest.approx(2 * np.hypot(*c), rel=0.05)


@pytest.mark.slow
def test_profile_tolerance_is_a_half_band(tmp_path):
    """``profile_tolerance = 0.003`` is a half-band: every ``|f| <= 3 um`` passes.

    Every tooth space carries ``f = 2.5 um cos(2 psi)`` (scaled so that its
    sampled extremes are exactly -2.5 and +2.5 um: a range of 5 um, inside the
    +-3 um band, so it passes); tooth space SUNK also sits 1 um low (-3.5 to
    +1.5 um: a range of 5 um as well, but outside the band, so it fails). The
    pattern is the same on every tooth and symmetric in psi, so the whole-gear
    registration has nothing to take out but SUNK's 1/z share.
    """
    sunk = 7
    t_loc = (np.arange(M) + 0.5) / M * PITCH - PITCH / 2
    c = np.cos(2 * Z * t_loc)
    pattern = 2.5e-3 * c / np.abs(c).max()
    assert (pattern.min(), pattern.max()) == (-2.5e-3, 2.5e-3)
    out = []
    for k in range(Z):
        p, n = working(t_loc + k * PITCH)
        f = pattern - (1e-3 if k + 1 == sunk else 0.0)
        out.append(p - f[:, None] * n)  # + = material added = into the opening
    r, table, summary = run(tmp_path / "band", np.vstack(out))
    lo, hi = table["profile_min_mm"], table["profile_max_mm"]
    rest = np.arange(Z) != sunk - 1
    assert np.abs(lo[rest] + 2.5e-3).max() < 0.1e-3 and np.abs(hi[rest] - 2.5e-3).max() < 0.1e-3
    assert lo[sunk - 1] == pytest.approx(-3.5e-3, abs=0.1e-3)
    # the band rule by hand: a tooth passes when max(|min|, |max|) <= the half-band
    by_hand = [k + 1 for k in range(Z) if max(abs(lo[k]), abs(hi[k])) > 0.003]
    assert by_hand == [sunk]
    lim = summary["limits"]["profile_tolerance"]
    assert lim["failing_teeth"] == [sunk] and not lim["passed"]
    assert r.returncode == 1 and f"profile_tolerance tooth {sunk} " in r.stderr


LIMIT_OF_COLUMN = {
    "profile_pass": "profile_tolerance",
    "position_pass": "position_tolerance_arcsec",
    "single_pitch_pass": "single_pitch_tolerance_arcsec",
    "cumulative_pitch_pass": "cumulative_pitch_tolerance_arcsec",
    "runout_pass": "runout_tolerance",
}


@pytest.mark.slow
def test_pass_columns_agree_with_json_and_console(clean):
    """One verdict per tooth and limit: the CSV's pass columns, the JSON's failing teeth
    and the console lines name the same teeth."""
    r, table, summary = clean
    assert list(table)[-6:] == [*LIMIT_OF_COLUMN, "tooth_pass"]
    for col, key in LIMIT_OF_COLUMN.items():
        assert set(table[col]) <= {"true", "false"}
        failing = [k + 1 for k, v in enumerate(table[col]) if v == "false"]
        assert failing == summary["limits"][key]["failing_teeth"], key
    bad = [k + 1 for k, v in enumerate(table["tooth_pass"]) if v == "false"]
    assert bad == [TURNED, TURNED + 1, BUMPED]
    # the failure line names every failing tooth, not only the worst one
    assert "(failing teeth 5, 12)" in r.stderr and "(failing teeth 5, 6)" in r.stderr


@pytest.mark.slow
def test_cumulative_pitch_and_runout_name_their_failing_teeth(tmp_path):
    """The whole-gear limits are judged per tooth too: the teeth outside the band (as wide
    as the limit) that holds the most of them fail; the gear fails exactly when one does."""
    strict = LIMITS.replace("pitch_tolerance_arcsec = 30.0", "pitch_tolerance_arcsec = 6.0")
    pts = synthetic(bump=False) + np.array([0.004, -0.003])  # teeth 5 um off the CMM origin
    _, table, summary = run(tmp_path, pts, "", limits=strict)
    lim = summary["limits"]
    # one turned tooth: it alone leaves the band, not every tooth it spans with
    assert lim["cumulative_pitch_tolerance_arcsec"]["failing_teeth"] == [TURNED]
    assert not lim["cumulative_pitch_tolerance_arcsec"]["passed"]
    # runout 10 um against 5 um: the teeth that fit no 5 um band with the most others
    rr = table["runout_mm"]
    ok = np.array([v == "true" for v in table["runout_pass"]])
    most = max(np.count_nonzero((rr >= a) & (rr <= a + 0.005)) for a in rr)
    assert 0 < np.count_nonzero(~ok) < Z and np.count_nonzero(ok) == most
    assert np.ptp(rr[ok]) <= 0.005 + 1e-9
    assert lim["runout_tolerance"]["failing_teeth"] == [k + 1 for k in np.flatnonzero(~ok)]


@pytest.mark.slow
def test_inspection_png_marks_the_same_teeth_as_the_csv(tmp_path, monkeypatch):
    """inspection.png, drawn in the same run: red curves in the profile panel are the teeth
    failing the profile limit; shaded teeth in the pitch panel those failing a pitch limit;
    the verdict lines are the console's; the pitch panel has a legend and an x label; the
    design line is in the title."""
    import matplotlib.pyplot as plt

    from corr_cad.export import plots
    from corr_cad.run.folder.outputs import StagingDir
    from corr_cad.run.pipeline import run_scene
    from corr_cad.run.scene.scene import load_scene

    figs = []

    def record(fig, path):
        figs.append(fig)
        path.write_bytes(b"")  # the run lists the file; the figure is what is read here
        return path

    monkeypatch.setattr(plots, "_save", record)
    folder = tmp_path / "png"
    folder.mkdir()
    (folder / "cmm.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.10f},{y:.10f}" for x, y in synthetic()) + "\n"
    )
    (folder / "s.toml").write_text(
        '[export]\nformats = ["inspection"]\n[errors]\nmeasured_profile = "cmm.csv"\n' + LIMITS
    )
    said = []
    with StagingDir(folder / "out") as stage:
        run_scene(load_scene(folder / "s.toml"), stage, progress=said.append)
    with open(folder / "out" / "inspection.csv") as f:
        rows = list(csv.DictReader(f))
    (fig,) = figs
    top, pitch, runout = fig.axes
    red = set()
    for ln in top.get_lines():
        if ln.get_color() == "tab:red" and len(ln.get_xdata()) > 3:
            red.add(int(round(np.mean(ln.get_xdata()) / (360 / Z))) + 1)
    assert red == {int(x["tooth"]) for x in rows if x["profile_pass"] == "false"}
    shaded = {
        int(round(p.get_x() + p.get_width() / 2))
        for p in pitch.patches
        if p.get_facecolor()[:3] == pytest.approx((0.839, 0.153, 0.157), abs=1e-3)
    }
    cols = ("position_pass", "single_pitch_pass", "cumulative_pitch_pass")
    assert shaded == {int(x["tooth"]) for x in rows if "false" in (x[c] for c in cols)}
    assert pitch.get_xlabel() == "tooth space" and pitch.get_legend() is not None
    verdicts = [t.get_text() for t in fig.texts if t is not fig._suptitle]
    console = [ln.strip().removeprefix("inspection ") for ln in said if "inspection " in ln]
    console = [c for c in console if c.split(":")[0] in LIMIT_OF_COLUMN.values()]
    assert len(console) == 5 and verdicts == console
    assert "profile_tolerance: FAIL teeth 5, 12 (worst tooth" in console[0]
    assert "z = 25, Rj = 135 mm" in fig._suptitle.get_text()
    plt.close(fig)


def _cli(folder, name, text):
    (folder / f"{name}.toml").write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", f"{name}.toml", "--out", name, "--quiet"],
        cwd=folder,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return r


@pytest.mark.slow
def test_inspection_under_the_drive_predicts_the_drive_with_the_ring_in_its_row(tmp_path):
    """A ring with a 2 um third harmonic, inspected as ring A and as ring B of the drive:
    the measurement (teeth, pitches, registration, limits) is the same either way; the
    predicted transmission error is that of the drive's datasheet with the same harmonic
    in that row's ring alone (the other ring nominal), within the measurement's
    discretization (at most A (k dt)^2 / 8 of the deviation, 1.2e-6 of it at 6000 points,
    here within 100 times that); inspection.json says which model and row."""
    t = np.linspace(0, 2 * np.pi, 6000, endpoint=False)
    p, n = working(t)
    pts = p - (0.002 * np.cos(3 * t))[:, None] * n  # + = material added = into the opening
    (tmp_path / "h3.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.12f},{y:.12f}" for x, y in pts) + "\n"
    )
    base = (
        '[load]\ninput_torque = 1.1e5\n[solver]\nmodel = "drive"\n'
        "[datasheet]\npositions_per_mesh = 1\ntransmission_error_positions_per_turn = 4\n"
    )
    insp = '[export]\nformats = ["inspection"]\n'
    sheet = '[export]\nformats = ["datasheet"]\n'
    harmonic = "profile_deviation_harmonics = [[3, 0.002, 0]]\n"
    _cli(tmp_path, "ia", base + insp + '[errors]\nmeasured_profile = "h3.csv"\n')
    _cli(
        tmp_path,
        "ib",
        base + insp + '[inspection]\nrow = "b"\n[errors.row_b]\nmeasured_profile = "h3.csv"\n',
    )
    _cli(tmp_path, "da", base + sheet + f"[errors]\n{harmonic}[errors.row_b]\n")
    _cli(tmp_path, "db", base + sheet + f"[errors.row_b]\n{harmonic}")
    got = {k: json.loads((tmp_path / k / "inspection.json").read_text()) for k in ("ia", "ib")}
    assert (got["ia"]["model"], got["ia"]["row"]) == ("drive", "a")
    assert (got["ib"]["model"], got["ib"]["row"]) == ("drive", "b")
    for k in got["ia"]:
        if k not in ("row", "predicted", "forces"):
            assert got["ia"][k] == got["ib"][k], k
    bound = 100 * (3 * 2 * math.pi / 6000) ** 2 / 8
    for row, ds in (("a", "da"), ("b", "db")):
        pred = got[f"i{row}"]["predicted"]
        assert (pred["model"], pred["row"], pred["ring"]["row"]) == ("drive", row, row)
        assert pred["ring"]["other_ring"] == "nominal"
        sheet_te = json.loads((tmp_path / ds / "datasheet.json").read_text())
        sheet_te = sheet_te["transmission_error_arcsec"]
        for way in ("forward_peak_to_peak", "reverse_peak_to_peak"):
            te = pred["measured"]["transmission_error_arcsec"][way]
            assert te == pytest.approx(sheet_te[way], rel=bound), (row, way)
            assert te > 1e3 * pred["nominal"]["transmission_error_arcsec"][way]
        assert pred["measured"]["backlash_arcmin"]["max"] == 0.0  # the harmonic preloads
    forces = got["ib"]["forces"]
    assert forces["measured_includes"].startswith("the drive's row B")
    assert forces["roller_1_and_all"]["F_n_peak_any_roller"]["change_percent"] > 10.0


@pytest.mark.parametrize(
    "data,pattern",
    [
        (
            {"inspection": {"row": "b"}},
            r'^\[inspection\] row = "b": ring B is solved under \[solver\] model = "drive" only',
        ),
        (
            {
                "solver": {"model": "drive"},
                "export": {"formats": ["inspection"]},
                "inspection": {"row": "b"},
                "errors": {"measured_profile": "a.csv"},
            },
            r"^\[export\] formats lists 'inspection' with \[inspection\] row = \"b\" but "
            r"\[errors.row_b\] measured_profile is not set",
        ),
        (
            {"inspection": {"row": "c"}},
            r"^\[inspection\] row = 'c': must be one of a, b",
        ),
    ],
)
def test_the_inspected_row_is_checked_in_one_line(data, pattern):
    from corr_cad.errors import SceneError
    from corr_cad.run.scene.scene import parse_scene

    with pytest.raises(SceneError, match=pattern):
        parse_scene({"load": {"input_torque": 1.1e5}, **data})


def test_inspection_under_the_drive_is_no_longer_refused():
    from corr_cad.run.scene.scene import parse_scene

    scene = parse_scene(
        {
            "load": {"input_torque": 1.1e5},
            "solver": {"model": "drive", "contact_law": "palmgren"},
            "export": {"formats": ["inspection"]},
            "errors": {"measured_profile": "a.csv"},
        }
    )
    assert scene.formats == ("inspection",) and scene.inspection.get("row") is None
