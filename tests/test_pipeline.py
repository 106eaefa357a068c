"""The stage graph: only what a scene asks for runs; outputs are atomic and deterministic."""

import json
import shutil
from pathlib import Path

import pytest

from corr_cad.run import pipeline
from corr_cad.run.folder.outputs import StagingDir
from corr_cad.run.scene.scene import parse_scene

PROTO = {
    "export": {"formats": ["dxf", "png", "forces"], "representation": "arcs"},
    "load": {"input_torque": 1.1e5},
    "solver": {"positions": 260},
}


def _scene(**over):
    data = {k: dict(v) for k, v in PROTO.items()}
    for k, v in over.items():
        data.setdefault(k, {}).update(v)
    return parse_scene(data, name="t")


def test_plan_is_minimal_and_ordered():
    assert pipeline.plan(("dxf",)) == ["undercut", "profiles", "dxf_geometry", "dxf_files"]
    assert pipeline.plan(("forces",)) == ["undercut", "forces", "force_files"]
    assert pipeline.plan(("png",)) == ["undercut", "profiles", "preview_png"]
    assert pipeline.plan(("stl", "glb")) == ["undercut", "profiles", "solids", "mesh_files"]
    assert pipeline.plan(("step",)) == ["undercut", "profiles", "step_files"]
    from corr_cad.run.scene.scene import FORMATS

    full = pipeline.plan(
        FORMATS, checks=True, measured=True, interference_method="both", first_stage=True
    )
    assert len(full) == len(set(full)) == len(pipeline.STAGES)
    assert pipeline.plan(("forces",), checks=True) == [
        "undercut",
        "forces",
        "force_files",
        "checks",
    ]
    assert pipeline.plan(("dxf",), checks=False)[-1] == "dxf_files"
    for name in full:
        for dep in pipeline.STAGES[name].requires:
            assert full.index(dep) < full.index(name)


def _run(scene, out):
    with StagingDir(out) as stage:
        return pipeline.run_scene(scene, stage)


def _patch_everywhere(monkeypatch, name: str, fn) -> None:
    """Replace ``name`` in every stage module that binds it (and where it is defined)."""
    import importlib
    import pkgutil

    import corr_cad.run

    hits = 0
    for info in pkgutil.walk_packages(corr_cad.run.__path__, "corr_cad.run."):
        mod = importlib.import_module(info.name)
        if hasattr(mod, name):
            monkeypatch.setattr(mod, name, fn)
            hits += 1
    assert hits, name


def test_dxf_only_never_touches_the_solver_or_the_mesher(tmp_path, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("solver or mesher called for a DXF-only scene")

    from corr_cad.export import mesh

    _patch_everywhere(monkeypatch, "solve_forces", boom)
    monkeypatch.setattr(mesh, "solid", boom)
    m = _run(_scene(export={"formats": ["dxf"]}), tmp_path / "o")
    assert [s["name"] for s in m["stages"]] == pipeline.plan(("dxf",))
    assert sorted(m["files"]) == ["disk_cam.dxf", "inner_gear.dxf", "roller.dxf", "teeth_frame.dxf"]


def test_forces_only_never_approximates_the_profile(tmp_path, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("profile approximated for a forces-only scene")

    _patch_everywhere(monkeypatch, "approximate", boom)
    m = _run(_scene(export={"formats": ["forces"]}), tmp_path / "o")
    assert "forces" in m and "accuracy" not in m


def test_crank_angles_solve_exactly_those_positions(tmp_path):
    scene = _scene(export={"formats": ["forces"]}, solver={"crank_angles_deg": [0.0, 5.0, 10.0]})
    out = tmp_path / "o"
    _run(scene, out)
    summary = json.loads((out / "forces_summary.json").read_text())
    assert summary["solver"]["positions_solved"] == 3 and summary["solver"]["positions"] == 3
    lines = (out / "forces.csv").read_text().splitlines()
    assert lines[0] == "crank_angle_deg,roller,psi_deg,F_j,F_s,F_n,p_cam,p_slot,p_gear"
    assert len(lines) == 1 + 3 * 26


def test_manifest_records_what_ran(tmp_path):
    out = tmp_path / "o"
    m = _run(_scene(), out)
    on_disk = json.loads((out / "manifest.json").read_text())
    assert on_disk == m
    import hashlib

    for name, meta in m["files"].items():
        assert hashlib.sha256((out / name).read_bytes()).hexdigest() == meta["sha256"]
    acc = m["accuracy"]["working_profile"]
    assert acc["max_deviation_mm"] <= acc["tolerance_mm"] == 0.001
    assert m["undercut"]["undercut"] is False
    assert {"numpy", "ezdxf", "scipy", "numba", "matplotlib", "pillow"} <= set(m["versions"])
    from importlib import metadata

    assert m["versions"]["numba"] == metadata.version("numba")
    assert m["versions"]["numpy"] == metadata.version("numpy")
    assert [s["name"] for s in m["stages"]] == pipeline.plan(("dxf", "png", "forces"))
    summary = json.loads((out / "forces_summary.json").read_text())
    for key in (
        "F_j_mean",
        "F_n_mean",
        "F_s_mean",
        "F_j_peak",
        "F_n_peak",
        "F_s_peak_to_peak",
        "p_max",
    ):
        assert summary[key] > 0
    # 13 rollers carry load; 12 where one sits exactly at the edge of the loaded zone.
    assert (summary["loaded_rollers_min"], summary["loaded_rollers_max"]) == (12, 13)


@pytest.mark.slow
def test_outputs_are_deterministic(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    ma, mb = _run(_scene(), a), _run(_scene(), b)
    for name in ma["files"]:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    strip = lambda m: {k: v for k, v in m.items() if k != "stages"}  # noqa: E731
    assert strip(ma) == strip(mb)


def test_failed_run_leaves_previous_outputs(tmp_path, monkeypatch):
    out = tmp_path / "o"
    _run(_scene(export={"formats": ["dxf"]}), out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def fail_after_writing(ctx):
        (ctx.out / "inner_gear.dxf").write_text("half")
        raise KeyboardInterrupt  # simulated interruption mid-write

    stage = pipeline.STAGES["dxf_files"]
    monkeypatch.setitem(
        pipeline.STAGES,
        "dxf_files",
        stage.__class__(stage.name, stage.requires, fail_after_writing, stage.doc),
    )
    with pytest.raises(KeyboardInterrupt):
        _run(_scene(export={"formats": ["dxf"]}), out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir()] == ["o"]  # no staging debris


def test_staging_replaces_previous(tmp_path):
    out = tmp_path / "o"
    # names a run can write (a run may stage nothing else: run/folder/names.py)
    with StagingDir(out) as s:
        Path(s, "forces.csv").write_text("1")
    with StagingDir(out) as s:
        Path(s, "preview.png").write_text("2")
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "preview.png"]
    assert set(json.loads((out / "manifest.json").read_text())["files"]) == {"preview.png"}
    shutil.rmtree(out)


def test_worker_stages_only_beside_other_work():
    from corr_cad.run.stages.concurrent import worker_stages

    assert worker_stages(pipeline.plan(("step",))) == ()  # nothing to overlap it with
    assert worker_stages(pipeline.plan(("dxf", "forces"))) == ()
    assert worker_stages(pipeline.plan(("png", "step"))) == ("step_files",)


FAIL_BESIDE_THE_WORKER = """
import os, sys, time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
import psutil
from corr_cad.run import pipeline
from corr_cad.run.cli import _worker_init
from corr_cad.errors import SolverError
from corr_cad.run.scene.scene import parse_scene

def boom(ctx):
    # Fail once the worker has begun writing STEP files (four more to come).
    while not any(n.endswith(".step") for n in os.listdir(ctx.out)):
        time.sleep(0.005)
    raise SolverError("boom")

pipeline.STAGES["preview_png"] = replace(pipeline.STAGES["preview_png"], run=boom)
scene = parse_scene({"export": {"formats": ["png", "step"], "chord_tolerance": 0.05}}, "t")
out = Path(sys.argv[1])
pool = ProcessPoolExecutor(2, initializer=_worker_init, initargs=(os.getpid(),))
try:
    pipeline.run_scene(scene, out, executor=pool, concurrent_stages=True)
except SolverError:
    pass
# Returned: the worker is dead already, so nothing more is written.
print(len(psutil.Process().children(recursive=True)))
names = sorted(os.listdir(out))
time.sleep(3.0)
print(names == sorted(os.listdir(out)))
"""


@pytest.mark.slow
def test_a_failing_stage_kills_the_step_worker_before_returning(tmp_path):
    import subprocess
    import sys

    r = subprocess.run(
        [sys.executable, "-c", FAIL_BESIDE_THE_WORKER, str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["0", "True"]
