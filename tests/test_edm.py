"""Wire-EDM package and CMM nominal points (issue 12), tested as a user runs them.

The G-code is read by an independent parser (``gcodeparser``), its arcs
traced here, and the path compared with the exact offset curve computed in
this file from the closed form: roller centre ``s = e cos psi + sqrt(L^2 -
e^2 sin^2 psi)``, ``psi = z t``, point ``s (sin t, cos t)``; the working
profile is its outer offset by ``r`` and the wire centre runs ``d = wire/2 +
gap`` inside it, i.e. at offset ``r - d`` along the same normals.
"""

import csv
import json
import math
import subprocess
import sys

import ezdxf
import numpy as np
import pytest
from gcodeparser import parse_gcode_lines

from tests.helpers import without_progress

Z, E, RJ, R = 25, 3.5, 135.0, 8.0
L = RJ + R
WIRE, GAP = 0.25, 0.02
D = WIRE / 2 + GAP
TOL = 0.001
SPACING = 0.5


def curve(t, off, z=Z, e=E, ll=L):
    """Closed-form offset of the roller-centre locus by ``off`` (outer normal)."""
    t = np.asarray(t, dtype=float)
    psi = z * t
    w = np.sqrt(ll * ll - (e * np.sin(psi)) ** 2)
    s = e * np.cos(psi) + w
    ds = -z * e * np.sin(psi) * s / w  # ds/dt
    ur = np.stack([np.sin(t), np.cos(t)], -1)
    ut = np.stack([np.cos(t), -np.sin(t)], -1)
    tang = ds[..., None] * ur + s[..., None] * ut
    n = s[..., None] * ur - ds[..., None] * ut
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return s[..., None] * ur + off * n, tang / np.linalg.norm(tang, axis=-1, keepdims=True), n


def distance(q, off):
    """Distance of points ``q`` from the closed-form offset curve (Newton, numeric derivatives)."""
    q = np.asarray(q, dtype=float)
    # seed: the nearest of 41 samples within +-0.06 rad of the point's polar angle
    win = np.linspace(-0.06, 0.06, 41)
    tt = np.arctan2(q[:, 0], q[:, 1])[:, None] + win[None, :]
    dd = np.linalg.norm(curve(tt, off)[0] - q[:, None, :], axis=-1)
    t = tt[np.arange(len(q)), np.argmin(dd, axis=1)]
    h = 1e-6
    for _ in range(12):
        c = curve(t, off)[0]
        c1 = (curve(t + h, off)[0] - curve(t - h, off)[0]) / (2 * h)
        c2 = (curve(t + h, off)[0] - 2 * c + curve(t - h, off)[0]) / (h * h)
        g = np.sum((c - q) * c1, 1)
        dg = np.sum(c1 * c1, 1) + np.sum((c - q) * c2, 1)
        t = t - np.clip(g / dg, -1e-3, 1e-3)
    return np.linalg.norm(q - curve(t, off)[0], axis=1)


def run(folder, scene_text, name="s.toml"):
    (folder / name).write_text(scene_text)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", name, "--out", "out", "--quiet"],
        cwd=folder,
        capture_output=True,
        text=True,
    )


@pytest.fixture(scope="module")
def edm_run(tmp_path_factory):
    """Prototype, EDM + CMM + forces, in a folder that holds other files."""
    folder = tmp_path_factory.mktemp("edm")
    (folder / "notes.txt").write_text("unrelated file\n")
    r = run(
        folder,
        f"""
[export]
formats = ["edm", "cmm", "forces"]
tolerance = {TOL}
[edm]
wire_diameter = {WIRE}
spark_gap = {GAP}
feed_mm_per_min = 3.5
[inspection]
point_spacing = {SPACING}
[load]
input_torque = 1.1e5
[solver]
positions = 360
""",
    )
    assert r.returncode == 0, r.stderr
    out = folder / "out"
    return out, json.loads((out / "manifest.json").read_text())


def trace(path):
    """Parse the program line by line; returns the moves (kind, start, end, centre) by section."""
    text = path.read_text().splitlines()
    assert "G21" in text and "G90" in text
    markers = ("(lead-in)", "(contour)", "(lead-out)")
    assert [ln for ln in text if ln in markers] == list(markers)
    comments = [ln for ln in text if ln.startswith("(")]
    pos, section, feed, moves = None, "preamble", None, []
    for ln in text:
        if ln in markers:
            section = ln.strip("()")
            continue
        if not ln or ln[0] not in "GM":
            continue
        (g,) = parse_gcode_lines(ln)
        kind, num = g.command
        p = g.params
        feed = p.get("F", feed)
        if kind == "G" and num == 0:
            pos = np.array([p["X"], p["Y"]], dtype=float)
        elif kind == "G" and num in (1, 2, 3):
            end = np.array([p["X"], p["Y"]], dtype=float)
            m = {"section": section, "start": pos, "end": end, "kind": num}
            if num in (2, 3):
                m["centre"] = pos + np.array([p["I"], p["J"]], dtype=float)
            moves.append(m)
            pos = end
    return moves, comments, feed


def arc_points(m, n=16):
    c = m["centre"]
    a0 = math.atan2(*(m["start"] - c)[::-1])
    a1 = math.atan2(*(m["end"] - c)[::-1])
    sweep = (a1 - a0) % (2 * math.pi)
    if m["kind"] == 2:  # G02: clockwise
        sweep -= 2 * math.pi
    rad = np.linalg.norm(m["start"] - c)
    ang = a0 + np.linspace(0, 1, n) * sweep
    return c + rad * np.stack([np.cos(ang), np.sin(ang)], 1), sweep


def direction(m, at_end):
    if m["kind"] == 1:
        v = m["end"] - m["start"]
    else:
        p = (m["end"] if at_end else m["start"]) - m["centre"]
        v = np.array([p[1], -p[0]]) if m["kind"] == 2 else np.array([-p[1], p[0]])
    return v / np.linalg.norm(v)


def test_gcode_traced_by_independent_parser_follows_exact_offset(edm_run):
    out, man = edm_run
    moves, comments, feed = trace(out / "inner_gear_edm.nc")
    contour = [m for m in moves if m["section"] == "contour"]
    pts = np.concatenate(
        [
            arc_points(m)[0] if m["kind"] != 1 else np.linspace(m["start"], m["end"], 16)
            for m in contour
        ]
    )
    dev = distance(pts, R - D)
    reported = man["edm"]["max_deviation_mm"]
    assert dev.max() <= TOL
    assert dev.max() <= reported + 1e-6  # the reported number is the true worst case
    assert dev.max() >= 0.9 * reported
    # radius mismatch of every programmed arc within what a controller accepts
    for m in contour:
        if m["kind"] != 1:
            r0 = np.linalg.norm(m["start"] - m["centre"])
            r1 = np.linalg.norm(m["end"] - m["centre"])
            assert abs(r0 - r1) < 2e-4
    # closed, once around, clockwise (polar angle from +y towards +x grows)
    np.testing.assert_array_equal(contour[0]["start"], contour[-1]["end"])
    ang = np.unwrap(np.arctan2(pts[:, 0], pts[:, 1]))
    assert ang[-1] - ang[0] == pytest.approx(2 * math.pi, abs=1e-6)
    # the header names the design, the offset and the measured deviation
    head = " ".join(comments)
    assert f"wire centre offset {D:g} mm into the opening" in head
    assert f"{reported:.3g} mm" in head and "z = 25" in head and "e = 3.5" in head
    assert feed == 3.5


def test_lead_in_tangent_and_start_hole_in_scrap(edm_run):
    out, man = edm_run
    moves, _, _ = trace(out / "inner_gear_edm.nc")
    lead_in = [m for m in moves if m["section"] == "lead-in"]
    lead_out = [m for m in moves if m["section"] == "lead-out"]
    contour = [m for m in moves if m["section"] == "contour"]
    assert np.allclose(lead_in[-1]["end"], contour[0]["start"])
    assert np.allclose(lead_out[0]["start"], contour[-1]["end"])
    k_in = math.acos(
        min(1.0, float(np.dot(direction(lead_in[-1], True), direction(contour[0], False))))
    )
    k_out = math.acos(
        min(1.0, float(np.dot(direction(contour[-1], True), direction(lead_out[0], False))))
    )
    assert k_in < 2e-4 and k_out < 2e-4  # tangent, to the 1e-4 mm number format
    # quarter arcs: lead_in_length / 2 radius, 90 deg
    for m in (lead_in[-1], lead_out[0]):
        assert abs(arc_points(m)[1]) == pytest.approx(math.pi / 2, abs=1e-3)
        assert np.linalg.norm(m["start"] - m["centre"]) == pytest.approx(1.0, abs=2e-4)
    # start hole: the program starts and ends there, and the hole lies in the opening
    hole = lead_in[0]["start"]
    np.testing.assert_array_equal(hole, lead_out[-1]["end"])
    to_profile = distance(hole[None, :], R)[0]
    r_hole = np.hypot(*hole)
    assert r_hole < np.hypot(*curve(np.array([math.atan2(*hole)]), R)[0][0])  # inside
    assert to_profile > 1.5  # start hole radius
    # lead-in point: least loaded over the cycle according to forces.csv
    psi_sel = man["edm"]["lead_in_point"]["psi_deg"]
    with open(out / "forces.csv") as f:
        rows = list(csv.DictReader(f))
    psi = np.array([float(r["psi_deg"]) for r in rows])
    fn = np.array([float(r["F_n"]) for r in rows])
    psi = (psi + 180.0) % 360.0 - 180.0
    near = np.abs((psi - psi_sel + 180.0) % 360.0 - 180.0) <= 0.25
    assert near.any() and fn[near].max() == 0.0
    assert 170.0 < abs(psi_sel) <= 180.0  # towards the tooth tip
    t_sel = math.radians(psi_sel) / Z
    q = curve(np.array([t_sel]), R - D)[0][0]
    assert np.linalg.norm(contour[0]["start"] - q) < TOL


def test_dxf_describes_the_same_path(edm_run):
    out, _ = edm_run
    moves, _, _ = trace(out / "inner_gear_edm.nc")
    doc = ezdxf.readfile(out / "inner_gear_edm.dxf")
    msp = doc.modelspace()
    assert doc.header["$INSUNITS"] == 4
    assert {e.dxf.layer for e in msp} == {"CUT", "START_HOLE", "LEAD"}
    (cut,) = msp.query('LWPOLYLINE[layer=="CUT"]')
    assert cut.closed
    (hole,) = msp.query('CIRCLE[layer=="START_HOLE"]')
    assert hole.dxf.radius == pytest.approx(1.5)
    leads = msp.query('LWPOLYLINE[layer=="LEAD"]')
    assert len(leads) == 2
    contour = [m for m in moves if m["section"] == "contour"]
    pts = cut.get_points("xyb")
    assert len(pts) == len(contour)
    for (x, y, b), m in zip(pts, contour, strict=True):
        assert (x, y) == pytest.approx(tuple(m["start"]), abs=1e-9)
        sweep = arc_points(m)[1] if m["kind"] != 1 else 0.0
        assert 4 * math.atan(b) == pytest.approx(sweep, abs=1e-9)
    np.testing.assert_allclose(list(hole.dxf.center)[:2], moves[0]["start"], atol=1e-9)


@pytest.mark.slow
def test_lead_in_at_tooth_tip_without_forces_and_refusals(tmp_path):
    r = run(tmp_path, '[export]\nformats = ["edm"]\n')
    assert r.returncode == 0, r.stderr
    man = json.loads((tmp_path / "out" / "manifest.json").read_text())
    li = man["edm"]["lead_in_point"]
    assert li["psi_deg"] == 180.0 and "tooth tip" in li["where"]
    text = (tmp_path / "out" / "inner_gear_edm.nc").read_text()
    assert "tooth tip" in text and "no forces computed" in text
    p = np.array(li["point_mm"])
    assert math.degrees(math.atan2(p[0], p[1])) == pytest.approx(180.0 / Z, abs=1e-3)
    # start hole too large for the scrap around the lead-in
    bad = tmp_path / "bad"
    bad.mkdir()
    r = run(bad, '[export]\nformats = ["edm"]\n[edm]\nstart_hole_diameter = 6.0\n')
    assert r.returncode == 2 and not (bad / "out").exists()
    assert len(without_progress(r.stderr).strip().splitlines()) == 1
    assert "Traceback" not in r.stderr
    assert "[edm] start_hole_diameter = 6" in r.stderr and "scrap" in r.stderr
    # wire offset beyond the smallest concave radius (tooth space of 0.749 mm)
    r = run(
        bad,
        "[design]\ntooth_count = 100\neccentricity = 3.4\nroller_radius = 0.2\n"
        '[export]\nformats = ["edm"]\n[edm]\nwire_diameter = 1.0\nspark_gap = 0.3\n',
    )
    assert r.returncode == 2 and not (bad / "out").exists()
    assert len(without_progress(r.stderr).strip().splitlines()) == 1
    assert "[edm] wire_diameter = 1" in r.stderr and "smallest concave radius" in r.stderr
    assert "0.74" in r.stderr


def test_cmm_points_on_exact_curve_with_inward_normals(edm_run):
    out, man = edm_run
    with open(out / "inner_gear_nominal.csv") as f:
        rd = csv.reader(f)
        assert next(rd)[0].startswith("# corr_cad CMM nominal points")  # names the profile
        assert next(rd) == ["tooth", "t_deg", "x", "y", "nx", "ny"]
        rows = np.array([[float(v) for v in r] for r in rd])
    tooth, t = rows[:, 0].astype(int), np.radians(rows[:, 1])
    xy, nn = rows[:, 2:4], rows[:, 4:6]
    exact, tang, n_out = curve(t, R)
    assert np.abs(xy - exact).max() <= 1e-9
    assert np.abs(np.sum(nn * tang, 1)).max() <= 1e-9
    assert np.abs(np.linalg.norm(nn, axis=1) - 1).max() <= 1e-12
    assert np.all(np.sum(nn * n_out, 1) < -0.999999)  # from the ring material into the opening
    # every point is also at distance exactly r from the locus (envelope property)
    assert np.abs(distance(xy, R)).max() <= 1e-9
    pitch = 2 * math.pi / Z
    assert np.all(np.abs(t - (tooth - 1) * pitch) <= pitch / 2 + 1e-12)
    assert sorted(set(tooth)) == list(range(1, Z + 1))
    gaps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    assert gaps.max() <= SPACING + 1e-9
    assert man["cmm"]["point_spacing_mm"] <= SPACING


def test_lead_in_polar_angle_in_the_manifest_is_in_degrees(edm_run):
    """``t_deg`` is the lead-in point's roller-centre polar angle, in degrees: ``psi / z``."""
    _, man = edm_run
    li = man["edm"]["lead_in_point"]
    assert li["t_deg"] == pytest.approx(li["psi_deg"] / Z, abs=1e-9)
    assert 180.0 / Z - 1.0 < abs(li["t_deg"]) < 180.0 / Z + 1e-9  # near the tooth tip
    # the point written is the wire path's point at that angle
    q = curve(np.array([li["t_deg"] * math.pi / 180.0]), R - D)[0][0]
    assert np.linalg.norm(np.array(li["point_mm"]) - q) < TOL


def test_wire_contour_is_tangent_continuous(edm_run):
    """G1 at every vertex of the cut (and where it closes), as the G-code programs it."""
    out, _ = edm_run
    moves, _, _ = trace(out / "inner_gear_edm.nc")
    contour = [m for m in moves if m["section"] == "contour"]
    kinks = [
        math.acos(min(1.0, float(np.dot(direction(a, True), direction(b, False)))))
        for a, b in zip(contour, contour[1:] + contour[:1], strict=True)
    ]
    # a 1e-4 mm number format turns a tangent by ~1e-4 / radius; 0.6 deg is 1e-2 rad
    assert max(kinks) < 1e-3, math.degrees(max(kinks))
    assert sum(m["kind"] != 1 for m in contour) > 0.9 * len(contour)  # arcs, not chords


def test_all_moves_at_once_are_each_moves_points_bit_for_bit():
    """The measurement's points of all moves at once equal :meth:`Move.points` move by move."""
    from corr_cad.shop.edm import Move, _moves_at

    rng = np.random.default_rng(7)
    moves = []
    for i in range(60):
        a = tuple(np.round(rng.uniform(-50, 50, 2), 4))
        b = tuple(np.round(rng.uniform(-50, 50, 2), 4))
        if i % 3 == 0:
            moves.append(Move("line", a, b))
        else:
            c = tuple(np.round(0.5 * (np.add(a, b)) + rng.uniform(-5, 5, 2), 4))
            moves.append(Move("arc", a, b, c, bool(i % 2)))
    moves = tuple(moves)
    u = np.linspace(0.0, 1.0, 17)
    uu = rng.uniform(0.0, 1.0, len(moves))
    for ra in (0.0, 1.0, 0.3):
        at = _moves_at(moves, ra)
        ref = np.concatenate([m.points(u, ra) for m in moves])
        assert np.array_equal(at(np.broadcast_to(u, (len(moves), 17))), ref)
        one = np.concatenate([m.points(np.array([x]), ra) for m, x in zip(moves, uu, strict=True)])
        assert np.array_equal(at(uu[:, None]), one)
