"""Robustness: fuzzed scenes and measured data, instrumentation, determinism, containment."""

import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from corr_cad import CorrCadError, ProfileError, SceneError, working_profile
from corr_cad.export.measured_io import read_measured_points
from corr_cad.mechanics.row import solver_geometry
from corr_cad.run.folder.outputs import StagingDir
from corr_cad.run.pipeline import run_scene
from corr_cad.run.scene.scene import SCHEMA, parse_scene
from corr_cad.tolerance.measured import validate_points

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**12), 10**12),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)
values = st.recursive(
    scalars,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=3)
    ),
    max_leaves=8,
)
key_names = st.sampled_from([k for keys in SCHEMA.values() for k in keys] + ["bogus", "z", ""])
section_names = st.sampled_from([*SCHEMA, "extra", "Design"])
scenes = st.dictionaries(
    section_names, st.one_of(st.dictionaries(key_names, values, max_size=5), values), max_size=4
)


@pytest.mark.slow
@settings(max_examples=300)
@given(scenes)
def test_scene_loader_never_fails_otherwise(data):
    # Every input either validates or raises the one-line SceneError.
    try:
        scene = parse_scene(data)
    except SceneError as exc:
        assert "\n" not in str(exc) and str(exc)
    else:
        assert scene.design.tooth_count >= 3


BAD_SCENES = [
    "[design]\ntooth_count = 1e400\n",
    "[design]\ncam_radius = inf\n",
    "[export]\nformats = [[1]]\n",
    '[tolerances]\nroller_radius = { normal = "a" }\n',
    "[errors]\nroller_radius_errors = [1, 2, 3]\n",
    "\x00\x01",
    "[[design]]\n",
    '[solver]\nvariants = ["eq3_printed", "eq3_printed"]\n',
]


@pytest.mark.parametrize("text", BAD_SCENES)
def test_bad_scene_files_exit_2_one_line_no_output(tmp_path, text):
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


@settings(max_examples=60)
@given(st.text(alphabet="xy,0123456789.-e\n nan", max_size=300))
def test_measured_reader_fuzz(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("m") / "p.csv"
    path.write_text(text)
    from corr_cad import GearDesign

    w = working_profile(GearDesign())
    try:
        validate_points(read_measured_points(path), w, "p.csv")
    except ProfileError as exc:
        assert "\n" not in str(exc)


def test_scene_without_errors_never_builds_error_terms(tmp_path, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("error terms built for a scene without errors")

    monkeypatch.setattr(solver_geometry, "_error_gaps", boom)
    data = {
        "export": {"formats": ["forces"]},
        "load": {"input_torque": 1e5},
        "solver": {"positions": 52},
    }
    with StagingDir(tmp_path / "o") as stage:
        run_scene(parse_scene(data), stage)
    data["errors"] = {"cam_radius_error": 0.001}
    with (
        pytest.raises(AssertionError, match="error terms built"),
        StagingDir(tmp_path / "p") as stage,
    ):
        run_scene(parse_scene(data), stage)


def test_meshes_are_deterministic_too(tmp_path):
    data = {"export": {"formats": ["stl", "dxf"], "chord_tolerance": 0.01}}
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        with StagingDir(out) as stage:
            run_scene(parse_scene(data), stage)
    for f in ("inner_gear.stl", "assembly_000deg.stl", "teeth_frame.stl", "inner_gear.dxf"):
        assert (a / f).read_bytes() == (b / f).read_bytes(), f


@pytest.mark.slow
def test_out_never_writes_outside_the_chosen_folder(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text('[export]\nformats = ["dxf", "png"]\n')
    before = {p for p in tmp_path.rglob("*")}
    out = tmp_path / "deep" / "out"
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    new = {p for p in tmp_path.rglob("*")} - before
    assert all(p == tmp_path / "deep" or out in p.parents or p == out for p in new)


def test_errors_are_corrcad_errors():
    # Every error a user can cause is one tree (and a built-in).
    for cls in (SceneError, ProfileError):
        assert issubclass(cls, CorrCadError) and issubclass(cls, ValueError)


def test_bench_quick_writes_tables_and_plots(tmp_path):
    from corr_cad.run.bench.bench import run

    rows = run(tmp_path, ["solids"], quick=True)
    assert len(rows["solids"]) == 3
    assert (tmp_path / "mesh_tolerance.csv").exists() and (tmp_path / "mesh_tolerance.png").exists()
    errs = [abs(r[3]) for r in rows["solids"]]
    assert errs[0] > errs[1] > errs[2]  # finer chords, smaller volume error


def test_manifest_lists_stages_with_times(tmp_path):
    import json

    scene = tmp_path / "s.toml"
    scene.write_text('[export]\nformats = ["dxf"]\n')
    out = tmp_path / "o"
    subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(out), "--quiet"],
        check=True,
    )
    m = json.loads(Path(out / "manifest.json").read_text())
    assert [s["name"] for s in m["stages"]] == ["undercut", "profiles", "dxf_geometry", "dxf_files"]
    assert all(s["seconds"] >= 0 for s in m["stages"])


def test_bench_study_names_in_the_cli_are_the_bench_studies():
    """The CLI lists them without importing the bench (cold start); they must agree."""
    import argparse

    from corr_cad.run import cli
    from corr_cad.run.bench import bench

    sub = next(a for a in cli._parser()._actions if isinstance(a, argparse._SubParsersAction))
    study = next(a for a in sub.choices["bench"]._actions if "--study" in a.option_strings)
    assert tuple(study.choices) == tuple(bench.STUDIES)
