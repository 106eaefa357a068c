"""Tests that catch wrong physics (issue 10 item 4).

Each test compares the package with something that shares no code with it:
hand-computed values, the closed form written out here, ``mpmath``, brute
force, or :mod:`corr_cad.mechanics.reference` (which imports nothing from the package).
``tests/README.md`` lists the deliberate mistakes each one catches.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.errors import DesignError
from corr_cad.geometry.deviations import ManufacturingErrors, harmonic_deviation
from corr_cad.geometry.profile import undercut_analysis
from corr_cad.mechanics import contact
from corr_cad.mechanics.reference import reference_geometry, reference_position
from corr_cad.mechanics.row.solver import cycle_angles, solve_forces
from corr_cad.tolerance.allocation import allocate
from corr_cad.tolerance.checks import Checks
from corr_cad.tolerance.montecarlo import Distribution, draw_samples, monte_carlo

M0 = 1.1e5
DEG = math.pi / 180.0  # written out: the tests never use the package's conversions


# --- unit conversions, pinned to hand-computed values -------------------------------


def test_eccentricity_error_gap_is_plus_de_cos_psi(prototype):
    """docs/physics.md: the eccentricity error's cam-contact gap is about ``+de cos psi``
    (the cam centre moved out to e + de presses on the roller at psi = 0)."""
    from corr_cad.mechanics.row.solver_geometry import roller_geometry

    de = 0.001
    R = prototype.roller_count
    crank = np.radians([0.0, 30.0, 90.0])
    geo = roller_geometry(prototype, crank, ManufacturingErrors(eccentricity_error=de))
    nominal = roller_geometry(prototype, crank)
    want = de * np.cos(crank[:, None] - np.arange(R) * 2 * math.pi / R)  # psi of each roller
    np.testing.assert_allclose(geo.gap - nominal.gap, want, atol=0.05 * de)  # "about"
    assert geo.gap[0, 0] == pytest.approx(de, rel=1e-3)  # +1.000 um at psi = 0


def test_harmonic_phase_is_in_degrees():
    # dev(t) = a cos(k t - phase): phase 90 deg shifts a 3rd harmonic by 30 deg of t.
    dev = harmonic_deviation([(3, 0.002, 90.0)])
    assert dev(np.array([0.0]))[0] == pytest.approx(0.0, abs=1e-18)
    assert dev(np.array([math.pi / 6]))[0] == pytest.approx(0.002, rel=1e-15)
    assert dev(np.array([math.pi / 3]))[0] == pytest.approx(0.0, abs=1e-18)


def test_scene_angles_are_degrees():
    from corr_cad.run.scene.scene import parse_scene

    sc = parse_scene(
        {
            "errors": {
                "cam_phase_error_deg": 0.05,
                "slot_angle_errors_deg": [0.01 * i for i in range(26)],
                "profile_deviation_harmonics": [[3.0, 0.002, 20.0]],
            }
        }
    )
    assert sc.errors.cam_phase_error == pytest.approx(8.726646259971648e-4, rel=1e-15)
    assert sc.errors.slot_angle_errors[3] == pytest.approx(5.235987755982989e-4, rel=1e-15)
    t = 0.1
    assert sc.errors.profile_deviation(np.array([t]))[0] == pytest.approx(
        0.002 * math.cos(3 * t - 20.0 * DEG), rel=1e-14
    )


def _ref_backlash_arcmin(design, crank_angle, errors):
    """Backlash from the reference's own compatibility, by hand.

    With the crank held, the cam turns freely until a roller touches cam,
    gear and slot wall at zero load: per roller that happens at
    ``tau_i = (d . c - g_j) / advance`` with ``d`` fixed by the gear and slot
    contacts. The frame turns ``1/(z+1)`` of the free crank play; 1 rad =
    60 * 180 / pi arcmin.
    """
    rows = reference_geometry(design, crank_angle, errors)
    fwd, rev = math.inf, -math.inf
    for g in rows:
        if abs(g["advance"]) < 1e-12:  # at psi = 0 or pi the cam cannot close it
            continue
        n, ut, c = g["n"], g["ut"], g["c"]
        a_n = -g["g_n"]
        a_t = -math.copysign(g["clr"], g["ft"])
        det = n[0] * ut[1] - n[1] * ut[0]
        d = ((a_n * ut[1] - n[1] * a_t) / det, (n[0] * a_t - a_n * ut[0]) / det)
        tau = (d[0] * c[0] + d[1] * c[1] - g["g_j"]) / g["advance"]
        if g["advance"] > 0:
            fwd = min(fwd, tau)
        elif g["advance"] < 0:
            rev = max(rev, tau)
    return max(fwd - rev, 0.0) / len(rows) * 60.0 * 180.0 / math.pi


#: Asymmetric per-roller scatter (all in clearance with the -0.004 mm below).
RADIUS_SCATTER = tuple(round(0.0015 * math.sin(1.7 * i), 6) for i in range(26))


def test_backlash_in_arcmin_against_hand_calculation(prototype, tmp_path):
    import json
    import subprocess
    import sys

    angles = [0.0, 3.7, 11.0]
    scene = tmp_path / "lm.toml"
    scene.write_text(
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        f"[solver]\ncrank_angles_deg = {angles}\n"
        "[errors]\nroller_radius_error = -0.004\n"
        f"roller_radius_errors = {list(RADIUS_SCATTER)}\n"
        "[checks]\nmax_backlash_arcmin = 100.0\n"
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    m = json.loads((tmp_path / "o" / "manifest.json").read_text())
    got = m["checks"]["max_backlash_arcmin"]["value"]
    err = ManufacturingErrors(roller_radius_error=-0.004, roller_radius_errors=RADIUS_SCATTER)
    want = max(_ref_backlash_arcmin(prototype, a * DEG, err) for a in angles)
    assert want > 0.1  # a real play, not a zero that any unit would match
    assert got == pytest.approx(want, rel=1e-6)


# --- Monte Carlo metrics equal a direct solve of the same sample --------------------


def test_montecarlo_metrics_equal_direct_solves(prototype):
    tol = {
        "cam_radius": Distribution("normal", 0.002),
        "eccentricity": Distribution("uniform", 0.003),
        "cam_phase": Distribution("normal", 0.02),  # deg
        "roller_radius": Distribution("normal", 0.001),
        "slot_angle": Distribution("uniform", 0.01),  # deg
    }
    n, seed, positions = 5, 7, 26
    mc = monte_carlo(prototype, M0, tol, n, seed, positions)
    units = draw_samples(tol, n, seed, prototype.roller_count)
    angles = 2 * math.pi * np.arange(positions) / positions
    gear_top = 0
    for k in range(n):
        err = ManufacturingErrors(
            cam_radius_error=0.002 * units["cam_radius"][k],
            eccentricity_error=0.003 * units["eccentricity"][k],
            cam_phase_error=0.02 * units["cam_phase"][k] * DEG,
            roller_radius_errors=tuple(0.001 * units["roller_radius"][k]),
            slot_angle_errors=tuple(0.01 * units["slot_angle"][k] * DEG),
        )
        res = solve_forces(prototype, M0, angles, errors=err)
        p = max(res.p_cam.max(), res.p_slot.max(), res.p_gear.max())
        gear_top += res.p_gear.max() > max(res.p_cam.max(), res.p_slot.max())
        assert mc.metrics["peak_pressure"][k] == pytest.approx(p, rel=1e-9)
        assert mc.metrics["peak_gear_force"][k] == pytest.approx(res.F_n.max(), rel=1e-9)
        assert mc.metrics["min_loaded_rollers"][k] == np.count_nonzero(res.F_j > 0, axis=1).min()
        lm = max(_ref_backlash_arcmin(prototype, a, err) for a in angles[:3])
        assert mc.metrics["backlash_arcmin"][k] >= lm - 1e-9
    assert gear_top >= 1  # the gear contact decides the peak in some samples


def test_montecarlo_cam_contact_counts_when_it_is_the_peak():
    # With a small eccentricity the tooth tips are blunt and the cam contact
    # carries the highest pressure: the Monte Carlo peak must follow it.
    design = GearDesign(eccentricity=1.0)
    tol = {"cam_radius": Distribution("uniform", 0.004)}
    mc = monte_carlo(design, M0, tol, 3, 3, 26)
    units = draw_samples(tol, 3, 3, design.roller_count)
    angles = 2 * math.pi * np.arange(26) / 26
    for k in range(3):
        err = ManufacturingErrors(cam_radius_error=0.004 * units["cam_radius"][k])
        res = solve_forces(design, M0, angles, errors=err)
        assert res.p_cam.max() > max(res.p_gear.max(), res.p_slot.max())
        assert mc.metrics["peak_pressure"][k] == pytest.approx(res.p_cam.max(), rel=1e-9)


# --- allocation with a "min" limit uses the lower percentile -------------------------


def test_allocation_min_loaded_rollers_uses_lower_percentile(prototype):
    checks = Checks(min_loaded_rollers=9)
    kw = {"samples": 30, "seed": 2, "positions": 26, "percentile": 95.0}
    out = allocate(prototype, M0, {}, checks, "roller_radius", **kw, rel_precision=0.05)
    T, fail = out["tolerance"], out["failing_at"]
    assert 0 < T < fail

    def p5(T):
        mc = monte_carlo(prototype, M0, {"roller_radius": Distribution("uniform", T)}, 30, 2, 26)
        return np.percentile(mc.metrics["min_loaded_rollers"], 5)

    assert p5(T) >= 9  # 95 % of the samples keep 9 rollers loaded at T...
    assert p5(fail) < 9  # ...and fewer than 95 % do at the next step


# --- forces on an allowed-undercut design ---------------------------------------------


@pytest.mark.slow
def test_trimmed_tips_carry_nothing(tmp_path):
    import csv
    import json
    import subprocess
    import sys

    scene = tmp_path / "u.toml"
    scene.write_text(
        "[design]\nroller_radius = 11.0\nallow_undercut = true\n"
        '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1.1e5\n'
        "[solver]\npositions = 260\n"
    )
    out = tmp_path / "o"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "manifest.json").read_text())
    limit = m["undercut"]["trimmed_psi_deg"]
    assert 150 < limit < 157
    rows = list(csv.DictReader((out / "forces.csv").open()))
    beyond = [
        row for row in rows if abs(math.remainder(float(row["psi_deg"]), 360.0)) > limit + 1e-9
    ]
    assert beyond and all(float(row["F_j"]) == 0.0 for row in beyond)
    p = max(float(row[c]) for row in rows for c in ("p_cam", "p_slot", "p_gear"))
    assert p == pytest.approx(1592, rel=2e-3)  # not the 13,228 MPa of an untrimmed tip
    assert m["forces"]["peak"]["pressure"]["value"] == pytest.approx(p, rel=1e-8)
    design = GearDesign(roller_radius=11.0, allow_undercut=True)
    for k in (0, 7):
        row_angle = k * 360.0 / 260
        F, _ = reference_position(design, M0, row_angle * DEG, psi_contact_limit=limit * DEG)
        got = [float(x["F_j"]) for x in rows[26 * k : 26 * k + 26]]
        assert float(rows[26 * k]["crank_angle_deg"]) == pytest.approx(row_angle, abs=1e-6)
        np.testing.assert_allclose(got, F, rtol=2e-7, atol=1e-6 * F.max())


# --- the full-cycle periodicity shortcut under every error kind ----------------------

ERROR_KINDS = {
    "none": ManufacturingErrors(),
    "cam_radius": ManufacturingErrors(cam_radius_error=0.004),
    "eccentricity": ManufacturingErrors(eccentricity_error=0.006),
    "roller_radius": ManufacturingErrors(roller_radius_error=-0.002),
    "roller_radius_each": ManufacturingErrors(
        roller_radius_errors=tuple(np.linspace(-0.003, 0.003, 26))
    ),
    "slot_angle": ManufacturingErrors(
        slot_angle_errors=tuple(np.radians(np.linspace(-0.01, 0.01, 26)))
    ),
    "slot_angle_uniform": ManufacturingErrors(slot_angle_errors=(1e-4,) * 26),
    "cam_phase": ManufacturingErrors(cam_phase_error=np.radians(0.03)),
    "profile": ManufacturingErrors(profile_deviation=harmonic_deviation([(2, 0.004, 30.0)])),
}


@pytest.mark.parametrize("kind", list(ERROR_KINDS))
def test_full_cycle_shortcut_equals_direct(prototype, kind):
    err = ERROR_KINDS[kind]
    full = solve_forces(prototype, M0, positions=52, errors=err)
    direct = solve_forces(prototype, M0, cycle_angles(52), errors=err)
    np.testing.assert_allclose(full.F_j, direct.F_j, rtol=1e-9, atol=1e-9 * direct.F_j.max())
    np.testing.assert_allclose(full.F_n, direct.F_n, rtol=1e-9, atol=1e-9 * direct.F_n.max())
    np.testing.assert_allclose(full.p_gear, direct.p_gear, rtol=1e-9, atol=1e-3)


# --- the contact law against the exact circle overlap --------------------------------

CURVATURES = [
    (1 / 8.0, 1 / 135.0),  # roller on cam: convex-convex
    (1 / 8.0, -1 / 60.0),  # roller in the tooth space: concave gear
    (1 / 8.0, -1 / 8.5),  # very conformal
    (1 / 8.0, 1 / 1.2),  # roller on a sharp tip
    (1 / 8.0, 0.0),  # slot wall: flat
]


@pytest.mark.parametrize("k1, k2", CURVATURES)
def test_approach_is_exact_circle_overlap_to_the_validity_knee(k1, k2):
    mpmath.mp.dps = 40
    kmax = max(abs(k1), abs(k2))
    frac = np.concatenate([np.geomspace(1e-8, 0.5, 40), np.linspace(0.5, 0.989, 60)])
    u = frac / kmax**2  # b^2 up to 0.989 of the limit b = R_min

    def sag(b2, k):
        if k == 0:
            return mpmath.mpf(0)
        R = 1 / mpmath.mpf(k)
        return mpmath.sign(R) * (abs(R) - mpmath.sqrt(R * R - b2))

    exact = np.array([float(sag(mpmath.mpf(x), k1) + sag(mpmath.mpf(x), k2)) for x in u])
    np.testing.assert_allclose(contact.approach(u, k1, k2), exact, rtol=1e-13)
    assert np.all(contact.is_valid(u, k1, k2))
    assert not contact.is_valid(1.0001 / kmax**2, k1, k2)


def test_half_width_and_pressure_by_hand():
    # Steel on steel, r = 8 on a flat, l = 12, F = 1000 N: E' = E / (2 (1 - nu^2)).
    Ep = 2.06e5 / (2 * (1 - 0.09))
    b2 = 4 * 1000 * 8.0 / (math.pi * 12 * Ep)
    assert contact.half_width_sq_per_force(1 / 8.0, 0.0, 12.0, Ep) * 1000 == pytest.approx(b2)
    p = 2 * 1000 / (math.pi * math.sqrt(b2) * 12)
    assert contact.max_pressure(1000.0, b2 / 1000, 12.0) == pytest.approx(p, rel=1e-14)


# --- the roller collision limit against brute-force placed centres ------------------


def _closest_centres_brute(z, e, Rj, r, n=20000):
    L = Rj + r
    R = z + 1
    out = math.inf
    for phi in np.linspace(0, 2 * math.pi / R, n // R + 2):  # one pitch is enough
        o1 = e * np.array([math.sin(phi), math.cos(phi)])
        th = np.arange(R) * 2 * math.pi / R
        u = np.stack([np.sin(th), np.cos(th)], axis=1)
        # |s u - o1| = L on the slot line: s = u.o1 + sqrt((u.o1)^2 - |o1|^2 + L^2)
        uo = u @ o1
        s = uo + np.sqrt(uo * uo - o1 @ o1 + L * L)
        h = s[:, None] * u
        out = min(out, float(np.min(np.hypot(*(h - np.roll(h, -1, axis=0)).T))))
    return out


@pytest.mark.parametrize("z, e, Rj", [(100, 1.0, 50.0), (60, 2.0, 60.0), (25, 3.5, 135.0)])
def test_collision_limit_against_placed_centres(z, e, Rj):
    def design(r):
        return GearDesign(
            tooth_count=z, eccentricity=e, cam_radius=Rj, roller_radius=r, allow_undercut=True
        )

    # The limit depends on r through L = Rj + r: r* = d_min(r*) / 2, by bisection.
    lo, hi = 1e-3, Rj
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if 2 * mid < _closest_centres_brute(z, e, Rj, mid, 4000):
            lo = mid
        else:
            hi = mid
    r = 0.5 * lo
    assert design(r).min_roller_centre_distance == pytest.approx(
        _closest_centres_brute(z, e, Rj, r), rel=1e-6
    )
    # Just above the brute-force limit the design is refused. (Just below it the
    # slotted frame's webs, checked since, are already too thin, so acceptance
    # there is not the collision rule's to give.)
    with pytest.raises(DesignError, match="collide|frame slots"):
        design(hi * 1.001)


# --- the reference itself: independent of the package, and right ------------------


def test_reference_imports_nothing_from_the_package():
    import ast
    import inspect

    import corr_cad.mechanics.reference as ref

    tree = ast.parse(inspect.getsource(ref))
    mods = {
        (n.module or "") if isinstance(n, ast.ImportFrom) else a.name
        for n in ast.walk(tree)
        if isinstance(n, (ast.Import, ast.ImportFrom))
        for a in n.names
    }
    assert all(not m.startswith((".", "corr_cad")) and m for m in mods), mods
    assert not any(isinstance(n, ast.ImportFrom) and n.level > 0 for n in ast.walk(tree))


def test_reference_locus_is_the_closed_form(prototype):
    z, e, L = 25, 3.5, 143.0
    for t in np.linspace(0, 2 * math.pi, 37):
        g = reference_geometry(prototype, t * z, None)[0]  # crank angle z t: roller 1 at t
        psi = z * t
        s = e * math.cos(psi) + math.sqrt(L * L - e * e * math.sin(psi) ** 2)
        assert g["centre"][0] == pytest.approx(s * math.sin(t), abs=1e-10)
        assert g["centre"][1] == pytest.approx(s * math.cos(t), abs=1e-10)


def test_undercut_threshold_is_where_the_working_radius_vanishes():
    # At the admissible radius the reference's working-profile curvature at the
    # tip (psi = pi) is infinite: 1 + r k_locus = 0 there.
    d = GearDesign(tooth_count=39, cam_radius=150.0, eccentricity=3.0, roller_radius=5.0)
    r_adm = undercut_analysis(d).admissible_roller_radius
    from corr_cad.mechanics.reference import locus_frame

    k = locus_frame(math.pi / 39, 39, 3.0, 150.0 + r_adm)["curvature"]
    assert 1 + r_adm * k == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("dr", [0.0, 0.001], ids=["clearance", "preloaded"])
def test_montecarlo_on_trimmed_tips_equals_direct_solve(dr):
    """Also with 1 um oversize rollers: every gap is closed, so a roller on a trimmed tip
    would carry load unless the compiled kernel's inputs mask it as not loadable."""
    design = GearDesign(roller_radius=11.0, allow_undercut=True)
    limit = math.radians(undercut_analysis(design).trimmed_psi_deg)
    tol = {"eccentricity": Distribution("uniform", 0.0002)}
    base = ManufacturingErrors(roller_radius_error=dr)
    kw = {"psi_contact_limit": limit, "base_errors": base}
    mc = monte_carlo(design, M0, tol, 2, 4, 52, **kw)
    compiled = monte_carlo(design, M0, tol, 2, 4, 52, kernel=True, **kw)  # numba's inputs
    for name, v in mc.metrics.items():
        np.testing.assert_allclose(compiled.metrics[name], v, rtol=1e-9, err_msg=name)
    units = draw_samples(tol, 2, 4, design.roller_count)
    angles = 2 * math.pi * np.arange(52) / 52
    for k in range(2):
        err = ManufacturingErrors(
            eccentricity_error=0.0002 * units["eccentricity"][k], roller_radius_error=dr
        )
        res = solve_forces(design, M0, angles, errors=err, psi_contact_limit=limit)
        p = max(res.p_cam.max(), res.p_slot.max(), res.p_gear.max())
        assert mc.metrics["peak_pressure"][k] == pytest.approx(p, rel=1e-9)
        assert mc.metrics["peak_gear_force"][k] == pytest.approx(res.F_n.max(), rel=1e-9)
        if dr == 0.0:
            assert p < 1800  # the untrimmed tip would give ~2200 MPa here


def test_allocation_keeps_the_scenes_errors(prototype):
    # A +0.02 mm cam preloads every roller (F_n ~ 21,000 N): no tolerance keeps 5000 N.
    checks = Checks(max_gear_force=5000.0)
    kw = {"samples": 10, "seed": 2, "positions": 26}
    base = ManufacturingErrors(cam_radius_error=0.02)
    out = allocate(prototype, M0, {}, checks, "eccentricity", base_errors=base, **kw)
    assert out["tolerance"] == 0.0 and out["failing_at"] == 0.0
