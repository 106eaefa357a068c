"""Profile modification (issue 20): equidistant, shift, normal table; every file follows.

Every reference is computed here from the closed form: roller centre
``s = e cos psi + sqrt(L^2 - e^2 sin^2 psi)`` at polar angle ``t`` with
``psi = z t``, outward normal from a central difference of that curve, and
the modified profile ``P(t; L + shift) + (r + eq + n(psi)) N(t; L + shift)``
sampled densely. Distances are nearest-sample distances (sampling error
below 1e-8 mm at the densities used). Exported files are read back with
ezdxf or parsed as text.
"""

import csv
import json
import math
import subprocess
import sys

import ezdxf
import numpy as np
import pytest
from ezdxf import path as ezpath
from scipy.spatial import cKDTree

Z, E, RJ, R = 25, 3.5, 135.0, 8.0
L = RJ + R
PITCH = 2 * math.pi / Z


# ---------------------------------------------------------------- closed forms
def locus(t, ll=L):
    t = np.asarray(t, dtype=float)
    psi = Z * t
    s = E * np.cos(psi) + np.sqrt(ll * ll - (E * np.sin(psi)) ** 2)
    return np.stack([s * np.sin(t), s * np.cos(t)], -1)


def normal(t, ll=L):
    h = 1e-6
    d = (locus(t + h, ll) - locus(t - h, ll)) / (2 * h)
    n = np.stack([-d[..., 1], d[..., 0]], -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def bump(psi):
    """A smooth, tooth-periodic normal modification: 0 in the tooth space, 20 um at the tip."""
    return 0.010 * (1.0 - np.cos(psi))


def modified(t, eq=0.0, sh=0.0, table=False):
    t = np.asarray(t, dtype=float)
    off = R + eq + (bump(Z * t) if table else 0.0 * t)
    return locus(t, L + sh) + off[..., None] * normal(t, L + sh)


def clearance_dense(psi, eq=0.0, sh=0.0, table=False, half_window=0.02, n=40001):
    """Distance from the nominal roller centre at psi to the dense modified curve, less r."""
    out = []
    for p in np.atleast_1d(psi):
        t0 = p / Z
        c = locus(np.array([t0]))[0]
        tt = np.linspace(t0 - half_window, t0 + half_window, n)
        pts = modified(tt, eq, sh, table)
        out.append(np.min(np.hypot(pts[:, 0] - c[0], pts[:, 1] - c[1])) - R)
    return np.array(out)


def table_csv(path, symmetric=True):
    psi = np.linspace(0, 180, 181) if symmetric else np.linspace(-180, 180, 361)
    rows = "\n".join(f"{p:.6f},{bump(math.radians(p)):.15f}" for p in psi)
    path.write_text("psi_deg,normal_mm\n" + rows + "\n")
    return path


# ------------------------------------------------------------ library checks
PSI = np.radians(np.array([0.0, 20.0, 45.0, 90.0, 135.0, 170.0, -60.0, -150.0]))


@pytest.mark.parametrize(
    "kw",
    [{"eq": 0.012}, {"sh": 0.015}, {"table": True}, {"eq": 0.01, "sh": -0.006, "table": True}],
    ids=["equidistant", "shift", "normal_table", "combined"],
)
def test_family_clearance_along_the_flank_matches_dense_geometry(kw, tmp_path):
    from corr_cad import GearDesign
    from corr_cad.geometry.modification import Modification, flank_clearance, modified_profile
    from corr_cad.run.scene.scene_modification import read_normal_table

    table = read_normal_table(table_csv(tmp_path / "n.csv")) if kw.get("table") else None
    mod = Modification(kw.get("eq", 0.0), kw.get("sh", 0.0), table)
    d = GearDesign()
    got = flank_clearance(d, modified_profile(d, mod), PSI)
    want = clearance_dense(PSI, **kw)
    assert np.max(np.abs(got - want)) < 2e-7, (got, want)
    if kw == {"eq": 0.012}:
        assert np.allclose(want, 0.012, atol=1e-7)  # uniform: the equidistant is exact


def test_shift_clearance_varies_with_the_pressure_angle():
    # First order: sh L / W cos(beta); 15 um shift gives 15 um at psi 0, less on the flank.
    c = clearance_dense(np.radians([0.0, 90.0]), sh=0.015)
    w = math.sqrt(L * L - E * E)
    beta = math.atan2(Z * E, w)
    assert c[0] == pytest.approx(0.015, abs=1e-7)
    assert c[1] == pytest.approx(0.015 * L / w * math.cos(beta), abs=2e-6)


def test_normal_table_is_c2_across_the_tooth_tip(tmp_path):
    from corr_cad.run.scene.scene_modification import read_normal_table

    tab = read_normal_table(table_csv(tmp_path / "n.csv", symmetric=False))
    eps = 1e-7
    for nu in (0, 1, 2):
        lo = tab(np.array([math.pi - eps]), nu)[0]
        hi = tab(np.array([-math.pi + eps]), nu)[0]
        assert lo == pytest.approx(hi, abs=1e-5)


@pytest.mark.parametrize(
    "rows, words",
    [
        ("0,0\n90,0.01\n45,0.02\n180,0\n", "must increase strictly"),
        ("0,0\n60,0.01\n120,0.02\n", "at least 4"),
        ("0,0\n60,0.01\n120,0.02\n170,0\n", "spans [0, 180]"),
        ("-180,0\n0,0.01\n90,0.02\n180,0.01\n", "same value"),
        ("0,0\n60,abc\n120,0.02\n180,0\n", "line 2"),
        ("0,0\n60,2\n120,0.02\n180,0\n", "allowed range is [-1, 1]"),
    ],
)
def test_bad_table_is_one_line_exit_2(tmp_path, rows, words):
    (tmp_path / "n.csv").write_text(rows)
    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["dxf"]\n[modification]\nnormal_table = "n.csv"\n'
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "o"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2, r.stderr
    assert words in r.stderr and "normal_table" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.mark.slow
def test_modified_curve_undercut_is_refused(tmp_path):
    (tmp_path / "s.toml").write_text(
        '[design]\nroller_radius = 10.0\n[export]\nformats = ["dxf"]\n'
        "[modification]\nequidistant_mm = 0.2\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "o"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "undercut" in r.stderr and "[modification]" in r.stderr


# ------------------------------------------------------------- exported files
EQ = 0.02


@pytest.fixture(scope="module")
def shop(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shop")
    (folder / "s.toml").write_text(
        '[export]\nformats = ["dxf", "edm", "cmm", "png", "stl", "interference"]\n'
        f'representation = "arcs"\ntolerance = 0.001\n[modification]\nequidistant_mm = {EQ}\n'
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=folder,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    return folder / "out"


def _layer_points(path, layer):
    doc = ezdxf.readfile(path)
    pts = []
    for ent in doc.modelspace():
        if ent.dxf.layer == layer:
            pts.extend((v.x, v.y) for v in ezpath.make_path(ent).flattening(1e-6))
    return np.array(pts, dtype=float)


def _disc_clearance(points, psi):
    """Clearance of roller discs at their nominal positions (tooth 1) to a point cloud."""
    tree = cKDTree(points)
    d, _ = tree.query(locus(psi / Z))
    return d - R


@pytest.mark.slow
def test_dxf_profile_clears_the_nominal_roller_by_plus_equidistant(shop):
    psi = np.radians(np.linspace(-170, 170, 35))
    work = _disc_clearance(_layer_points(shop / "inner_gear.dxf", "WORKING_PROFILE"), psi)
    conj = _disc_clearance(_layer_points(shop / "inner_gear.dxf", "CONJUGATE_PROFILE"), psi)
    assert np.all(np.abs(work - EQ) <= 0.001 + 1e-5), work  # the [export] tolerance
    assert np.all(np.abs(conj) <= 0.001 + 1e-5), conj


@pytest.mark.slow
def test_edm_path_clears_by_equidistant_less_the_wire_offset(shop):
    m = json.loads((shop / "manifest.json").read_text())
    d = m["edm"]["wire_offset_mm"]
    psi = np.radians(np.linspace(-170, 170, 35))
    cut = _disc_clearance(_layer_points(shop / "inner_gear_edm.dxf", "CUT"), psi)
    assert np.all(np.abs(cut - (EQ - d)) <= 0.001 + 1e-4), cut  # tolerance + G-code rounding
    # The G-code's end points lie on the same path.
    text = (shop / "inner_gear_edm.nc").read_text()
    xy = [
        (float(a), float(b))
        for a, b in __import__("re").findall(r"G0[123] X(-?[0-9.]+) Y(-?[0-9.]+)", text)
    ]
    tree = cKDTree(locus(np.linspace(0, 2 * math.pi, 400001)))
    dist, _ = tree.query(np.array(xy[2:-2]))
    assert np.all(np.abs(dist - (R + EQ - d)) < 0.002)


@pytest.mark.slow
def test_cmm_points_sit_at_r_plus_equidistant_from_the_roller_locus(shop):
    with open(shop / "inner_gear_nominal.csv") as f:
        assert f.readline().startswith("# corr_cad CMM nominal points")  # the profile line
        rows = list(csv.DictReader(f))
    p = np.array([[float(r["x"]), float(r["y"])] for r in rows])
    n = np.array([[float(r["nx"]), float(r["ny"])] for r in rows])
    tree = cKDTree(locus(np.linspace(0, 2 * math.pi, 2_000_001)))
    dist, _ = tree.query(p)
    assert np.all(np.abs(dist - (R + EQ)) < 1e-5)
    # the normal points from the ring material into the opening: towards the locus
    inward = locus(np.arctan2(p[:, 0], p[:, 1])) - p
    assert np.all(np.sum(n * inward, axis=1) > 0)


@pytest.mark.slow
def test_stl_ring_clears_the_nominal_roller_by_plus_equidistant(shop):
    import trimesh

    v = trimesh.load(shop / "inner_gear.stl").vertices
    v = v[(np.abs(v[:, 2]) < 1e-9) & (np.hypot(v[:, 0], v[:, 1]) < L + R + 10)][:, :2]
    a = v[np.argsort(np.arctan2(v[:, 0], v[:, 1]))]  # the opening's outline at z = 0
    ab = np.roll(a, -1, axis=0) - a
    q = locus(np.radians(np.linspace(-170, 170, 35)) / Z)
    u = np.clip(np.einsum("qij,ij->qi", q[:, None, :] - a[None], ab) / np.sum(ab * ab, 1), 0, 1)
    foot = a[None] + u[..., None] * ab[None]
    c = np.min(np.linalg.norm(q[:, None, :] - foot, axis=2), axis=1) - R
    assert np.all(np.abs(c - EQ) <= 0.001 + 1e-6), c  # chord tolerance


@pytest.mark.slow
def test_exact_clearance_csv_gives_the_ring_clearance_of_the_modification(shop):
    with open(shop / "clearance.csv") as f:
        ring = np.array([float(r["ring_clearance_mm"]) for r in csv.DictReader(f)])
    assert np.all(np.abs(ring - EQ) < 1e-9), (ring.min(), ring.max())


@pytest.mark.slow
def test_modification_png_and_manifest(shop):
    m = json.loads((shop / "manifest.json").read_text())
    assert (shop / "modification.png").stat().st_size > 10_000
    rec = m["modification"]
    assert rec["equidistant_mm"] == EQ and rec["families"] == ["equidistant"]
    assert rec["flank_clearance_mm"]["min"] == pytest.approx(EQ, abs=1e-9)


def test_manifest_clearance_at_named_roll_angles_is_the_curve_there():
    """A 15 um shift: the clearance varies along the flank, so each named roll angle of
    ``manifest.json`` must be read at that angle (degrees) of the dense closed form."""
    from types import SimpleNamespace

    from corr_cad import GearDesign
    from corr_cad.geometry.modification import Modification
    from corr_cad.run.stages.stages_modification import modification_manifest

    scene = SimpleNamespace(design=GearDesign(), modification=Modification(0.0, 0.015, None))
    at = modification_manifest(SimpleNamespace(scene=scene))["flank_clearance_mm"]["at_psi_deg"]
    want = clearance_dense(np.radians([0.0, 45.0, 90.0, 135.0]), sh=0.015)
    assert list(at) == ["0", "45", "90", "135"]
    np.testing.assert_allclose([at[k] for k in at], want, atol=2e-7)
    assert want[0] - want[2] > 1e-3  # the curve does vary: 15 um at psi 0, less on the flank


def test_a_measured_ring_with_a_designed_clearance_repeats_after_a_revolution():
    """The designed clearance alone is alike on every tooth (mesh period); added to a ring
    deviation of its own (here harmonics) the windup repeats only after 2 pi."""
    from corr_cad import GearDesign
    from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
    from corr_cad.geometry.modification import (
        Modification,
        modification_gap,
        modified_profile,
        with_modification,
    )
    from corr_cad.mechanics.row.windup import result_period_rad

    d = GearDesign()
    gap = modification_gap(d, modified_profile(d, Modification(0.01, 0.0, None)))
    alone = with_modification(ManufacturingErrors(), gap)
    assert result_period_rad(d, alone) == pytest.approx(2 * math.pi / (Z * (Z + 1)), rel=1e-15)
    ring = ManufacturingErrors(profile_deviation=harmonic_deviation(((3, 0.002, 0.0),)))
    both = with_modification(ring, gap)
    assert not both.tooth_periodic_profile and both.per_roller
    assert result_period_rad(d, both) == 2 * math.pi


# ------------------------------------------------------------------ backlash
def _roller_distance_beyond_locus(x, delta):
    """Signed distance of every roller centre beyond the locus (+ = towards the ring).

    Output angle ``x``, crank locked at ``(z + 1) x``, frame turned by ``delta``:
    each roller rides the cam (|H - O1| = L) in its slot.
    """
    phi = (Z + 1) * x
    th = np.arange(Z + 1) * 2 * math.pi / (Z + 1)
    a = x + delta + th
    g = a - phi
    s = E * np.cos(g) + np.sqrt(L * L - (E * np.sin(g)) ** 2)
    h = np.stack([s * np.sin(a), s * np.cos(a)], -1)
    out = []
    for k in range(Z + 1):
        tt = np.linspace(a[k] - 0.01, a[k] + 0.01, 20001)
        pts = locus(tt)
        d = np.hypot(pts[:, 0] - h[k, 0], pts[:, 1] - h[k, 1])
        j = int(np.argmin(d))
        sign = 1.0 if np.hypot(*h[k]) > np.hypot(*pts[j]) else -1.0
        out.append(sign * d[j])
    return np.array(out)


def test_backlash_of_an_equidistant_modification_matches_a_hand_calculation():
    from scipy.optimize import brentq

    from corr_cad import GearDesign
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.geometry.modification import (
        Modification,
        modification_gap,
        modified_profile,
        with_modification,
    )
    from corr_cad.mechanics.row.windup import Windup

    eq = 0.01
    d = GearDesign()
    err = with_modification(
        ManufacturingErrors(), modification_gap(d, modified_profile(d, Modification(eq)))
    )
    xs = np.array([0.0, 0.37 * 2 * math.pi / (Z * (Z + 1))])
    w = Windup(d, xs, errors=err)
    got = w.backlash()
    for k, x in enumerate(xs):

        def f(dl, x=x):
            return float(np.max(_roller_distance_beyond_locus(x, dl))) - eq

        hi = brentq(f, 1e-7, 1e-2, xtol=1e-12)
        lo = brentq(f, -1e-2, -1e-7, xtol=1e-12)
        assert got[k] == pytest.approx(hi - lo, rel=5e-3), (got[k], hi - lo)


# ---------------------------------------------------------------- inspection
def _ring_points(eq, m=60):
    t_loc = (np.arange(m) + 0.5) / m * PITCH - PITCH / 2
    t = np.concatenate([t_loc + k * PITCH for k in range(Z)])
    return modified(t, eq)


def _inspect(folder, against):
    folder.mkdir(parents=True, exist_ok=True)
    pts = _ring_points(EQ)
    (folder / "cmm.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.10f},{y:.10f}" for x, y in pts) + "\n"
    )
    (folder / "s.toml").write_text(
        '[export]\nformats = ["inspection"]\n[errors]\nmeasured_profile = "cmm.csv"\n'
        f'[modification]\nequidistant_mm = {EQ}\ninspect_against = "{against}"\n'
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=folder,
        capture_output=True,
        text=True,
    )
    with open(folder / "out" / "inspection.csv") as f:
        rows = list(csv.DictReader(f))
    return r, rows


@pytest.mark.slow
def test_ring_made_to_the_modified_profile_inspects_zero_and_the_modification(tmp_path):
    _, rows = _inspect(tmp_path / "mod", "modified")
    lo = np.array([float(r["profile_min_mm"]) for r in rows])
    hi = np.array([float(r["profile_max_mm"]) for r in rows])
    assert np.all(np.abs(lo) < 1e-7) and np.all(np.abs(hi) < 1e-7)
    _, rows = _inspect(tmp_path / "conj", "conjugate")
    lo = np.array([float(r["profile_min_mm"]) for r in rows])
    hi = np.array([float(r["profile_max_mm"]) for r in rows])
    # material removed: -equidistant_mm on every point (+ = material added)
    assert np.all(np.abs(lo + EQ) < 1e-7) and np.all(np.abs(hi + EQ) < 1e-7)


# ------------------------------------------------------------------- default
@pytest.mark.slow
def test_without_modification_nothing_changes(tmp_path):
    (tmp_path / "s.toml").write_text('[export]\nformats = ["dxf"]\n')
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert "modification" not in m and "conjugate_profile" not in m["accuracy"]
    doc = ezdxf.readfile(tmp_path / "out" / "inner_gear.dxf")
    assert "CONJUGATE_PROFILE" not in doc.layers
