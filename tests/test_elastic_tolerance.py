"""The studies on samples (Monte Carlo with its datasheet metrics, allocation, modification
design, sweeps) on the chain the nominal drive solves: the crankshaft on its support
bearings, or the elastic ring, frame and cams."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors as ME
from corr_cad.geometry.parts import part_outlines
from corr_cad.geometry.profile import working_profile
from corr_cad.mechanics import palmgren
from corr_cad.mechanics.bodies.reduction import MeshSpec, reduce_bodies
from corr_cad.mechanics.crank.bearing import EccentricBearing
from corr_cad.mechanics.crank.crankshaft import STEEL_E, Crankshaft
from corr_cad.mechanics.crank.support_bearing import SupportBearing
from corr_cad.mechanics.drive.coupling import BodyTables
from corr_cad.mechanics.drive.drive import solve_drive
from corr_cad.mechanics.drive.drive_crank import CrankSupport
from corr_cad.mechanics.row.solver import loaded_mask
from corr_cad.mechanics.row.solver_geometry import cycle_angles
from corr_cad.tolerance.montecarlo import Distribution, monte_carlo
from corr_cad.tolerance.montecarlo_drive import drive_chunk

DESIGN = GearDesign()
NEEDLES = EccentricBearing(40, 6.0, 12.0)
SMALL = GearDesign(tooth_count=9, cam_radius=45.0, roller_radius=4.0, eccentricity=1.5)
#: A coarse mesh of the small design (the coupling, not the FE, is under test).
COARSE = MeshSpec(fine=0.25, grade=0.5, coarse=1.0, spacing=0.25)
ARCMIN = 180.0 * 60.0 / math.pi
M0 = 1.1e5  # crank moment, N*mm


def crank(scale: float = 1.0) -> CrankSupport:
    """A 60 mm shaft on cylindrical roller bearings; ``scale``: every compliance that many
    times smaller (E x scale, Palmgren's constant / scale^(1/0.9))."""
    shaft = Crankshaft(
        60.0, 82.4, 12.0, (6.0, 26.0), (-27.0, 59.0), -27.0, young_modulus=STEEL_E * scale
    )
    soft = palmgren.STEEL_COMPLIANCE * scale ** (-1 / 0.9)
    return CrankSupport(shaft, SupportBearing("cylindrical", 16, 12.0, 12.0, 85.0, compliance=soft))


@pytest.fixture(scope="module")
def small_tables() -> BodyTables:
    return reduce_bodies(SMALL, part_outlines(SMALL, working_profile(SMALL), 0.01), COARSE)


def _errors(rng, R, phase=0.0):
    return ME(
        cam_radius_error=float(rng.normal(0.0, 0.002)),
        eccentricity_error=float(rng.normal(0.0, 0.002)),
        roller_radius_errors=tuple(rng.normal(0.0, 0.002, R)),
        cam_phase_error=phase,
    )


def _own_errors(base, tolerances, draws, k):
    """Sample k's errors: the draws are the errors themselves (a test's own mapping)."""
    return draws["errors"][k]


def _alone(design, ea, eb, angles, **kw) -> dict:
    """One sample by :func:`solve_drive` on its own, its metrics written out here: the
    largest gear force and contact pressure over both rows, the fewest loaded rollers of
    a row, the drive's free rotation (arcmin of the output)."""
    res = solve_drive(design, M0, angles, errors=ea, errors_b=eb, **kw)
    assert res.success
    pressure = max(float(np.max([r.p_cam, r.p_slot, r.p_gear])) for r in res.rows)
    return {
        "peak_gear_force": float(res.F_n.max()),
        "peak_pressure": pressure,
        "min_loaded_rollers": float(min(loaded_mask(r.F_j).sum(axis=1).min() for r in res.rows)),
        "backlash_arcmin": float(res.backlash.max()) * ARCMIN,
    }


def _chunk(design, ea, eb, angles, drive):
    n = len(ea)
    got, ok = drive_chunk(
        design, M0, angles, None, None, {}, {"errors": ea}, {"errors": eb}, n, math.pi, drive,
        _own_errors,
    )  # fmt: skip
    assert ok
    return got


@pytest.mark.parametrize("bearing", [NEEDLES, None], ids=["needles", "fixed cams"])
def test_crank_monte_carlo_equals_solve_drive_sample_by_sample(bearing):
    """Each sample of a block on the crankshaft equals solve_drive with the same crank and
    that sample's errors (cam B's own phase error included: eccentric B turned by it)."""
    R = DESIGN.roller_count
    rng = np.random.default_rng(5)
    n = 4
    ea = [_errors(rng, R, math.radians(0.05 * k)) for k in range(n)]
    eb = [_errors(rng, R) for _ in range(n)]
    angles = cycle_angles(11)
    c = crank()
    drive = {"bearing": bearing, "contact_model": "palmgren", "crank": c}
    got = _chunk(DESIGN, ea, eb, angles, drive)
    rigid = _chunk(DESIGN, ea, eb, angles, {**drive, "crank": None})
    for k in range(n):
        want = _alone(DESIGN, ea[k], eb[k], angles, bearing=bearing, contact_model="palmgren",
                      crank=c)  # fmt: skip
        for name, v in want.items():
            assert got[name][k] == pytest.approx(v, rel=1e-9, abs=1e-12), (name, k)
    # the chain is in: the crank's deflection moves the forces
    assert np.all(np.abs(got["peak_gear_force"] / rigid["peak_gear_force"] - 1) > 1e-6)


@pytest.mark.parametrize("bearing", [NEEDLES, None], ids=["needles", "fixed cams"])
def test_elastic_monte_carlo_equals_solve_drive_sample_by_sample(small_tables, bearing):
    R = SMALL.roller_count
    rng = np.random.default_rng(7)
    n = 3
    ea = [_errors(rng, R, math.radians(0.03)) for _ in range(n)]
    eb = [_errors(rng, R) for _ in range(n)]
    angles = cycle_angles(7)
    drive = {"bearing": bearing, "contact_model": "nonlinear", "bodies": small_tables}
    got = _chunk(SMALL, ea, eb, angles, drive)
    rigid = _chunk(SMALL, ea, eb, angles, {**drive, "bodies": None})
    for k in range(n):
        want = _alone(SMALL, ea[k], eb[k], angles, bearing=bearing, bodies=small_tables)
        for name, v in want.items():
            assert got[name][k] == pytest.approx(v, rel=1e-9, abs=1e-12), (name, k)
    assert np.all(np.abs(got["peak_gear_force"] / rigid["peak_gear_force"] - 1) > 1e-6)


def test_influence_is_made_once_a_block_not_once_a_sample(small_tables, monkeypatch):
    """A block's samples share the nominal positions' influence matrices: the FE tables'
    interpolation into whole matrices runs at most once a block whatever its sample
    count (the overlap Newton reads only its loaded rollers' columns, and needs none
    where every position settles)."""
    from corr_cad.mechanics.drive import coupling

    calls = []
    real = coupling.influence_matrices

    def counted(*a, **kw):
        calls.append(len(a[2]))
        return real(*a, **kw)

    monkeypatch.setattr(coupling, "influence_matrices", counted)
    R = SMALL.roller_count
    rng = np.random.default_rng(1)
    ea = [_errors(rng, R) for _ in range(5)]
    _chunk(SMALL, ea, ea, cycle_angles(7), {"bodies": small_tables})
    # One block of 5 samples x 7 positions: the 7 nominal positions once, if at all.
    assert calls in ([], [7])


@pytest.mark.parametrize("chain", ["crank", "bodies"])
def test_chain_1e9_stiffer_gives_the_rigid_monte_carlo(small_tables, chain):
    """The limit: a crank (shaft and supports) or bodies 1e9 times stiffer, the rigid
    chain's Monte Carlo figures (force metrics) to 1e-9."""
    design = DESIGN if chain == "crank" else SMALL
    stiff = (
        crank(1e9)
        if chain == "crank"
        else BodyTables(
            small_tables.ring * 1e-9,
            small_tables.frame * 1e-9,
            small_tables.frame_radii,
            small_tables.nodes,
            small_tables.mesh_size,
            small_tables.cam * 1e-9,
        )
    )
    normal = Distribution("normal", 0.002)
    tol = {"roller_radius": normal, "cam_radius": normal}
    base = {"bearing": NEEDLES, "contact_model": "palmgren"}
    rigid = monte_carlo(design, M0, tol, 4, 3, 9, drive=base)
    elastic = monte_carlo(design, M0, tol, 4, 3, 9, drive={**base, chain: stiff})
    assert rigid.success and elastic.success
    for name, v in rigid.metrics.items():
        np.testing.assert_allclose(elastic.metrics[name], v, rtol=1e-9, atol=1e-12, err_msg=name)


@pytest.mark.parametrize(
    "clearance,law", [(0.0, "palmgren"), (0.005, "palmgren"), (0.005, "nonlinear")]
)
def test_crank_datasheet_metrics_equal_the_sample_alone(clearance, law):
    """The datasheet pass on the crank: each sample's windup figures equal a one-sample
    block's (the datasheet pass of that sample alone) to 1e-9, and differ from the
    rigid crank's (softer: lower rigidity). With a needle clearance some positions'
    cams float free at zero moment (their preload taken up by the clearance): the
    crank's fixed point settles there too."""
    from corr_cad.mechanics.datasheet import DatasheetSpec
    from corr_cad.tolerance.mc_datasheet import DatasheetMC
    from corr_cad.tolerance.mc_drive_datasheet import drive_datasheet_samples, drive_grid

    R = DESIGN.roller_count
    rng = np.random.default_rng(3)
    pairs = [(_errors(rng, R, math.radians(0.04)), _errors(rng, R)) for _ in range(3)]
    cfg = DatasheetMC(DatasheetSpec(rated_torque=2.86e6), positions_per_mesh=2)
    grid = drive_grid(DESIGN, pairs[0][0], pairs[0][1], ("roller_radius",), 2)[:6]
    bearing = EccentricBearing(40, 6.0, 12.0, clearance)
    drive = {"bearing": bearing, "contact_model": law, "crank": crank()}
    got, ok = drive_datasheet_samples(DESIGN, pairs, cfg, grid, math.pi, drive)
    assert ok
    rigid, _ = drive_datasheet_samples(DESIGN, pairs, cfg, grid, math.pi, {**drive, "crank": None})
    for k, pair in enumerate(pairs):
        one, _ = drive_datasheet_samples(DESIGN, [pair], cfg, grid, math.pi, drive)
        for name, v in one.items():
            assert got[name][k] == pytest.approx(v[0], rel=1e-9, abs=1e-12), (name, k)
    key = "torsional_rigidity_Nm_per_arcmin"
    assert np.all(got[key] < rigid[key])


SMALL_SCENE = """
[design]
tooth_count = 9
cam_radius = 45.0
roller_radius = 4.0
eccentricity = 1.5
[export]
formats = {formats}
[load]
input_torque = 2.0e4
[solver]
positions = 18
model = "drive"
contact_law = "palmgren"
bodies = "{bodies}"
[tolerances]
roller_radius = {{ normal = 0.002 }}
cam_radius = {{ normal = 0.002 }}
[montecarlo]
samples = {samples}
positions = 9
datasheet_positions_per_mesh = 2
[datasheet]
positions_per_mesh = 2
transmission_error_positions_per_turn = 2
{extra}
"""


def _small_scene(formats='["forces", "montecarlo"]', bodies="rigid", samples=6, extra=""):
    return SMALL_SCENE.format(formats=formats, bodies=bodies, samples=samples, extra=extra)


@pytest.mark.slow
def test_body_tables_built_once_a_run(tmp_path, monkeypatch):
    """The FE reduction runs once in a run whose forces, datasheet and Monte Carlo (force
    and datasheet metrics) all solve on the elastic bodies, and the cache is not read
    again for the samples: counters on both."""
    import tomllib

    from corr_cad.run.pipeline import run_scene
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages import stages_bodies

    monkeypatch.setenv("CORR_CAD_CACHE_DIR", str(tmp_path / "cache"))
    counts = {"reduce": 0, "read": 0}
    real_reduce, real_read = stages_bodies.reduce_bodies, stages_bodies._read

    def reduce(*a, **kw):
        counts["reduce"] += 1
        return real_reduce(*a, **kw)

    def read(*a, **kw):
        counts["read"] += 1
        return real_read(*a, **kw)

    monkeypatch.setattr(stages_bodies, "reduce_bodies", reduce)
    monkeypatch.setattr(stages_bodies, "_read", read)
    text = _small_scene('["forces", "datasheet", "montecarlo"]', "elastic", 5)
    scene = parse_scene(tomllib.loads(text), name="el")
    (tmp_path / "out").mkdir()
    m = run_scene(scene, tmp_path / "out")
    assert counts == {"reduce": 1, "read": 0}
    assert m["montecarlo"]["samples"] == 5
    summary = json.loads((tmp_path / "out" / "montecarlo_summary.json").read_text())
    assert "nominal design's" in summary["model"]["samples_chain"]


def _cli(tmp_path, text, name, *args):
    import os
    import subprocess
    import sys

    (tmp_path / f"{name}.toml").write_text(text)
    env = {**os.environ, "CORR_CAD_CACHE_DIR": str(tmp_path / "cache")}
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", f"{name}.toml", "--out", name, *args],
        cwd=tmp_path, capture_output=True, text=True, env=env,
    )  # fmt: skip
    return r, tmp_path / name


@pytest.mark.slow
def test_cli_monte_carlo_on_the_crank_serial_equals_two_workers(tmp_path):
    """The CLI with montecarlo under [crankshaft]: it runs (no refusal), states the chain
    in montecarlo_summary.json, and writes the same montecarlo.csv on one process and on
    two workers, byte for byte."""
    text = _small_scene(
        '["forces", "montecarlo", "modification"]',
        extra="[crankshaft]\nshaft_diameter = 20.0\n[bearings.crank]\n"
        "[modification.design]\ntarget_backlash_arcmin = 5.0\nmax_binding_probability = 0.5\n"
        "steps = 2\nsamples = 10\npositions = 8\nforce_candidates = 1\n",
    )
    r1, one = _cli(tmp_path, text, "one", "--workers", "1")
    assert r1.returncode == 0, r1.stderr
    r2, two = _cli(tmp_path, text, "two", "--workers", "2")
    assert r2.returncode == 0, r2.stderr
    assert (one / "montecarlo.csv").read_bytes() == (two / "montecarlo.csv").read_bytes()
    s = json.loads((one / "montecarlo_summary.json").read_text())
    assert s["model"]["crank"]["crankshaft"]["shaft_diameter_mm"] == 20.0
    assert "crankshaft" in s["model"]["samples_chain"]
    mod = json.loads((one / "modification.json").read_text())
    assert mod["samples_chain"] == s["model"]["samples_chain"]
    assert "[crankshaft]" in (one / "modified.toml").read_text()
    rigid, out_r = _cli(tmp_path, _small_scene(), "rigid", "--workers", "1")
    assert rigid.returncode == 0, rigid.stderr
    sr = json.loads((out_r / "montecarlo_summary.json").read_text())
    assert "samples_chain" not in sr["model"]
    # the softer chain carries less of each micrometre: a lower peak force at p50 or equal
    p = s["percentiles"]["peak_gear_force"]["p50"]
    assert p != sr["percentiles"]["peak_gear_force"]["p50"]


def soft_crank() -> CrankSupport:
    """A slender 30 mm shaft on cylindrical roller bearings (steel)."""
    shaft = Crankshaft(30.0, 82.4, 12.0, (6.0, 26.0), (-27.0, 59.0), -27.0)
    return CrankSupport(shaft, SupportBearing("cylindrical", 16, 12.0, 12.0, 85.0))


@pytest.mark.slow
def test_allocation_on_the_crank_allows_more_of_the_errors_it_takes_up():
    """The crank's compliance moves each cam's centre under its row's resultant: a cam
    radius or eccentricity error (one row's rollers all pressed) makes less force than on
    the rigid crank, so the largest tolerance that keeps the gear-force limit is larger
    (measured: 9.0 -> 13.2 um and 17.4 -> 23.9 um); a roller's own radius error, which
    the cam's centre barely relieves, stays within 5 %."""
    from corr_cad import Checks, allocate

    base = {"bearing": NEEDLES, "contact_model": "palmgren"}
    checks = Checks(max_gear_force=1.3 * 2664.0)
    got = {}
    for name, drive in (("rigid", base), ("crank", {**base, "crank": soft_crank()})):
        for kind in ("cam_radius", "eccentricity", "roller_radius"):
            a = allocate(DESIGN, M0, {}, checks, kind, samples=20, positions=36, drive=drive)
            got[name, kind] = a["tolerance"]
    assert got["crank", "cam_radius"] > 1.3 * got["rigid", "cam_radius"]
    assert got["crank", "eccentricity"] > 1.2 * got["rigid", "eccentricity"]
    assert got["crank", "roller_radius"] == pytest.approx(got["rigid", "roller_radius"], rel=0.05)


def test_allocation_on_the_elastic_bodies_allows_more(small_tables):
    """Each roller's contact in series with the bodies' approach: an error makes less
    force, the allocated roller radius tolerance is larger than on rigid bodies."""
    from corr_cad import Checks, allocate

    base = {"bearing": NEEDLES, "contact_model": "palmgren"}
    checks = Checks(max_gear_force=1.3 * 2766.0)
    rigid = allocate(SMALL, 2e4, {}, checks, "roller_radius", samples=20, positions=36,
                     drive=base)  # fmt: skip
    el = allocate(SMALL, 2e4, {}, checks, "roller_radius", samples=20, positions=36,
                  drive={**base, "bodies": small_tables})  # fmt: skip
    assert el["tolerance"] > 1.2 * rigid["tolerance"]


def test_modification_design_on_the_crank():
    """The zero-load figures (backlash, binding) are the gaps' and equal the rigid
    crank's to the bit; the force-solved candidate's p95 contact pressure is lower on the
    softer chain (1493 against 1602 MPa measured)."""
    from corr_cad.tolerance.modification_design import design_modification

    tol = {
        "cam_radius": Distribution("normal", 0.003),
        "roller_radius": Distribution("normal", 0.001),
    }
    kw = dict(
        family="equidistant", objective="peak_pressure", target_backlash_arcmin=5.0,
        max_binding_probability=0.5, crank_moment=M0, equidistant_mm=(0.0, 0.01, 3),
        shift_mm=(0.0, 0.0, 1), samples=20, seed=1, positions=16, force_candidates=3,
    )  # fmt: skip
    base = {"bearing": None, "contact_model": "palmgren"}
    rigid = design_modification(DESIGN, tol, drive=base, **kw)
    soft = design_modification(DESIGN, tol, drive={**base, "crank": soft_crank()}, **kw)
    for a, b in zip(rigid["candidates"], soft["candidates"], strict=True):
        assert a["backlash_arcmin"] == b["backlash_arcmin"]
        assert a["binding_probability"] == b["binding_probability"]
    pa = rigid["chosen"]["peak_pressure_MPa"]["p95"]["value"]
    pb = soft["chosen"]["peak_pressure_MPa"]["p95"]["value"]
    assert pb < 0.97 * pa


def test_sweep_points_on_the_chain(small_tables):
    """An error's sweep point is solve_drive on the nominal bodies (and the crank); a
    design's point asks for that design's own tables, once."""
    from corr_cad.tolerance.sweeps import METRICS, sweep_point

    asked = []

    def tables_for(design):
        asked.append(design)
        return reduce_bodies(design, part_outlines(design, working_profile(design), 0.01), COARSE)

    drive = {"model": "drive", "contact_model": "palmgren", "bodies": small_tables,
             "bodies_for": tables_for}  # fmt: skip
    rec = sweep_point(SMALL, "cam_radius_error", 0.004, 2e4, 18, 0.55, drive)
    res = solve_drive(SMALL, 2e4, positions=18, errors=ME(cam_radius_error=0.004),
                      contact_model="palmgren", bodies=small_tables)  # fmt: skip
    want = res.rows[0].summary()
    assert rec["status"] == "ok" and asked == []
    for k in METRICS:
        assert rec[k] == pytest.approx(want[k], rel=1e-12), k
    rec = sweep_point(SMALL, "eccentricity", 1.6, 2e4, 18, 0.55, drive)
    assert rec["status"] == "ok" and len(asked) == 1 and asked[0].eccentricity == 1.6
    own = tables_for(asked[0])
    res = solve_drive(asked[0], 2e4, positions=18, contact_model="palmgren", bodies=own)
    assert rec["F_j_peak"] == pytest.approx(float(res.rows[0].summary()["F_j_peak"]), rel=1e-12)
    c = crank()
    rec = sweep_point(DESIGN, "eccentricity_error", 0.003, M0, 18, 0.55,
                      {"model": "drive", "contact_model": "palmgren", "crank": c})  # fmt: skip
    res = solve_drive(DESIGN, M0, positions=18, errors=ME(eccentricity_error=0.003),
                      contact_model="palmgren", crank=c)  # fmt: skip
    assert rec["F_j_peak"] == pytest.approx(float(res.rows[0].summary()["F_j_peak"]), rel=1e-12)


def test_crank_binding_pressure_where_the_cams_float_free_at_zero_moment():
    """A sample whose preloaded positions' cams float free in their needle clearance at
    zero crank moment (no force: the shaft's deflection is round-off): the datasheet pass
    settles and every figure is finite (it failed to, before the fixed point's floor)."""
    from corr_cad.mechanics.datasheet import DatasheetSpec
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.tolerance.mc_datasheet import DatasheetMC

    c = parse_scene({"solver": {"model": "drive"}, "load": {"input_torque": M0},
                     "crankshaft": {}}).crank  # fmt: skip
    sheet = DatasheetMC(DatasheetSpec(rated_torque=2.86e6), positions_per_mesh=4)
    drive = {"bearing": EccentricBearing(40, 6.0, 12.0, 0.005), "contact_model": "palmgren",
             "crank": c}  # fmt: skip
    tol = {"roller_radius": Distribution("normal", 0.001)}
    mc = monte_carlo(DESIGN, M0, tol, 1, 1, 8, drive=drive, datasheet=sheet)
    assert mc.success
    assert all(np.all(np.isfinite(v)) for v in mc.metrics.values())


def test_nominal_tables_on_a_perturbed_sample_are_its_own_to_1e_3(small_tables):
    """The small-perturbation choice: a sample's drive (cam radius +6 um, eccentricity
    +6 um, rollers +3 um) solved on the nominal design's tables against tables rebuilt
    for its own cam and load points (the same mesh sizes in mm): peak gear force, mean
    crank rotation and peak pressure within 1e-3 (the prototype's: 1.2e-4, 6.5e-5,
    7.2e-5; benchmarks/bench_perturbed_tables.py)."""
    dRj, de, dr = 0.006, 0.006, 0.003
    d = SMALL
    dp = replace(d, cam_radius=d.cam_radius + dRj, eccentricity=d.eccentricity + de,
                 roller_radius=d.roller_radius + dr)  # fmt: skip
    k = d.roller_radius / dp.roller_radius
    spec = MeshSpec(COARSE.fine * k, COARSE.grade, COARSE.coarse * k, COARSE.half_width * k,
                    COARSE.depth * k, COARSE.spacing * k)  # fmt: skip
    o = part_outlines(d, working_profile(d), 0.01)
    own = reduce_bodies(dp, {**o, "cam": part_outlines(dp, working_profile(dp), 0.01)["cam"]}, spec)
    err = ME(cam_radius_error=dRj, eccentricity_error=de, roller_radius_error=dr)
    got = []
    for tab in (small_tables, own):
        res = solve_drive(d, 2e4, positions=36, errors=err, contact_model="palmgren", bodies=tab)
        p = max(float(np.max([r.p_cam, r.p_slot, r.p_gear])) for r in res.rows)
        got.append(np.array([res.F_n.max(), np.mean(res.cam_rotation), p]))
    assert np.all(np.abs(got[1] / got[0] - 1) < 1e-3), got[1] / got[0] - 1
    assert np.any(np.abs(got[1] / got[0] - 1) > 1e-7)  # the tables do differ


@pytest.mark.parametrize("section", [{"crankshaft": {}}, {"crankshaft": {"shaft_diameter": 30.0}},
                                     {"bearings": {"crank": {"type": "rigid"}}}])  # fmt: skip
def test_modified_toml_keeps_the_crank(section):
    """modified.toml of a scene on the crank keeps its sections (an empty one too: its
    presence puts the crank in), so a study added to it solves on the same chain."""
    import tomllib

    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.stages_modification import modified_toml

    data = {"solver": {"model": "drive"}, "load": {"input_torque": M0}, **section}
    text = modified_toml(parse_scene(data), 0.01, 0.0)
    again = parse_scene(tomllib.loads(text))
    assert again.crank is not None and again.crank == parse_scene(data).crank
    plain = modified_toml(parse_scene({"solver": {"model": "drive"}}), 0.01, 0.0)
    assert "crank" not in plain


@pytest.mark.parametrize("chain", ["bodies", "stiff crank"])
def test_datasheet_metrics_on_the_chain(small_tables, chain):
    """The datasheet pass on the elastic bodies: each sample equals its one-sample block to
    1e-9 and the bodies lower the rigidity; on a crank 1e9 times stiffer, the rigid
    chain's datasheet figures to 1e-9."""
    from corr_cad.mechanics.datasheet import DatasheetSpec
    from corr_cad.tolerance.mc_datasheet import DatasheetMC
    from corr_cad.tolerance.mc_drive_datasheet import drive_datasheet_samples, drive_grid

    design = SMALL if chain == "bodies" else DESIGN
    R = design.roller_count
    rng = np.random.default_rng(9)
    pairs = [(_errors(rng, R, math.radians(0.03)), _errors(rng, R)) for _ in range(3)]
    rated = 2e4 * R if chain == "bodies" else 2.86e6
    cfg = DatasheetMC(DatasheetSpec(rated_torque=rated), positions_per_mesh=2)
    grid = drive_grid(design, pairs[0][0], pairs[0][1], ("roller_radius",), 2)[:5]
    base = {"bearing": NEEDLES, "contact_model": "palmgren"}
    drive = {**base, "bodies": small_tables} if chain == "bodies" else {**base, "crank": crank(1e9)}
    got, ok = drive_datasheet_samples(design, pairs, cfg, grid, math.pi, drive)
    rigid, ok_r = drive_datasheet_samples(design, pairs, cfg, grid, math.pi, base)
    assert ok and ok_r
    key = "torsional_rigidity_Nm_per_arcmin"
    if chain == "bodies":
        for k, pair in enumerate(pairs):
            one, _ = drive_datasheet_samples(design, [pair], cfg, grid, math.pi, drive)
            for name, v in one.items():
                assert got[name][k] == pytest.approx(v[0], rel=1e-9, abs=1e-12), (name, k)
        assert np.all(got[key] < rigid[key])
    else:
        for name, v in rigid.items():
            np.testing.assert_allclose(got[name], v, rtol=1e-9, atol=1e-9, err_msg=name)
