"""The drive's Monte Carlo datasheet metrics (``[solver] model = "drive"``): lost motion,
rigidity, transmission error and binding of both rows together.

Expected values come from the drive's datasheet (:func:`corr_cad.mechanics.datasheet.datasheet`
with the numpy :class:`~corr_cad.mechanics.drive.drive_windup.DriveWindup`, not the compiled
solver the Monte Carlo uses), from the paper's compiled kernel at load share 0.5 (the
limiting case), from Hertz's line-contact pressure written out here, or from the real CLI.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import pathlib
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors as ME
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.tolerance.mc_datasheet import DatasheetMC
from corr_cad.tolerance.mc_drive_datasheet import drive_datasheet_samples, drive_grid
from corr_cad.tolerance.montecarlo import Distribution, monte_carlo

ROOT = pathlib.Path(__file__).resolve().parents[1]
DESIGN = GearDesign()
T_R = 2.86e6  # N*mm
M0 = T_R / 26
ARCMIN = 60.0 * 180.0 / math.pi  # written out
ARCSEC = 60.0 * ARCMIN
NEEDLES = EccentricBearing(40, 6.0, 12.0)
#: Row B's rollers differ one from the next: a tooth pitch of positions.
WAVY = tuple(0.001 * np.sin(np.arange(26)))


def _spec(series=None, levels=3):
    return DatasheetSpec(
        rated_torque=T_R,
        positions_per_mesh=1,
        transmission_error_positions_per_turn=4,
        series_rigidity_Nm_per_arcmin=series,
        torque_levels=levels,
    )


def _metrics_of(ds):
    """The Monte Carlo's columns read off a datasheet on its own positions."""
    te = max(np.ptp(ds.at(0.03)), np.ptp(ds.at(-0.03))) * ARCSEC
    return {
        "lost_motion_arcmin": float(ds.lost_motion().max() * ARCMIN),
        "torsional_rigidity_Nm_per_arcmin": float(ds.rigidity().min()),
        "transmission_error_arcsec": float(te),
    }


@pytest.mark.parametrize(
    "law,bearing",
    [("nonlinear", None), ("nonlinear", NEEDLES), ("palmgren", None), ("palmgren", NEEDLES)],
)
def test_the_nominal_sample_equals_the_drive_datasheet_on_the_same_positions(law, bearing):
    """No tolerance: every sample is the scene's drive (row A 2 um small rollers, row B its
    own wavy rollers, a series rigidity), and its lost motion, rigidity and transmission error
    are the drive datasheet's on the same grid (one tooth pitch, 1 position a mesh period)."""
    ea, eb = ME(roller_radius_error=-0.002), ME(roller_radius_errors=WAVY)
    spec = _spec(series=800.0)
    drive = {"errors_b": eb, "bearing": bearing, "bearing_b": bearing}
    ds = datasheet(DESIGN, spec, errors=ea, contact_model=law, drive=drive)
    want = _metrics_of(ds)
    cfg = DatasheetMC(spec, positions_per_mesh=1)
    mc = monte_carlo(
        DESIGN,
        M0,
        {},
        2,
        1,
        12,
        base_errors=ea,
        datasheet=cfg,
        drive={**drive, "contact_model": law},
    )
    assert mc.success
    grid = drive_grid(DESIGN, ea, eb, (), 1)
    np.testing.assert_array_equal(grid, ds.output_angles)  # 26 positions: a tooth pitch
    assert len(grid) == 26
    for k in range(2):
        for name in ("lost_motion_arcmin", "torsional_rigidity_Nm_per_arcmin"):
            assert mc.metrics[name][k] == pytest.approx(want[name], rel=1e-9), name
        te = mc.metrics["transmission_error_arcsec"][k]
        assert te == pytest.approx(want["transmission_error_arcsec"], rel=1e-7, abs=1e-9)
    assert 0.1 < want["lost_motion_arcmin"] and want["torsional_rigidity_Nm_per_arcmin"] < 800.0


def test_identical_rigid_rows_equal_the_paper_row_at_load_share_one_half():
    """Both rows alike (undersize rollers, a cam radius error), cams fixed: the drive's rows
    share the moment exactly half and half (z + 1 even), so its lost motion and rigidity are
    the paper row's at load_share 0.5, solved by the paper's compiled kernel."""
    from corr_cad.tolerance.mc_datasheet import datasheet_chunk, grid_positions

    err = ME(cam_radius_error=0.001, roller_radius_error=-0.002)
    cfg = DatasheetMC(_spec(), positions_per_mesh=3)
    grid = grid_positions(DESIGN, err, (), 3)
    drive = {"bearing": None, "contact_model": "nonlinear"}
    got, ok = drive_datasheet_samples(DESIGN, [(err, err)], cfg, grid, math.pi, drive)
    R = DESIGN.roller_count
    arrays = (
        np.array([0.001]),
        np.zeros(1),
        np.zeros(1),
        np.full((1, R), -0.002),
        np.zeros((1, R)),
    )
    paper, ok_p = datasheet_chunk(DESIGN, arrays, 1, cfg, grid, 0.5, math.pi, err)
    assert ok and ok_p
    for name in ("lost_motion_arcmin", "torsional_rigidity_Nm_per_arcmin"):
        assert got[name][0] == pytest.approx(paper[name][0], rel=1e-9), name
    assert got["transmission_error_arcsec"][0] == pytest.approx(
        paper["transmission_error_arcsec"][0], rel=1e-6, abs=1e-9
    )
    assert got["binding_pressure_MPa"][0] == 0.0 == paper["binding_pressure_MPa"][0]


def _pairs(n, dr, fit, seed=5):
    rng = np.random.default_rng(seed)
    R = DESIGN.roller_count

    def errors():
        return ME(
            cam_radius_error=float(rng.normal(0.0, 0.001)),
            eccentricity_error=float(rng.normal(0.0, 0.001)),
            roller_radius_errors=tuple(rng.normal(dr, 0.001, R)),
            slot_angle_errors=tuple(rng.normal(0.0, 1e-5, R)),
            cam_phase_error=math.radians(float(rng.normal(0.0, 0.005))),
            slot_clearance=fit,
        )

    return [(errors(), errors()) for _ in range(n)]


@pytest.mark.parametrize(
    "bearing,dr,fit,rigidity",
    [
        (None, -0.001, 0.002, (0.0, 1.0)),  # preloaded samples; theta(0+-) at the free ends
        (NEEDLES, -0.001, 0.002, (0.5, 1.0)),  # preloaded samples on needles
        (replace(NEEDLES, diametral_clearance=0.003), -0.004, 0.004, (0.0, 1.0)),
    ],
)
def test_a_sample_in_a_block_equals_the_sample_solved_alone(bearing, dr, fit, rigidity):
    """Four samples with every error kind, each equal to its own solve bit for bit: rigid
    cams with preloaded samples and the free ends read as theta(0+-) (rigidity from 0), the
    same on needles, and needles with a clearance in a drive with play."""
    spec = replace(_spec(), rigidity_range=rigidity)
    cfg = DatasheetMC(spec, positions_per_mesh=1)
    grid = drive_grid(DESIGN, ME(), None, ("roller_radius",), 1)
    drive = {"bearing": bearing, "contact_model": "nonlinear"}
    pairs = _pairs(4, dr, fit)
    block, ok = drive_datasheet_samples(DESIGN, pairs, cfg, grid, math.pi, drive)
    assert ok
    for k, pair in enumerate(pairs):
        alone, _ = drive_datasheet_samples(DESIGN, [pair], cfg, grid, math.pi, drive)
        for name, v in alone.items():
            assert block[name][k] == v[0], (name, k)
    assert np.ptp(block["lost_motion_arcmin"]) > 0
    if dr > -0.002:
        assert np.all(block["binding_pressure_MPa"] > 0)


def _hertz(F, k1, k2, length, E):
    """Line contact's peak pressure ``p = sqrt(F E' (k1 + k2) / (pi l))`` (Hertz), MPa;
    ``E'`` the contact modulus ``E / (2 (1 - nu^2))``."""
    return np.sqrt(np.maximum(F, 0.0) * E * (k1 + k2) / (math.pi * length))


@pytest.mark.parametrize("bearing", [None, NEEDLES])
def test_binding_is_the_zero_moment_preload_pressure_of_both_rows(bearing):
    """Row B's rollers 3 um oversize in slots without clearance: at zero crank moment the
    rows hold a preload. The sample's binding pressure is the largest Hertz pressure (written
    out) of the cam, ring and slot contacts of the numpy drive solver's forces there; the
    crank moment of those forces is zero."""
    ea, eb = ME(roller_radius_error=-0.002), ME(roller_radius_error=0.003)
    cfg = DatasheetMC(_spec(), binding_pressure_MPa=1500.0, positions_per_mesh=2)
    grid = drive_grid(DESIGN, ea, eb, (), 2)
    drive = {"bearing": bearing, "contact_model": "nonlinear"}
    got, ok = drive_datasheet_samples(DESIGN, [(ea, eb)], cfg, grid, math.pi, drive)
    assert ok
    solver = DriveSolver(DESIGN, DESIGN.tooth_count * grid, errors=ea, errors_b=eb, bearing=bearing)
    res = solver.result(0.0)
    assert res.success
    length, E = DESIGN.roller_length, DESIGN.material.contact_modulus
    peak = 0.0
    for row, g in zip(res.rows, solver.geo, strict=True):
        Fj = row.F_j
        p_cam = _hertz(Fj, g.k_roller, g.k_cam, length, E)
        p_ring = _hertz(g.rho_n * Fj, g.k_roller, g.k_gear, length, E)
        p_slot = _hertz(np.abs(g.rho_s) * Fj, g.k_roller, 0.0, length, E)
        peak = max(peak, float(np.max(np.maximum(np.maximum(p_cam, p_ring), p_slot))))
    arm = np.where(solver.geo_joined.loadable, solver.geo_joined.arm, 0.0)
    F = np.concatenate([r.F_j for r in res.rows], axis=1)
    assert np.all(np.abs(np.sum(arm * F, axis=1)) <= 1e-9 * np.sum(np.abs(arm * F), axis=1))
    assert peak > 1500.0  # a real preload, above the limit given
    assert got["binding_pressure_MPa"][0] == pytest.approx(peak, rel=1e-6)
    assert got["binds"][0] == 1.0
    # A clearance in both rows: nothing presses at zero moment.
    free, _ = drive_datasheet_samples(DESIGN, [(ea, ea)], cfg, grid, math.pi, drive)
    assert free["binding_pressure_MPa"][0] == 0.0 and free["binds"][0] == 0.0


@pytest.mark.parametrize("law", ["palmgren", "nonlinear"])
def test_rows_that_just_touch_press_nothing(law):
    """Row B's rollers 1 um small and cam A's phase 0.003 deg off: at some grid positions
    the rigid rows' free intervals just meet, and the zero-moment solve leaves the rollers
    there forces below the solver's idle force (1e-9 N against kilonewtons under load:
    round-off of zero, 1e-236 N under Palmgren's law, 6.5e-118 MPa as a Hertz pressure).
    They touch without load: the binding pressure is 0, cams fixed or on needles."""
    from corr_cad.mechanics.drive.drive import _IDLE_FORCE

    ea, eb = ME(cam_phase_error=math.radians(0.003)), ME(roller_radius_error=-0.001)
    cfg = DatasheetMC(_spec(), positions_per_mesh=2)
    grid = drive_grid(DESIGN, ea, eb, (), 2)
    for bearing in (None, NEEDLES, replace(NEEDLES, diametral_clearance=0.005)):
        drive = {"bearing": bearing, "contact_model": law}
        got, ok = drive_datasheet_samples(DESIGN, [(ea, eb)], cfg, grid, math.pi, drive)
        assert ok
        assert got["binding_pressure_MPa"][0] == 0.0 and got["binds"][0] == 0.0, bearing
    solver = DriveSolver(DESIGN, DESIGN.tooth_count * grid, errors=ea, errors_b=eb)
    geo = solver.geo_joined
    a = np.where(geo.loadable, geo.advance, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(geo.loadable, -geo.gap, np.inf) / a
    touching = np.min(np.where(a > 0, t, np.inf), axis=1) <= np.max(
        np.where(a < 0, t, -np.inf), axis=1
    )
    assert touching.any()  # the case: positions whose zero-moment equilibrium is solved
    F = solver.solve(0.0)[1][touching]
    assert 0.0 < F.max() <= _IDLE_FORCE


def test_monte_carlo_with_the_datasheet_metrics_is_independent_of_chunking():
    tol = {
        "roller_radius": Distribution("normal", 0.001),
        "cam_phase": Distribution("normal", 0.005),
        "slot_clearance": Distribution("uniform", 0.002),
    }
    cfg = DatasheetMC(_spec(), positions_per_mesh=1)
    drive = {"bearing": NEEDLES, "contact_model": "nonlinear"}
    base = ME(roller_radius_error=-0.001)
    one = monte_carlo(DESIGN, M0, tol, 4, 3, 12, base_errors=base, datasheet=cfg, drive=drive)
    two = monte_carlo(
        DESIGN, M0, tol, 4, 3, 12, base_errors=base, datasheet=cfg, drive=drive, chunk=1
    )
    assert one.success
    assert {"lost_motion_arcmin", "binds", "peak_gear_force"} <= set(one.metrics)
    for name, v in one.metrics.items():
        np.testing.assert_array_equal(v, two.metrics[name])


SCENE = """
[export]
formats = ["montecarlo"]
[load]
input_torque = 1.1e5
[solver]
model = "drive"
positions = 12
[errors]
roller_radius_error = -0.002
[errors.row_b]
roller_radius_error = -0.001
[bearings.eccentric]
needles = 40
needle_diameter = 6.0
needle_length = 12.0
[tolerances]
roller_radius = {{ normal = 0.001 }}
[montecarlo]
samples = 6
positions = 12
datasheet_positions_per_mesh = 1
[datasheet]
series_rigidity_Nm_per_arcmin = 1000.0
[checks]
max_lost_motion_arcmin = 1.0
min_torsional_rigidity_Nm_per_arcmin = {rigidity}
max_failure_probability = 0.0
max_binding_probability = 0.5
"""


def _run(folder: pathlib.Path, text: str, hashseed: str):
    folder.mkdir()
    (folder / "s.toml").write_text(text)
    env = {**os.environ, "PYTHONHASHSEED": hashseed}
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out"],
        cwd=folder,
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )


@pytest.mark.slow
def test_drive_gates_on_the_datasheet_metrics_through_the_cli(tmp_path):
    """The real CLI on a drive scene with needle bearings: the datasheet metrics are columns
    of montecarlo.csv, the summary states the model and its binding, a rigidity gate above
    every sample fails with exit 1, and the bytes do not depend on the hash seed."""
    a = _run(tmp_path / "a", SCENE.format(rigidity=100.0), "0")
    assert a.returncode == 0, a.stderr[-3000:]
    out = tmp_path / "a" / "out"
    with open(out / "montecarlo.csv") as f:
        header = f.readline().strip().split(",")
    assert header == [
        "sample",
        "roller_radius_magnitude",
        "roller_radius_row_b_magnitude",
        "peak_gear_force",
        "peak_pressure",
        "min_loaded_rollers",
        "backlash_arcmin",
        "lost_motion_arcmin",
        "torsional_rigidity_Nm_per_arcmin",
        "transmission_error_arcsec",
        "binding_pressure_MPa",
        "binds",
    ]
    rows = np.genfromtxt(out / "montecarlo.csv", delimiter=",", names=True)
    summary = json.loads((out / "montecarlo_summary.json").read_text())
    assert (
        summary["model"]["model"] == "drive"
        and "zero crank moment" in (summary["model"]["binding"])
    )
    assert summary["model"]["bearing"]["needles"] == 40
    k = rows["torsional_rigidity_Nm_per_arcmin"]
    assert np.all((100.0 < k) & (k < 1000.0))  # series-limited, above the gate
    assert summary["failure_probability"]["min_torsional_rigidity_Nm_per_arcmin"] == 0.0
    assert set(summary["nominal"]) >= {"lost_motion_arcmin", "binds"}
    # The same scene under another hash seed: the same bytes.
    b = _run(tmp_path / "b", SCENE.format(rigidity=100.0), "12345")
    assert b.returncode == 0, b.stderr[-3000:]
    for name in ("montecarlo.csv", "montecarlo_summary.json", "montecarlo.png"):
        one = hashlib.sha256((out / name).read_bytes()).hexdigest()
        two = hashlib.sha256((tmp_path / "b" / "out" / name).read_bytes()).hexdigest()
        assert one == two, name
    # A rigidity gate above every sample: the gate fails, exit 1.
    c = _run(tmp_path / "c", SCENE.format(rigidity=float(k.max()) * 1.5), "0")
    assert c.returncode == 1, c.stderr[-3000:]
    assert "min_torsional_rigidity_Nm_per_arcmin" in c.stderr
    m = json.loads((tmp_path / "c" / "out" / "manifest.json").read_text())
    gate = m["checks"]["montecarlo"]["min_torsional_rigidity_Nm_per_arcmin"]
    assert gate["probability"] == 1.0 and not gate["passed"]


def _one_position(pairs, k, p, grid, bearing, cls=DriveSolver):
    from corr_cad.tolerance.montecarlo_drive import stacked_geometry

    phi = DESIGN.tooth_count * grid[p : p + 1]
    geo = stacked_geometry(DESIGN, phi, [pairs[k]], math.pi)
    return cls(DESIGN, phi, geometry=geo, bearing=bearing)


@pytest.mark.parametrize("compiled", [False, True])
def test_a_cam_that_unloads_on_its_needles_settles(compiled):
    """Row A's rollers load cam A at the rigid start but leave it at the equilibrium (-3 % of
    T_R): cam A then sinks back into its needles, whose Palmgren law has no stiffness at no
    load, so Newton nears u = 0 only linearly and cam A's force balance never met its own
    (vanishing) scale. Measured against the loaded cam's forces it settles: the moment is
    M0 and each cam's needles carry its rollers' resultant."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver

    grid = drive_grid(DESIGN, ME(), None, ("roller_radius",), 1)
    cls = CompiledDriveSolver if compiled else DriveSolver
    solver = _one_position(_pairs(4, -0.003, 0.002, 7), 2, 19, grid, NEEDLES, cls)
    M = 0.03 * T_R / 26
    res = solver.result(M)
    assert res.success, res.message
    arm = np.where(solver.geo_joined.loadable, solver.geo_joined.arm, 0.0)
    F = np.concatenate([r.F_j for r in res.rows], axis=1)
    assert np.sum(arm * F) == pytest.approx(M, rel=1e-9)
    Z = NEEDLES.needles
    ang = 2.0 * np.pi * np.arange(Z) / Z
    for c in (0, 1):
        q = res.needle_loads[c]
        resultant = np.hypot(q @ np.cos(ang), q @ np.sin(ang))
        # against the loaded cam's forces: the unloaded cam keeps their round-off
        top = 1e-9 * res.bearing_load.max()
        np.testing.assert_allclose(resultant, res.bearing_load[c], rtol=1e-9, atol=top)
    assert res.bearing_load[0, 0] < 1e-6 < res.bearing_load[1, 0]  # cam A unloaded


@pytest.mark.parametrize("law", ["nonlinear", "palmgren"])
def test_positions_once_missed_from_the_rigid_start_settle_there(law):
    """Needles with a clearance, a drive with play, +-3 % of T_R: from the rigid start the
    residual's line search finds no descent at some positions (both cams adrift in their
    clearances); the energy's line search settles them there. Every moment reaches
    equilibrium (moment M0, each cam's needles carrying its rollers' resultant), and
    :func:`_solve_all` (each sign's largest moment from the rigid start, its smallest
    from that solution scaled, the one between from both interpolated) gives the rigid
    start's equilibrium at every moment, under either contact law."""
    from corr_cad.tolerance.mc_drive_datasheet import _solve_all

    solver, moments, bearing = _play_drive(law)
    first = {k: solver.solve(m) for k, m in moments.items()}
    assert all(np.all(s[4] <= 1e-9) for s in first.values())
    sols, ok = _solve_all(solver, moments)
    assert ok
    arm = np.where(solver.geo_joined.loadable, solver.geo_joined.arm, 0.0)
    Z = bearing.needles
    ang = 2.0 * np.pi * np.arange(Z) / Z
    for k, m in moments.items():
        res = solver._build(m, *sols[k])
        F = np.concatenate([r.F_j for r in res.rows], axis=1)
        np.testing.assert_allclose(np.sum(arm * F, axis=1), m, rtol=1e-9)
        for c in (0, 1):
            q = res.needle_loads[c]
            resultant = np.hypot(q @ np.cos(ang), q @ np.sin(ang))
            np.testing.assert_allclose(resultant, res.bearing_load[c], rtol=1e-9, atol=1e-6)
        # The larger moments start from the smaller one's solution: the solver's tolerance apart.
        np.testing.assert_allclose(sols[k][0], first[k][0], rtol=1e-9)


def test_positions_cut_short_are_solved_again_from_another_moment():
    """A Newton cut to one iteration from the rigid start leaves positions unsettled;
    :func:`restart_missed` solves them again from their own solution at another moment,
    which reaches the full solve's equilibrium (unique: the contacts' energy is convex)."""
    from corr_cad.mechanics.drive.drive_restart import restart_missed
    from corr_cad.mechanics.row.solver_numerics import _solve_positions

    solver, moments, _ = _play_drive()
    m = moments[0]
    tau, F, *_ = _solve_positions(solver.geo_joined, solver.comp, m, solver.rtol)
    cut = solver._with_bearings(m, tau, F, 0, max_iter=1)
    missed = np.flatnonzero(~(cut[4] <= 1e-9))
    assert missed.size  # the case restarts are for
    got = restart_missed(solver, m, cut, [solver.solve(moments[2])])
    full = solver.solve(m)
    assert np.all(got[4] <= 1e-9)
    np.testing.assert_allclose(got[0], full[0], rtol=1e-9)
    np.testing.assert_allclose(got[1], full[1], rtol=0, atol=1e-9 * full[1].max())


@pytest.mark.parametrize("clearance", [0.0, 0.004])
def test_the_linear_start_gives_the_rigid_start_s_metrics(monkeypatch, clearance):
    """The datasheet pass starts each sign's first bearing Newton from the exact
    linear-contact solution: the samples' metrics are the rigid start's to 1e-9, with and
    without a bearing clearance (where both cams may start adrift in their clearances)."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver
    from corr_cad.tolerance import mc_drive_datasheet as mdd

    cfg = DatasheetMC(_spec(), positions_per_mesh=2)
    grid = drive_grid(DESIGN, ME(), None, ("roller_radius",), 2)
    bearing = replace(NEEDLES, diametral_clearance=clearance)
    drive = {"bearing": bearing, "contact_model": "nonlinear"}
    pairs = _pairs(3, -0.001, 0.0)
    linear, ok = drive_datasheet_samples(DESIGN, pairs, cfg, grid, math.pi, drive)
    assert ok
    monkeypatch.setattr(mdd, "_linear_start_solver", lambda: CompiledDriveSolver)
    rigid, ok = drive_datasheet_samples(DESIGN, pairs, cfg, grid, math.pi, drive)
    assert ok
    for name, v in rigid.items():
        np.testing.assert_allclose(linear[name], v, rtol=1e-9, atol=1e-12, err_msg=name)


def _play_drive(law: str = "nonlinear"):
    """The compiled drive of four roller-radius samples with play, needles with a 3 um
    clearance, and moments of +-3 %, +-50 % and +-25 % of T_R."""
    from corr_cad.mechanics.drive.drive_kernel import CompiledDriveSolver
    from corr_cad.tolerance.montecarlo_drive import stacked_geometry

    bearing = replace(NEEDLES, diametral_clearance=0.003)
    grid = drive_grid(DESIGN, ME(), None, ("roller_radius",), 1)
    phi = DESIGN.tooth_count * grid
    pairs = _pairs(4, -0.004, 0.004)
    geo = stacked_geometry(DESIGN, phi, pairs, math.pi)
    solver = CompiledDriveSolver(
        DESIGN, np.tile(phi, 4), geometry=geo, bearing=bearing, contact_model=law
    )
    moments = {0: 0.03 * T_R / 26, 1: -0.03 * T_R / 26, 2: 0.5 * T_R / 26, 3: -0.5 * T_R / 26}
    moments.update({4: 0.25 * T_R / 26, 5: -0.25 * T_R / 26})
    return solver, moments, bearing


@pytest.mark.slow
def test_the_drive_datasheet_on_needles_settles_every_torque_level():
    """Row A 2 um and row B 1 um small rollers on needles: at -35 % of T_R the start's cam
    shift unloads every roller, and the residual's line search finds no descent from the
    rigid start; the energy's line search settles it there, and every level settles.
    The curve rises with the torque and its rigidity sits below the series rigidity."""
    from corr_cad.mechanics.drive.drive_windup import DriveWindup
    from corr_cad.mechanics.row.windup import crank_angles_of

    ea, eb = ME(roller_radius_error=-0.002), ME(roller_radius_error=-0.001)
    x = (2 * math.pi / (25 * 26)) * np.arange(4) / 4
    first = DriveSolver(DESIGN, crank_angles_of(x, DESIGN), errors=ea, errors_b=eb, bearing=NEEDLES)
    assert np.all(first.solve(-0.35 * T_R / 26)[4] <= 1e-9)
    spec = replace(_spec(series=1000.0, levels=41), positions_per_mesh=4)
    ds = datasheet(DESIGN, spec, errors=ea, drive={"errors_b": eb, "bearing": NEEDLES})
    assert np.all(np.diff(ds.windup, axis=0) > 0)
    assert 500.0 < ds.rigidity().min() < 1000.0
    # Restarted from -30 % or from -40 % of T_R: the same (unique) equilibrium.
    got = []
    for before in (-0.3, -0.4):
        w = DriveWindup(DESIGN, x, errors=ea, errors_b=eb, bearing=NEEDLES)
        w.theta(before * T_R)
        got.append(w.theta(-0.35 * T_R))
    np.testing.assert_allclose(got[0], got[1], rtol=1e-9)
    np.testing.assert_allclose(got[0], ds.at(-0.35, contact_only=True)[:4], rtol=1e-9)


def test_the_estimate_counts_the_drive_s_datasheet_pass_over_row_b_s_span():
    """Under the drive the Monte Carlo's estimate counts its datasheet pass at the drive's
    cost a cell (more with bearings) over the span of the row that repeats last (row B's
    own rollers: a tooth pitch even with no tolerance on them)."""
    from corr_cad.run.budget.costs_montecarlo import DRIVE_DATASHEET_SECONDS, datasheet_pass
    from corr_cad.run.scene.scene import parse_scene

    base = {
        "export": {"formats": ["montecarlo"]},
        "load": {"input_torque": 1.1e5},
        "tolerances": {"cam_radius": {"normal": 0.001}},
        "checks": {"max_lost_motion_arcmin": 1.0},
        "montecarlo": {"samples": 1000},
    }
    rr = [0.001 * math.sin(k) for k in range(26)]
    drive = {"solver": {"model": "drive"}, "errors": {"row_b": {"roller_radius_errors": rr}}}
    bearing = {"bearings": {"eccentric": {"needles": 40, "needle_diameter": 6.0}}}
    bearing["bearings"]["eccentric"]["needle_length"] = 12.0
    s_paper, g_paper = datasheet_pass(parse_scene(base), 1000, 2)
    s_rigid, g_rigid = datasheet_pass(parse_scene({**base, **drive}), 1000, 2)
    s_needles, _ = datasheet_pass(parse_scene({**base, **drive, **bearing}), 1000, 2)
    assert g_paper == 4 and g_rigid == 4 * 26  # a mesh period; row B's tooth pitch
    per = (s_rigid - 1.0) / (1000 * g_rigid * 26 / 2)
    law = DRIVE_DATASHEET_SECONDS["nonlinear"]  # the paper's contact law
    assert per == pytest.approx(law[0], rel=1e-12)
    assert s_needles - 1.0 == pytest.approx((s_rigid - 1.0) * law[1] / law[0])
    assert (s_rigid - 1.0) > 26 * (s_paper - 8.0)


def test_allocation_on_the_drive_gates_transmission_error():
    """Allocation on the drive on the transmission error (its scatter grows with the rollers'
    scatter): a tighter limit allots a tighter roller tolerance, and the allotted one keeps
    the limit at the percentile (a direct Monte Carlo with the same draws)."""
    from corr_cad.tolerance.allocation import allocate
    from corr_cad.tolerance.checks import Checks

    cfg = DatasheetMC(_spec(), positions_per_mesh=1)
    kw = {
        "samples": 6,
        "positions": 12,
        "datasheet": cfg,
        "drive": {"bearing": None, "contact_model": "nonlinear"},
        "base_errors": ME(roller_radius_error=-0.002),
    }
    got = {}
    for limit in (2.0, 4.0):
        checks = Checks(max_transmission_error_arcsec=limit)
        got[limit] = allocate(DESIGN, M0, {}, checks, "roller_radius", **kw)
    assert 0 < got[2.0]["tolerance"] < got[4.0]["tolerance"] < 0.002
    for T, ok in ((got[2.0]["tolerance"], True), (got[2.0]["failing_at"], False)):
        mc = monte_carlo(
            DESIGN,
            M0,
            {"roller_radius": Distribution("uniform", T)},
            6,
            1,
            12,
            base_errors=kw["base_errors"],
            datasheet=cfg,
            drive=kw["drive"],
        )
        assert (np.percentile(mc.metrics["transmission_error_arcsec"], 95) <= 2.0) == ok
