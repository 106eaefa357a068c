"""The design search ([sizing]): refusals, the front against a grid, the reference, the
design scenes, reproducibility on every executor, and the verdict when nothing fits.

The CLI runs as a user runs it (``python -m corr_cad`` in a subprocess); the
grid and the figures of the design scenes are computed here, independently
of the search, through the scene loader and ``corr-cad run``.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import without_progress

ROOT = Path(__file__).resolve().parents[1]

#: Two variables, the paper's row without [life]: about 0.1 s a candidate.
TWO = """
[design]
tooth_count = 25
cam_radius = 135.0
roller_radius = 8.0
roller_length = 12.0
eccentricity = 3.5

[sizing]
objectives = ["mass", "rigidity"]
evaluations = {evaluations}
population = 16
seed = {seed}

[sizing.requirements]
rated_torque_Nm = 2860.0
max_outer_diameter_mm = 380.0

[sizing.variables]
eccentricity = [3.0, 4.0]
cam_radius = [130.0, 135.0]

[export]
formats = ["sizing"]
"""


def _cli(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", *args], cwd=cwd, capture_output=True, text=True
    )


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# --- refusals: one line, exit 2 --------------------------------------------------------


REFUSALS = {
    'objectives = ["mass"]': ("[sizing] objectives = ['mass']: give two or three", "sizing"),
    "roller_radius = [9.0, 7.0]": (
        "[sizing.variables] roller_radius = [9.0, 7.0]: give [min, max] with min <= max",
        "variables",
    ),
    "pinion_teeth = [16.0, 20.0]": ("varies the first stage but the scene has no", "variables"),
    "needle_diameter = [6.5, 7.0]": ("no standard size lies in the range", "variables"),
    "tooth_count = [24.5, 26.0]": ("the ends must be whole numbers", "variables"),
    "evaluations = 3": ("[sizing] evaluations = 3: allowed range is at least population", "sizing"),
}


@pytest.mark.parametrize("line", sorted(REFUSALS))
def test_bad_sizing_values_are_refused_in_one_line(tmp_path, line):
    want, section = REFUSALS[line]
    text = TWO.format(evaluations=40, seed=1)
    text = text.replace(f"[sizing.{section}]\n", f"[sizing.{section}]\n{line}\n")
    if section == "sizing":
        key = line.split(" =")[0]
        text = "\n".join(ln for ln in text.splitlines() if not ln.startswith(key + " ="))
        text = text.replace("[sizing]\n", f"[sizing]\n{line}\n")
    if line.startswith("needle"):
        text = text.replace("[sizing]", "[life]\nneedles = 40\nneedle_diameter = 6.0\n"
                            "needle_length = 11.8\n\n[sizing]")  # fmt: skip
    (tmp_path / "s.toml").write_text(text)
    r = _cli("run", "s.toml", "--out", "out", cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert want in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_size_refuses_a_scene_without_sizing(tmp_path):
    r = _cli("size", str(ROOT / "templates" / "prototype.toml"), "--out", "o", cwd=tmp_path)
    assert r.returncode == 2
    assert "has no [sizing] section" in r.stderr and len(r.stderr.splitlines()) == 1


# --- the pieces: levels, front, hypervolume, candidate scenes --------------------------


def test_levels_are_the_grid_or_the_standard_sizes():
    from corr_cad.run.scene.scene_schema_sizing import variable_levels

    assert variable_levels("cam_radius", 130.0, 132.0) == (130.0, 130.5, 131.0, 131.5, 132.0)
    assert variable_levels("tooth_count", 23, 25) == (23.0, 24.0, 25.0)
    assert variable_levels("needle_length", 9.0, 14.0) == (9.8, 11.8, 13.8)
    assert variable_levels("module", 1.2, 2.0) == (1.25, 1.5, 2.0)


def test_front_and_hypervolume_by_hand():
    from corr_cad.run.stages.sizing_search import hypervolume_2d, non_dominated

    F = np.array([[1.0, 4.0], [2.0, 2.0], [3.0, 3.0], [4.0, 1.0], [2.0, 2.0]])
    assert non_dominated(F).tolist() == [0, 1, 3, 4]  # (3, 3) is dominated by (2, 2)
    # staircase up to (5, 5): (5-1)(5-4) + (5-2)(4-2) + (5-4)(2-1) = 4 + 6 + 1
    assert hypervolume_2d(F, np.array([5.0, 5.0])) == pytest.approx(11.0)


def test_a_small_space_is_searched_whole_each_candidate_once():
    """Six designs, a population of eight, 100 evaluations allowed: six evaluated, once each,
    the scene's own design first."""
    from corr_cad.run.stages.sizing_search import search

    levels = {"a": (1.0, 2.0), "b": (1.0, 2.0, 3.0)}

    def batch(values):
        return [{"feasible": True, "violation": 0.0, "x": v["a"], "y": v["a"] - v["b"]}
                for v in values]  # fmt: skip

    out = search(levels, ["mass", "rigidity"], {"mass": "x", "rigidity": "y"}, batch, 100, 8, 1,
                 start={"a": 2.0, "b": 2.9})  # fmt: skip
    seen = [(v["a"], v["b"]) for _, v, _ in out]
    assert len(seen) == 6 and len(set(seen)) == 6 and seen[0] == (2.0, 3.0)


def test_a_candidate_carries_the_rated_torque_to_the_output():
    """T_R = M0 (z + 1) without a first stage; with one, M0 = T_in z_c / z_p."""
    import tomllib

    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.sizing_candidates import candidate_data

    req = {"rated_torque_Nm": 3000.0, "rated_life_h": None, "rated_speed_rpm": 15.0}
    req.update(dict.fromkeys(("max_contact_pressure_MPa", "min_efficiency"), None))
    base = tomllib.loads(TWO.format(evaluations=40, seed=1))
    base = {k: v for k, v in base.items() if k not in ("sizing", "export")}
    s = parse_scene(candidate_data(base, {"tooth_count": 26}, req), "c")
    assert s.load.input_torque * 27 == pytest.approx(3.0e6, rel=1e-12)
    comp = tomllib.loads((ROOT / "templates" / "compound.toml").read_text())
    comp = {k: v for k, v in comp.items() if k not in ("checks", "export")}
    s = parse_scene(candidate_data(comp, {"pinion_teeth": 18}, req), "c")
    assert s.load.input_torque * 26 == pytest.approx(3.0e6, rel=1e-12)
    assert s.datasheet["rated_torque_Nm"] == 3000.0


@pytest.mark.slow
def test_screening_ranks_designs_as_the_full_resolution_does():
    """Along the cam radius and eccentricity, life, rigidity and mass keep their order and
    the life is within 1 %; the efficiency, wanted, is the full resolution's own."""
    import tomllib

    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.sizing_candidates import candidate_data, evaluate
    from corr_cad.run.stages.stages_sizing import spearman

    text = (ROOT / "templates" / "sizing.toml").read_text()
    sz = parse_scene(tomllib.loads(text), "t").sizing
    req = sz["requirements"]
    full, scr, eff = [], [], []
    for e, rj in ((3.1, 140.0), (3.4, 128.0), (3.7, 135.0), (3.8, 138.0)):
        v = {"eccentricity": e, "cam_radius": rj}
        full.append(evaluate(candidate_data(sz["base"], v, req), req))
        scr.append(evaluate(candidate_data(sz["base"], v, req, True, False), req))
        eff.append(evaluate(candidate_data(sz["base"], v, req, True, True), req))
    for col in ("life_h", "torsional_rigidity_Nm_per_arcmin", "mass_kg"):
        assert spearman([r[col] for r in scr], [r[col] for r in full]) == 1.0, col
    for a, b, c in zip(scr, full, eff, strict=True):
        assert a["life_h"] == pytest.approx(b["life_h"], rel=0.01)
        assert a["mass_kg"] == b["mass_kg"] and c["efficiency"] == b["efficiency"]


# --- the front against a brute-force grid -----------------------------------------------


@pytest.mark.slow
def test_the_front_agrees_with_a_brute_force_grid(tmp_path):
    """Eccentricity x cam radius (21 x 11 points), mass and rigidity.

    Every non-dominated grid point lies within 3 % of the objectives' ranges
    of a point of the search's front (130 evaluations of the 231), and the
    hypervolumes agree to 2 %.
    """
    import tomllib

    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.sizing_candidates import candidate_data, evaluate
    from corr_cad.run.stages.sizing_search import hypervolume_2d, non_dominated

    (tmp_path / "s.toml").write_text(TWO.format(evaluations=130, seed=3))
    r = _cli("run", "s.toml", "--out", "out", "--executor", "serial", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    front = np.array(
        [[float(p["mass_kg"]), -float(p["torsional_rigidity_Nm_per_arcmin"])]
         for p in _rows(tmp_path / "out" / "pareto.csv")]
    )  # fmt: skip
    sz = parse_scene(tomllib.loads((tmp_path / "s.toml").read_text()), "s").sizing
    grid = []
    for e in np.round(np.arange(3.0, 4.0 + 1e-9, 0.05), 10):
        for rj in np.arange(130.0, 135.0 + 1e-9, 0.5):
            row = evaluate(candidate_data(sz["base"], {"eccentricity": e, "cam_radius": rj},
                                          sz["requirements"]), sz["requirements"])  # fmt: skip
            if row["feasible"]:  # a large eccentricity on the small cam undercuts
                grid.append([row["mass_kg"], -row["torsional_rigidity_Nm_per_arcmin"]])
    grid = np.array(grid)
    assert len(grid) > 150
    best = grid[non_dominated(grid)]
    span = grid.max(axis=0) - grid.min(axis=0)
    for p in best:
        assert np.min(np.linalg.norm((front - p) / span, axis=1)) <= 0.03, p
    ref = grid.max(axis=0) + 0.1 * span
    assert hypervolume_2d(front, ref) == pytest.approx(hypervolume_2d(best, ref), rel=0.02)


# --- the prototype as the reference, and every design scene runs ----------------------


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory):
    """The template's search with requirements the prototype meets (1,800 N*m)."""
    tmp = tmp_path_factory.mktemp("ref")
    text = (ROOT / "templates" / "sizing.toml").read_text()
    text = text.replace("rated_torque_Nm = 2000.0", "rated_torque_Nm = 1800.0")
    (tmp / "s.toml").write_text(text)
    r = _cli("size", "s.toml", "--out", "out", "--workers", "2", cwd=tmp)
    assert r.returncode == 0, r.stderr
    return tmp / "out"


@pytest.mark.slow
def test_the_front_holds_the_prototype_or_a_design_at_least_as_good(reference_run):
    m = json.loads((reference_run / "manifest.json").read_text())["sizing"]
    ref = m["reference"]
    assert ref["feasible"]
    front = _rows(reference_run / "pareto.csv")
    as_good = [
        p for p in front
        if float(p["mass_kg"]) <= ref["mass_kg"] and float(p["life_margin"]) >= ref["life_margin"]
    ]  # fmt: skip
    assert as_good or any(p["candidate"] == "reference" for p in front)
    assert all(p["feasible"] == "true" and p["fidelity"] == "full" for p in front)
    # screening's figures of the front's designs within 3 % of the full resolution's
    assert all(v <= 0.03 for v in m["screening_max_relative_difference"].values())


@pytest.mark.slow
def test_every_design_scene_runs_and_reproduces_its_figures(reference_run, tmp_path):
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.profile import working_profile
    from corr_cad.run.scene.scene import load_scene
    from corr_cad.run.stages.sizing_candidates import second_stage_mass_inertia

    rows = _rows(reference_run / "pareto.csv")
    front = {p["design"]: p for p in rows if p["design"]}
    assert sorted(front) == sorted(p.name for p in reference_run.glob("design_*.toml"))
    assert rows[0]["design"] == "design_01.toml" and rows[-1]["design"] == max(front)  # both ends
    for name, p in sorted(front.items()):
        r = _cli("run", str(reference_run / name), "--out", name, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        sheet = json.loads((tmp_path / name / "datasheet.json").read_text())
        man = json.loads((tmp_path / name / "manifest.json").read_text())
        got = {
            "torsional_rigidity_Nm_per_arcmin": sheet["torsional_rigidity_Nm_per_arcmin"][
                "catalogue"
            ],
            "lost_motion_arcmin": sheet["lost_motion_arcmin"]["max"],
            "efficiency": sheet["efficiency_forward"]["min"],
            "life_h": sheet["life_h"]["system"],
            "peak_contact_pressure_MPa": man["checks"]["max_contact_pressure"]["value"],
        }
        s = load_scene(reference_run / name)
        outlines = part_outlines(s.design, working_profile(s.design), s.tolerance)
        got["mass_kg"], got["input_inertia_kg_m2"] = second_stage_mass_inertia(s.design, outlines)
        for col, v in got.items():
            assert v == pytest.approx(float(p[col]), rel=1e-9), (name, col)
        assert all(c["passed"] for c in man["checks"].values())


# --- reproducible on every executor ------------------------------------------------------


@pytest.mark.slow
def test_the_same_seed_gives_the_same_bytes_serial_pool_and_dask(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    (tmp_path / "s.toml").write_text(TWO.format(evaluations=40, seed=7))
    runs = {
        "serial": ("--executor", "serial"),
        "pool": ("--executor", "process", "--workers", "2"),
    }
    for name, flags in runs.items():
        r = _cli("run", "s.toml", "--out", name, "--quiet", *flags, cwd=tmp_path)
        assert r.returncode == 0, r.stderr
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        r = _cli("run", "s.toml", "--out", "dask", "--quiet", "--executor", "dask",
                 "--scheduler", cluster.scheduler_address, cwd=tmp_path)  # fmt: skip
    assert r.returncode == 0, r.stderr
    want = (tmp_path / "serial" / "sizing.csv").read_bytes()
    assert len(_rows(tmp_path / "serial" / "sizing.csv")) >= 40
    for name in ("pool", "dask"):
        assert (tmp_path / name / "sizing.csv").read_bytes() == want, name
        assert (tmp_path / name / "pareto.csv").read_bytes() == (
            tmp_path / "serial" / "pareto.csv"
        ).read_bytes()


# --- nothing fits -------------------------------------------------------------------------


@pytest.mark.slow
def test_infeasible_requirements_name_the_binding_one(tmp_path):
    """50,000 N*m under 200 mm: exit 1, one line naming what binds, the files still written."""
    text = """
[design]
tooth_count = 25
cam_radius = 70.0
roller_radius = 4.0
roller_length = 12.0
eccentricity = 1.5

[life]
needles = 30
needle_diameter = 4.0
needle_length = 11.8

[sizing]
objectives = ["mass", "life_margin"]
evaluations = 24
population = 8

[sizing.requirements]
rated_torque_Nm = 50000.0
rated_life_h = 6000.0
max_outer_diameter_mm = 200.0

[sizing.variables]
cam_radius = [60.0, 75.0]
eccentricity = [1.0, 1.8]

[export]
formats = ["sizing", "report"]
"""
    (tmp_path / "s.toml").write_text(text)
    r = _cli("run", "s.toml", "--out", "out", cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    last = without_progress(r.stderr).strip().splitlines()
    assert len(last) == 1 and "Traceback" not in r.stderr
    line = last[0]
    assert line.startswith("corr-cad: no design fits: the best design within ")
    assert "max_outer_diameter_mm 200" in line and " binds (" in line
    assert "rated_life_h binds" in line or "max_contact_pressure_MPa binds" in line
    assert "would fit" in line
    for f in ("sizing.csv", "pareto.csv", "pareto.png", "manifest.json"):
        assert (tmp_path / "out" / f).is_file()
    assert _rows(tmp_path / "out" / "pareto.csv") == []
    html = (tmp_path / "out" / "report.html").read_text()  # the report's section says it too
    assert "Design from requirements" in html and "no design fits: the best design" in html


def test_the_budget_refuses_a_search_whose_files_would_not_fit(tmp_path):
    """The estimate counts sizing.csv's rows: 100,000 evaluations pass a 1 MB output budget."""
    (tmp_path / "s.toml").write_text(TWO.format(evaluations=100_000, seed=1))
    r = _cli("run", "s.toml", "--out", "out", "--max-output", "0.001", cwd=tmp_path)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert r.stderr.startswith("corr-cad: error: [sizing] evaluations = 100000: ")
    assert "would fit" in r.stderr and not (tmp_path / "out").exists()


def test_the_values_that_would_fit_are_rounded_towards_fitting():
    """A limit relaxed to three digits, never past what the design reaches."""
    from corr_cad.run.stages.sizing_report import relaxations

    row = {
        "violations": {"rated_life_h": 0.5, "max_outer_diameter_mm": 0.07, "max_mass_kg": 0.0},
        "life_h": 2999.7,
        "outer_diameter_mm": 341.2,
        "rated_torque_from_life_Nm": 2604.9,
    }
    assert relaxations(row, {}) == [
        "rated_life_h 2,990",  # the life reached, rounded down
        "rated_torque_Nm 2,600",  # the torque at which it reaches the rated life, down
        "max_outer_diameter_mm 342",  # the diameter reached, rounded up
    ]


def test_screening_lowers_the_resolution_and_keeps_the_model():
    """[life] alone computes the friction figures: screening takes one position per mesh
    and the efficiency at T_R alone (not where the efficiency is wanted); the model stays."""
    from corr_cad.run.stages.sizing_candidates import candidate_data

    req = {"rated_torque_Nm": 2000.0, "rated_life_h": 6000.0, "rated_speed_rpm": 15.0}
    base = {"life": {"needles": 40}, "solver": {"model": "drive"}}
    full = candidate_data(base, {}, req)
    scr = candidate_data(base, {}, req, screening=True, efficiency=False)
    assert "friction" not in full and full["solver"] == {"model": "drive"}
    assert scr["friction"] == {"positions_per_mesh": 1, "efficiency_torques": [1.0]}
    assert scr["solver"] == {"model": "drive", "positions": 360}
    assert scr["datasheet"]["positions_per_mesh"] == 4
    kept = candidate_data(base, {}, req, screening=True, efficiency=True)
    assert "friction" not in kept  # the efficiency wanted: the scene's own resolution


def test_a_knife_edge_tooth_is_refused_with_the_run_s_own_warning():
    """e = 3.85 mm on a 129 mm cam: a tooth tip of 0.039 mm, which `corr-cad run` warns of."""
    from corr_cad.run.stages.sizing_candidates import candidate_data, evaluate

    req = {"rated_torque_Nm": 2000.0, "rated_life_h": None, "rated_speed_rpm": 15.0}
    row = evaluate(candidate_data({}, {"cam_radius": 129.0, "eccentricity": 3.85}, req), req)
    assert (row["feasible"], row["refused_by"]) == (False, "geometry")
    assert row["reason"].startswith("tooth tip radius 0.0386 mm is below 0.1 mm (a knife edge")
