"""The Python API: exports, docstring examples, docs/api.md and examples/quickstart.py run."""

from __future__ import annotations

import doctest
import importlib
import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import ezdxf
import pytest

import corr_cad as cc

ROOT = Path(__file__).resolve().parents[1]

#: Modules whose docstring examples are executed.
DOCTEST_MODULES = [
    "corr_cad",
    "corr_cad.geometry.profile",
    "corr_cad.geometry.sampling",
    "corr_cad.mechanics.row.solver",
    "corr_cad.mechanics.row.windup",
    "corr_cad.mechanics.datasheet",
    "corr_cad.tolerance.montecarlo",
    "corr_cad.run.scene.scene",
    "corr_cad.run.pipeline",
    "corr_cad.tolerance.sweeps",
    "corr_cad.run.scene.schema_json",
    "corr_cad.export.plots",
    "corr_cad.run.bench.bench_scaling",
    "corr_cad.run.bench.bench_progress",
]
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def test_top_level_exports():
    for name in (
        "GearDesign",
        "Material",
        "load_scene",
        "run_scene",
        "solve_forces",
        "ForceResult",
        "monte_carlo",
        "allocate",
        "working_profile",
        "approximate",
        "CorrCadError",
        "DesignError",
        "SceneError",
        "SolverError",
        "ExportError",
        "ProfileError",
        "UndercutError",
    ):
        assert name in cc.__all__ and getattr(cc, name) is not None, name
    for name in cc.__all__:
        getattr(cc, name)
    with pytest.raises(AttributeError):
        cc.no_such_thing  # noqa: B018


def test_import_is_lazy_and_the_solver_loads_on_first_use():
    code = (
        "import sys, corr_cad; "
        "assert 'corr_cad.tolerance.montecarlo' not in sys.modules and 'jinja2' not in sys.modules "
        "and 'matplotlib' not in sys.modules; "
        "corr_cad.monte_carlo; assert 'corr_cad.tolerance.montecarlo' in sys.modules; print('ok')"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "ok"


def test_admissible_roller_radius_takes_a_design_and_still_takes_scalars():
    d = cc.GearDesign(tooth_count=39, eccentricity=2.0, roller_radius=6.0)
    r = cc.admissible_roller_radius(d)
    assert r == cc.admissible_roller_radius(39, 2.0, 135.0)
    # The limit is where the undercut starts (the design's own r is ignored).
    for share, undercut in ((1 - 1e-6, False), (1 + 1e-6, True)):
        probe = replace(d, roller_radius=r * share, allow_undercut=True, ring_outer_radius=None)
        assert cc.undercut_analysis(probe).undercut is undercut
    with pytest.raises(TypeError):
        cc.admissible_roller_radius(d, 2.0)
    with pytest.raises(TypeError):
        cc.admissible_roller_radius(39, 2.0)


@pytest.mark.parametrize("module", DOCTEST_MODULES)
def test_docstring_examples_run(module):
    res = doctest.testmod(importlib.import_module(module), optionflags=FLAGS, verbose=False)
    assert res.failed == 0


def test_docstring_examples_exist_on_the_public_functions():
    for fn in (
        cc.solve_forces,
        cc.monte_carlo,
        cc.allocate,
        cc.load_scene,
        cc.run_scene,
        cc.working_profile,
        cc.approximate,
        cc.admissible_roller_radius,
    ):
        assert ">>>" in (fn.__doc__ or ""), fn.__name__


def test_docs_api_md_runs():
    res = doctest.testfile(str(ROOT / "docs" / "api.md"), module_relative=False, optionflags=FLAGS)
    assert res.attempted > 30 and res.failed == 0


def test_quickstart_runs_and_its_numbers_hold(tmp_path):
    out = tmp_path / "qs"
    run = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "quickstart.py"), str(out)],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
    )
    text = run.stdout
    # The printed undercut limit is where the undercut starts.
    r_max = float(re.search(r"rollers up to ([\d.]+) mm", text).group(1))
    d = cc.GearDesign(tooth_count=39, eccentricity=2.0, roller_radius=6.0, allow_undercut=True)
    assert not cc.undercut_analysis(replace(d, roller_radius=r_max - 1e-3)).undercut
    assert cc.undercut_analysis(replace(d, roller_radius=r_max + 1e-3)).undercut
    for name in ("inner_gear.dxf", "disk_cam.dxf", "roller.dxf", "teeth_frame.dxf"):
        doc = ezdxf.readfile(out / name)
        assert len(doc.modelspace()) > 0
    assert re.search(r"peak gear force \d+ N on roller \d+", text)
    assert "Monte Carlo: p95 peak gear force" in text
