"""Every format with every optional section, through the real CLI, at small sizes.

A combination of formats and sections that no test ran once crashed the
last stage (the report, on the Monte Carlo's datasheet metrics) and lost
the whole run. Here ``formats = ["all"]`` runs with every section of the
scene schema set, twice: on the design's own ring (everything but the
inspection) and on a measured ring (the inspection too), and once more under
the two-row drive model (all but the one-row formats). ``[dask]`` is
parsed, but the runs use the process pool (a cluster is the work of
tests/test_dask_faults.py). Each run must exit 0, print no traceback,
write every file its formats declare and show every Monte Carlo metric in
the report.

Then a stage that raises something unexpected (injected in-process) must
end the run with one line, exit 3, and leave the previous outputs as they
were: a run keeps all its files or none.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from tests.helpers import without_progress

Z, E, RJ, R = 9, 1.5, 45.0, 4.0

SECTIONS = f"""
[design]
tooth_count = {Z}
cam_radius = {RJ}
roller_radius = {R}
eccentricity = {E}
[material]
young_modulus = 206000.0
[export]
formats = ["all"]
tolerance = 0.01
chord_tolerance = 0.05
interference_method = "both"
interference_positions = 2
[load]
input_torque = 2.0e4
[solver]
positions = 40
[tolerances]
roller_radius = {{ uniform = 0.001 }}
cam_radius = {{ uniform = 0.002 }}
[montecarlo]
samples = 12
positions = 20
allocation_samples = 8
datasheet_positions_per_mesh = 2
seed = 1
[checks]
max_contact_pressure = 4000.0
max_failure_probability = 0.5
max_binding_probability = 0.5
max_lost_motion_arcmin = 30.0
[datasheet]
positions_per_mesh = 2
transmission_error_positions_per_turn = 36
[sweeps]
points = 2
positions = 20
[edm]
wire_diameter = 0.25
[inspection]
profile_tolerance = 0.05
[modification]
equidistant_mm = 0.002
[modification.design]
target_backlash_arcmin = 20.0
max_binding_probability = 0.5
family = "equidistant"
steps = 2
samples = 10
positions = 16
force_candidates = 1
[assembly]
roller_classes_um = [-2.0, 0.0]
target_backlash_arcmin = 20.0
[budget]
time_warning_s = 3600
[dask]
connect_timeout_s = 5.0
[friction]
mu_cam = 0.05
efficiency_torques = [0.5, 1.0]
efficiency_speeds_rpm = [1000.0]
[life]
montecarlo_samples = 4
[first_stage]
pinion_teeth = 18
wheel_teeth = 36
crank_gear_teeth = 90
module = 1.5
shift_pinion = 0.5
shift_crank_gear = 0.5
face_width = 15.0
backlash_allowance = 0.03
"""

#: The design's own ring: the roller radius error gives the clearance.
NOMINAL = SECTIONS + "[errors]\nroller_radius_error = -0.002\n"
#: A measured ring (no [modification]: the measurement is the ring).
MEASURED = (
    SECTIONS.replace("[modification]\nequidistant_mm = 0.002\n", "")
    + '[errors]\nmeasured_profile = "cmm.csv"\nroller_radius_error = -0.002\n'
)
#: The two-row drive on Palmgren's law, both cams on needles, row B's own rollers; the
#: Monte Carlo and allocation gate binding and lost motion on the drive too.
DRIVE = (
    NOMINAL.replace(
        "[solver]\npositions = 40\n",
        '[solver]\npositions = 40\nmodel = "drive"\ncontact_law = "palmgren"\n',
    )
    # 20 needles of 4 mm fit on this design's pitch circle (27.4 mm; 21 at most)
    + "[bearings.eccentric]\nneedles = 20\nneedle_diameter = 4.0\nneedle_length = 10.0\n"
    + "[errors.row_b]\nroller_radius_error = -0.001\n"
)
#: The drive's Monte Carlo metrics: the force metrics over both rows and the datasheet's.
DRIVE_METRICS = {
    "peak_gear_force",
    "peak_pressure",
    "min_loaded_rollers",
    "backlash_arcmin",
    "lost_motion_arcmin",
    "torsional_rigidity_Nm_per_arcmin",
    "transmission_error_arcsec",
    "binding_pressure_MPa",
}


def _measured_points(m: int = 40) -> np.ndarray:
    """The working profile from its closed form: roller centre
    ``s = e cos psi + sqrt(L^2 - e^2 sin^2 psi)`` (``psi = z t``), offset by ``r``."""
    t = (np.arange(Z * m) + 0.5) / (Z * m) * 2 * math.pi
    ll = RJ + R
    psi = Z * t
    w = np.sqrt(ll * ll - (E * np.sin(psi)) ** 2)
    s = E * np.cos(psi) + w
    ds = -Z * E * np.sin(psi) * s / w
    ur = np.stack([np.sin(t), np.cos(t)], -1)
    ut = np.stack([np.cos(t), -np.sin(t)], -1)
    n = s[:, None] * ur - ds[:, None] * ut
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return s[:, None] * ur + R * n


def _cli(folder, scene_text: str):
    (folder / "s.toml").write_text(scene_text)
    (folder / "notes.txt").write_text("the user's own file\n")
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--workers", "2"],
        cwd=folder,
        capture_output=True,
        text=True,
    )


def _check_run(folder, r, drive: bool = False) -> dict:
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Traceback" not in r.stderr, r.stderr[-3000:]
    out = folder / "out"
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["complete"] is True
    on_disk = {p.name for p in out.iterdir()} - {"manifest.json"}
    assert set(manifest["files"]) == on_disk
    for name, entry in manifest["files"].items():
        assert (out / name).stat().st_size == entry["bytes"] > 0, name
    assert (folder / "notes.txt").read_text() == "the user's own file\n"
    # The report shows every Monte Carlo metric, the datasheet's among them,
    # with its label and unit (no raw column name).
    from corr_cad.export.report import METRIC_LABELS

    html = (out / "report.html").read_text(encoding="utf-8")
    summary = json.loads((out / "montecarlo_summary.json").read_text())
    for metric in summary["percentiles"]:
        assert METRIC_LABELS[metric][0] in html, metric
    if drive:  # both rows' metrics, row B's magnitudes in the table, the model stated
        assert set(summary["percentiles"]) == DRIVE_METRICS
        with open(out / "montecarlo.csv") as f:
            header = f.readline().strip().split(",")
        assert DRIVE_METRICS <= set(header) and "roller_radius_row_b_magnitude" in header
        assert summary["model"]["model"] == "drive" and "binding" in summary["model"]
        assert "Wilson interval" in html
        return manifest
    assert "lost_motion_arcmin" in summary["percentiles"]
    assert "Wilson interval" in html  # the binding gate's share of binding samples
    return manifest


@pytest.mark.slow
def test_all_formats_with_every_section_on_the_design_s_ring(tmp_path):
    r = _cli(tmp_path, NOMINAL)
    m = _check_run(tmp_path, r)
    left = dict(m.get("formats_left_out", {}))
    # no measured ring here; no [sizing.requirements]: "all" sizes nothing, saying why
    assert set(left) <= {"inspection", "sizing"}, left
    assert left.get("sizing", "no [sizing.requirements]").startswith("no [sizing.requirements]")
    expected = {
        "roller.dxf", "preview.png", "forces.csv", "roller.stl", "roller.3mf", "roller.glb",
        "roller.ply", "montecarlo.csv", "allocation.csv", "sweeps.json", "datasheet.json",
        "inner_gear_edm.nc", "inner_gear_nominal.csv", "modification.json", "assembly.json",
        "clearance.csv", "report.html", "efficiency.csv", "life.csv", "pinion.dxf",
        "crank_gear.dxf", "wheel.stl",
    }  # fmt: skip
    if "step" not in left:
        expected.add("roller.step")
    assert expected <= set(m["files"]), expected - set(m["files"])
    assert m["interference"]["positions"] == 2  # the mesh booleans ran too


@pytest.mark.slow
def test_all_formats_with_every_section_on_a_measured_ring(tmp_path):
    pts = _measured_points()
    (tmp_path / "cmm.csv").write_text(
        "x,y\n" + "\n".join(f"{x:.10f},{y:.10f}" for x, y in pts) + "\n"
    )
    r = _cli(tmp_path, MEASURED)
    m = _check_run(tmp_path, r)
    assert "inspection" not in dict(m.get("formats_left_out", {}))
    assert {"inspection.csv", "inspection.json", "measured_profile.dxf"} <= set(m["files"])


@pytest.mark.slow
def test_all_formats_with_every_section_under_the_drive_model(tmp_path):
    """The two-row drive: every format but the one-row one (inspection), which "all"
    leaves out with the reason; the modification is designed on the drive."""
    r = _cli(tmp_path, DRIVE)
    m = _check_run(tmp_path, r, drive=True)
    left = dict(m.get("formats_left_out", {}))
    assert set(left) == {"inspection", "sizing"}, left  # sizing: no requirements given
    assert left["inspection"] == "no [errors] measured_profile"  # no measured ring here
    expected = {
        "roller.dxf", "preview.png", "forces.csv", "forces_summary.json", "roller.stl",
        "roller.3mf", "roller.glb", "roller.ply", "montecarlo.csv", "allocation.csv",
        "sweeps.json", "datasheet.json", "datasheet.html", "windup.csv", "inner_gear_edm.nc",
        "inner_gear_nominal.csv", "assembly.json", "clearance.csv", "report.html",
        "efficiency.csv", "life.csv", "hysteresis.csv", "pinion.dxf", "crank_gear.dxf",
        "wheel.stl", "modification.json", "modified.toml",
    }  # fmt: skip
    if "step" not in left:
        expected.add("roller.step")
    assert expected <= set(m["files"]), expected - set(m["files"])
    sheet = json.loads((tmp_path / "out" / "datasheet.json").read_text())
    assert sheet["model"] == "drive"
    assert 'model = "drive"' in (tmp_path / "out" / "modified.toml").read_text()
    assert m["interference"]["positions"] == 2


SMALL = """
[export]
formats = ["dxf", "forces", "report"]
[load]
input_torque = 1.1e5
[solver]
positions = 26
"""


def _in_process(out, scene, *extra):
    from corr_cad.run.cli import main

    return main(["run", str(scene), "--out", str(out), "--executor", "serial", *extra])


def test_an_unexpected_error_in_a_late_stage_is_one_line_exit_3_and_loses_nothing(
    tmp_path, monkeypatch, capsys
):
    """A bug in the last stage: one line naming the stage, the error and what was
    discarded (exit 3, not the 1 of a failed check), the previous outputs intact."""
    from corr_cad.run.stages import stages
    from corr_cad.run.stages.context import Stage

    scene = tmp_path / "s.toml"
    scene.write_text(SMALL)
    out = tmp_path / "out"
    assert _in_process(out, scene, "--quiet") == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()

    def broken(ctx):
        raise KeyError("lost_motion_arcmin")

    old = stages.STAGES["report"]
    monkeypatch.setitem(stages.STAGES, "report", Stage("report", old.requires, broken, old.doc))
    monkeypatch.delenv("CORR_CAD_DEBUG", raising=False)
    assert _in_process(out, scene) == 3
    err = without_progress(capsys.readouterr().err).strip().splitlines()
    assert len(err) == 1, err
    line = err[0]
    assert line.startswith("corr-cad: internal error in stage report (KeyError:"), line
    assert "'lost_motion_arcmin'" in line and "Traceback" not in line
    # What was lost: the finished stages' files, discarded with the run.
    assert "files staged by undercut, profiles, dxf_geometry, dxf_files, forces" in line
    assert f"{out} holds its previous outputs" in line
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # nothing moved
    # CORR_CAD_DEBUG=1 adds the traceback before the line.
    monkeypatch.setenv("CORR_CAD_DEBUG", "1")
    assert _in_process(out, scene, "--quiet") == 3
    err = capsys.readouterr().err
    assert "Traceback" in err and "KeyError" in err
    assert err.strip().splitlines()[-1].startswith("corr-cad: internal error in stage report")


def test_an_unexpected_error_after_the_commit_says_the_files_are_in_place(
    tmp_path, monkeypatch, capsys
):
    from corr_cad.run import console

    scene = tmp_path / "s.toml"
    scene.write_text(SMALL)
    out = tmp_path / "out"

    def broken(manifest, out):
        raise ValueError("summary")

    monkeypatch.setattr(console, "summary_lines", broken)
    monkeypatch.delenv("CORR_CAD_DEBUG", raising=False)
    assert _in_process(out, scene) == 3
    err = without_progress(capsys.readouterr().err).strip().splitlines()
    assert len(err) == 1, err
    assert "(ValueError: summary)" in err[0]
    assert f"the run's files are complete in {out}" in err[0]
    assert json.loads((out / "manifest.json").read_text())["complete"] is True


def test_an_unexpected_error_in_another_command_is_one_line_exit_3(monkeypatch, capsys):
    from corr_cad.run import cli

    def broken(args):
        raise RuntimeError("schema")

    monkeypatch.setattr(cli, "_schema", broken)
    monkeypatch.delenv("CORR_CAD_DEBUG", raising=False)
    assert cli.main(["schema"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "corr-cad: internal error (RuntimeError: schema); this is a bug, please report it "
        "with the scene (CORR_CAD_DEBUG=1 shows the traceback)"
    ]
