"""The crankshaft and the elastic bodies in one solve (``[crankshaft]`` with ``[solver]
bodies = "elastic"``): each part alone in its limit, an independent solve of the joint
equations, the compliance budget with every component, the CLI."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import fsolve

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.geometry.parts import part_outlines
from corr_cad.geometry.profile import working_profile
from corr_cad.mechanics import palmgren
from corr_cad.mechanics.bodies.reduction import MeshSpec, reduce_bodies
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.crank.crankshaft import Crankshaft
from corr_cad.mechanics.crank.support_bearing import SupportBearing
from corr_cad.mechanics.drive.drive import DriveSolver
from corr_cad.mechanics.drive.drive_crank import CrankSupport, budget_terms

SMALL = GearDesign(tooth_count=9, cam_radius=45.0, roller_radius=4.0, eccentricity=1.5)
COARSE = MeshSpec(fine=0.25, grade=0.5, coarse=1.0, spacing=0.25)
ANGLES = np.radians(np.arange(0.0, 40.0, 8.0))
M0 = -2.0e4
NEEDLES = EccentricBearing(24, 3.0, 8.0, 0.004)
E = 2.06e5


@pytest.fixture(scope="module")
def tables():
    o = part_outlines(SMALL, working_profile(SMALL), 0.01)
    return reduce_bodies(SMALL, o, COARSE)


def crank(scale: float = 1.0, clearance: float = 0.003) -> CrankSupport:
    """A shaft of 20 mm on cylindrical roller supports (``scale``: every compliance of the
    shaft and its supports ``scale`` times smaller)."""
    shaft = Crankshaft(20.0, 20.0, 8.0, (4.0, 14.0), (-12.0, 30.0), -12.0, young_modulus=E * scale)
    soft = palmgren.STEEL_COMPLIANCE * scale ** (-1 / 0.9)
    b = SupportBearing("cylindrical", 12, 5.0, 8.0, 40.0, clearance=clearance, compliance=soft)
    return CrankSupport(shaft, b)


def scaled(t, f: float):
    """The bodies' tables ``1 / f`` times stiffer (every influence coefficient times ``f``)."""
    cam = None if t.cam is None else t.cam * f
    return replace(t, ring=t.ring * f, frame=t.frame * f, cam=cam)


def solve(law, bearing, target=M0, **kw):
    return DriveSolver(SMALL, ANGLES, contact_model=law, bearing=bearing, **kw).solve(target)


def same(a, b, rtol=1e-9):
    np.testing.assert_allclose(a[0], b[0], rtol=rtol)
    np.testing.assert_allclose(a[1], b[1], rtol=rtol, atol=rtol * b[1].max())


CASES = [
    ("palmgren", None),
    ("nonlinear", None),
    ("palmgren", NEEDLES),
    ("nonlinear", NEEDLES),
]


@pytest.mark.parametrize("law,bearing", CASES)
def test_each_part_alone_in_its_limit(tables, law, bearing):
    """The crank 1e9 times stiffer (its supports without clearance) with the bodies: the
    bodies alone to 1e-9; the bodies
    1e9 times stiffer with the crank: the crank alone to 1e-9; at the rated moment, half of
    it and a low one (3 %, the supports and needles in their clearances)."""
    for target in (M0, 0.5 * M0, -0.03 * M0):
        both = solve(law, bearing, target, crank=crank(1e9, clearance=0.0), bodies=tables)
        same(both, solve(law, bearing, target, bodies=tables))
        both = solve(law, bearing, target, crank=crank(), bodies=scaled(tables, 1e-9))
        same(both, solve(law, bearing, target, crank=crank()))
        assert np.max(both[4]) <= 1e-9


def _independent(solver: DriveSolver, M0: float, p: int):
    """Position ``p`` (cams fixed) solved another way, from the public pieces: each loaded
    roller's contact law ``G_k(F_k)`` plus the bodies' influence ``sum_j C_kj F_j`` equals
    ``a_k (tau_g - theta_c) + g_k + n_k . w_c`` with ``w``, ``theta`` the crankshaft's
    answer (CrankSupport.response) to the eccentric loads ``-sum_k F_k n_k`` and the rows'
    moments ``sum_k a_k F_k`` (eccentric B's frame is A's turned by pi: its vectors'
    components change sign), and ``sum a_k F_k = M0``; by MINPACK's hybrid method
    (scipy.optimize.fsolve) in an active-set loop, started from the rigid drive."""
    geo = solver.geo_joined
    R = SMALL.roller_count
    comp = solver.comp.take(np.array([p]))
    a = np.where(geo.loadable[p], geo.arm[p], 0.0)
    g = np.where(geo.loadable[p], geo.gap[p], -1e300)
    n = solver.n[p]
    C = solver.bodies[p]
    sign = np.repeat([1.0, -1.0], R)  # A's frame -> each eccentric's own
    rows = (slice(0, R), slice(R, 2 * R))
    support = solver.crank

    def overlap(F, tau):
        loads = np.stack([-(F[sl] @ n[sl]) * s for sl, s in zip(rows, (1.0, -1.0), strict=True)])
        moments = np.array([[a[sl] @ F[sl] for sl in rows]])
        resp = support.response(loads[None], moments)
        w, theta = resp["w"][0], resp["theta"][0]
        wk = np.concatenate([n[sl] @ w[c] for c, sl in enumerate(rows)]) * sign
        th = np.repeat(theta, R)
        return a * (tau - th) + g + wk - C @ F

    tau0 = DriveSolver(SMALL, ANGLES[p : p + 1], contact_model="palmgren").solve(M0)[0][0]
    active = a * tau0 + g > 0
    for _ in range(20):
        idx = np.flatnonzero(active)

        def eqs(x, idx=idx):
            F = np.zeros(len(a))
            F[idx] = x[:-1]
            G = comp.value_and_slope(F[None, :])[0][0][idx]
            r = G - overlap(F, x[-1])[idx]
            return np.append(r / 1e-3, (a @ F - M0) / abs(M0))

        x0 = np.append(np.full(len(idx), abs(M0) / np.sum(np.abs(a[idx]))), tau0)
        x = fsolve(eqs, x0, xtol=1e-12)
        F = np.zeros(len(a))
        F[idx] = x[:-1]
        h = overlap(F, x[-1])
        new = (active & (F > 0)) | (~active & (h > 0))
        if np.array_equal(new, active):
            return F, x[-1]
        active = new
    raise AssertionError("the active set did not settle")


@pytest.mark.parametrize("law", ["palmgren", "nonlinear"])
def test_joint_solve_equals_an_independent_one(tables, law):
    solver = DriveSolver(SMALL, ANGLES[:3], contact_model=law, crank=crank(), bodies=tables)
    tau, F, *_ = solver.solve(M0)
    for p in range(3):
        Fi, ti = _independent(solver, M0, p)
        assert np.max(np.abs(F[p] - Fi)) <= 1e-6 * np.max(Fi)
        assert abs(tau[p] / ti - 1) <= 1e-6


@pytest.mark.parametrize("law,bearing", CASES)
def test_budget_with_every_component_adds_up_and_each_is_positive(tables, law, bearing):
    s = DriveSolver(SMALL, ANGLES, contact_model=law, bearing=bearing, crank=crank(), bodies=tables)
    sol = s.solve(M0)
    parts = budget_terms(s, M0, sol)
    assert {"ring_body", "frame", "cam_body", "crankshaft_bending", "support_bearings"} <= set(
        parts
    )
    np.testing.assert_allclose(sum(parts.values()), M0 * sol[0], rtol=1e-6)
    for name, v in parts.items():
        if name == "initial_gaps" or (name == "needle_bearings" and bearing is None):
            np.testing.assert_array_equal(v, 0.0)
        else:
            assert np.all(v > 0), name


def test_a_preloaded_support_and_a_low_moment_converge(tables):
    """Hard cases: a preloaded support (negative clearance) with needles in their clearance,
    and a moment of 1 % of the rated one."""
    for target in (M0, 0.01 * M0, -0.01 * M0):
        sol = solve("nonlinear", NEEDLES, target, crank=crank(clearance=-0.002), bodies=tables)
        assert np.max(sol[4]) <= 1e-9


@pytest.mark.slow
def test_the_prototype_with_the_crank_and_the_bodies():
    """docs/physics.md: needles 40 x 6 x 12 mm (5 um), the default shaft and cylindrical
    supports, the bodies elastic: rigidity 2,521 N*m/arcmin; the budget at T_R: contacts
    44 %, needles 32 %, crankshaft 2.1 %, supports 3.0 %, ring 6.0 %, frame 2.7 %, cams
    10.1 %."""
    from corr_cad.mechanics.datasheet import DatasheetSpec, datasheet
    from corr_cad.run.scene.scene import parse_scene

    needles = {"needles": 40, "needle_diameter": 6.0, "needle_length": 12.0}
    scene = parse_scene(
        {
            "solver": {"model": "drive", "contact_law": "palmgren"},
            "load": {"input_torque": 1.1e5},
            "bearings": {
                "eccentric": {**needles, "diametral_clearance": 0.005},
                "crank": {"type": "cylindrical"},
            },
        }
    )
    d = GearDesign()
    tables = reduce_bodies(d, part_outlines(d, working_profile(d), 0.001))
    drive = {"errors_b": None, "bearing": scene.bearing, "bearing_b": None}
    drive.update(bodies=tables, crank=scene.crank)
    ds = datasheet(d, DatasheetSpec(rated_torque=2.86e6), contact_model="palmgren", drive=drive)
    assert round(ds.figures()["torsional_rigidity_Nm_per_arcmin"]["contact_only"]["min"]) == 2521
    share = {k: v["share"] for k, v in ds.compliance_budget["components"].items()}
    groups = {
        "contact_cam contact_ring contact_slot": 0.44,
        "needle_bearings": 0.321,
        "crankshaft_bending crankshaft_shear crankshaft_torsion": 0.021,
        "support_bearings": 0.030,
        "ring_body": 0.060,
        "frame": 0.027,
        "cam_body": 0.101,
    }
    for names, want in groups.items():
        assert sum(share[n] for n in names.split()) == pytest.approx(want, abs=0.001), names


@pytest.mark.parametrize("with_bodies", [False, True], ids=["crank", "crank and bodies"])
def test_rows_that_preload_their_cams_settle_at_zero_moment(tables, with_bodies):
    """Oversize rollers preload both rows at zero moment; the cams sit in their needles'
    clearance and the shaft carries round-off only: its supports stay centred in their
    clearance and the fixed point settles."""
    preload = ManufacturingErrors(roller_radius_error=0.003)
    kw = {"bodies": tables} if with_bodies else {}
    s = DriveSolver(
        SMALL, ANGLES, contact_model="palmgren", bearing=NEEDLES, errors=preload,
        crank=crank(clearance=0.01), **kw,
    )  # fmt: skip
    tau, F, *_, rel, _ = s.solve(0.0)
    assert np.max(rel) <= 1e-9 and np.min(np.max(F, axis=1)) > 0  # preloaded


SCENE = """[design]
tooth_count = 9
cam_radius = 45.0
roller_radius = 4.0
eccentricity = 1.5
[export]
formats = ["forces", "datasheet"]
[load]
input_torque = 2.0e4
[solver]
positions = 40
model = "drive"
contact_law = "palmgren"
bodies = "elastic"
[crankshaft]
shaft_diameter = 22.0
[bearings.crank]
"""


@pytest.mark.slow
def test_cli_crank_and_elastic_bodies_in_one_datasheet(tmp_path):
    (tmp_path / "both.toml").write_text(SCENE)
    env = {**os.environ, "CORR_CAD_CACHE_DIR": str(tmp_path / "cache")}
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "both.toml", "--out", "both", "--workers", "1"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env=env,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    out = tmp_path / "both"
    ds = json.loads((out / "datasheet.json").read_text())
    b = ds["compliance_budget"]
    comps = b["components"]
    for name in (
        "contact_cam",
        "contact_ring",
        "contact_slot",
        "crankshaft_bending",
        "crankshaft_shear",
        "crankshaft_torsion",
        "support_bearings",
        "ring_body",
        "frame",
        "cam_body",
    ):
        assert comps[name]["in_model"] and comps[name]["windup_arcmin"] > 0, name
    assert not comps["first_stage"]["in_model"]
    total = sum(c["windup_arcmin"] for c in comps.values())
    assert total == pytest.approx(b["windup_arcmin"], rel=1e-6)
    assert b["sum_relative_residual"] <= 1e-6
    inside = " ".join(ds["compliances"]["in_figure"])
    assert "crankshaft" in inside and "frame body" in inside and "support bearings" in inside
    assert "ring body (rigid)" not in ds["compliances"]["not_in_figure"]
    assert "crankshaft" not in ds["bodies"]["not_in_figure"]
    assert (out / "compliance.png").is_file()
    html = (out / "datasheet.html").read_text()
    assert "ring body" in html and "cam body" in html
    assert "ring body" in r.stdout and "crankshaft bending" in r.stdout
