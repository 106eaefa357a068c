"""Red-team findings on the drive, row B, friction and first-stage keys, each
through the real CLI in a folder that holds a user's file."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import without_progress

# The design of tests/test_every_format.py and its exact working profile (closed form).
from tests.test_every_format import RJ, E, R, Z
from tests.test_every_format import _measured_points as _working_points

DRIVE = f"""
[design]
tooth_count = {Z}
cam_radius = {RJ}
roller_radius = {R}
eccentricity = {E}
slot_clearance = 0.004
[export]
formats = ["datasheet"]
[load]
input_torque = 2.0e4
[solver]
positions = 40
model = "drive"
contact_law = "palmgren"
[datasheet]
positions_per_mesh = 2
transmission_error_positions_per_turn = 36
[bearings.eccentric]
needles = 30
needle_diameter = 4.0
needle_length = 10.0
diametral_clearance = 0.002
[errors]
roller_radius_error = -0.002
[errors.row_b]
roller_radius_error = -0.001
"""


def _run(tmp_path: Path, scene: str, files: dict[str, str] | None = None):
    (tmp_path / "notes.txt").write_text("user file\n")
    for name, text in (files or {}).items():
        (tmp_path / name).write_text(text)
    (tmp_path / "s.toml").write_text(scene)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=dict(os.environ),
        timeout=600,
    )


def _refused(tmp_path: Path, r) -> str:
    """The one stderr line of a refusal (exit 2, nothing written, the user's file kept)."""
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    lines = [x for x in without_progress(r.stderr).splitlines() if x.strip()]
    errors = [x for x in lines if "error" in x]
    assert len(errors) == 1, r.stderr
    assert not (tmp_path / "out").exists()
    assert (tmp_path / "notes.txt").read_text() == "user file\n"
    return errors[0]


def test_the_design_fit_of_a_cmm_file_written_to_nine_decimals_has_finite_sigmas():
    # The solver's last Jacobian came back with a zero centre column on this
    # near-exact file, and (J^T J)^-1 raised LinAlgError: an internal error
    # (exit 3) that lost the whole run.
    from corr_cad.geometry.profile import ProfileCurve
    from corr_cad.tolerance.inspection import fit_design_family

    fit = fit_design_family(ProfileCurve(Z, E, RJ + R, R), np.round(_working_points(), 9))
    sigmas = [fit["eccentricity_sigma_mm"], fit["link_length_sigma_mm"], *fit["centre_sigma_mm"]]
    assert all(math.isfinite(s) and 0 <= s < 1e-8 for s in sigmas)
    assert abs(fit["eccentricity_error_mm"]) < 1e-8


def test_a_fit_that_cannot_determine_its_parameters_is_one_profile_error():
    from corr_cad.errors import ProfileError
    from corr_cad.tolerance.inspection import _inverse_normal_matrix

    def flat(x):
        return np.zeros(7)

    with pytest.raises(ProfileError, match="do not determine"):
        _inverse_normal_matrix(np.zeros((7, 5)), flat, np.zeros(5), {"t": None})


@pytest.mark.slow
@pytest.mark.parametrize("row", ["a", "b"])
def test_inspecting_a_nine_decimal_cmm_file_in_either_row_of_the_drive(tmp_path, row):
    pts = _working_points()
    text = "x,y\n" + "".join(f"{x:.9f},{y:.9f}\n" for x, y in pts)
    table = "[errors]\n" if row == "a" else "[errors.row_b]\n"
    scene = DRIVE.replace('formats = ["datasheet"]', 'formats = ["inspection"]').replace(
        table, table + 'measured_profile = "m.csv"\n'
    )
    scene += f'[inspection]\nrow = "{row}"\nprofile_tolerance = 0.05\n'
    r = _run(tmp_path, scene, {"m.csv": text})
    assert r.returncode == 0, r.stderr[-2000:]
    report = json.loads((tmp_path / "out" / "inspection.json").read_text())
    assert report["row"] == row
    assert (tmp_path / "notes.txt").read_text() == "user file\n"


@pytest.mark.parametrize(
    ("old", "new", "expect"),
    [
        # each refusal names the key, its value, the range and a value that works
        ("slot_clearance = 0.004", "slot_clearance = nan", "in [-1, 1], e.g. 0"),
        ("slot_clearance = 0.004", 'slot_clearance = "0.004"', "must be a number, e.g. 0"),
        ("needle_diameter = 4.0", "needle_diameter = inf", "in [0.5, 100], e.g. "),
        ('contact_law = "palmgren"', 'contact_law = "hertz"', 'paper, palmgren, e.g. "paper"'),
        ('contact_law = "palmgren"', "contact_law = 1", 'must be a string, e.g. "paper"'),
        (
            "[errors.row_b]\nroller_radius_error = -0.001",
            "[errors.row_b]\nroller_radius_error = 1e9",
            "allowed range is (-2, 2), e.g. 0",
        ),
        (
            "[errors]\nroller_radius_error = -0.002",
            "[errors]\nroller_radius_error = 3.0",
            "allowed range is (-2, 2), e.g. 0",
        ),
        ("[errors.row_b]\n", "[errors.row_b]\ncam_radius_error = nan\n", "e.g. 0"),
    ],
)
def test_a_refusal_of_a_drive_key_names_a_value_that_works(tmp_path, old, new, expect):
    assert old in DRIVE
    line = _refused(tmp_path, _run(tmp_path, DRIVE.replace(old, new, 1)))
    assert expect in line, line


def test_inspection_row_c_names_a_row_that_works(tmp_path):
    line = _refused(tmp_path, _run(tmp_path, DRIVE + '[inspection]\nrow = "c"\n'))
    assert "[inspection] row = 'c'" in line and 'e.g. "a"' in line


@pytest.mark.parametrize("value", ["2.0", "-0.1", "nan"])
def test_max_binding_probability_states_the_range_the_loader_enforces(tmp_path, value):
    # It said "allowed range is (-inf, 1]" for 2 and nan, and "[0, 1]" for -0.1.
    scene = DRIVE.replace('formats = ["datasheet"]', 'formats = ["montecarlo"]')
    scene += "[tolerances]\nroller_radius = { uniform = 0.001 }\n"
    scene += f"[checks]\nmax_binding_probability = {value}\n"
    line = _refused(tmp_path, _run(tmp_path, scene))
    assert "max_binding_probability" in line and "[0, 1]" in line and "e.g. 0.01" in line
    assert "-inf" not in line


COMPOUND = (Path(__file__).resolve().parents[1] / "templates" / "compound.toml").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("allowance", ["0.6", "3.0"])
def test_a_tip_thinned_by_the_backlash_allowance_names_the_allowance(tmp_path, allowance):
    # It blamed shift_pinion = 0.5 ("reduce the shift or the addendum"), which
    # the template needs; the allowance is what thins the pinion's tip.
    scene = COMPOUND.replace("backlash_allowance = 0.03", f"backlash_allowance = {allowance}")
    line = _refused(tmp_path, _run(tmp_path, scene))
    assert f"[first_stage] backlash_allowance = {float(allowance):g}:" in line, line
    assert "shift_pinion" not in line
    works = line.rsplit("backlash_allowance = ", 1)[1]
    (tmp_path / "ok").mkdir()
    fixed = scene.replace(f"allowance = {allowance}", f"allowance = {works}")
    ok = _run(tmp_path / "ok", re.sub(r"formats = \[.*\]", 'formats = ["dxf"]', fixed))
    assert "backlash_allowance" not in ok.stderr  # the value it names passes that check


@pytest.mark.parametrize(
    ("given", "key"),
    [("input_torque_Nm = 0.0", "input_torque_Nm"), ("input_torque_Nm = 1e-310", "input_torque_Nm")],
)
def test_a_torque_too_small_for_the_datasheet_names_the_key_given(tmp_path, given, key):
    # It named "[load] input_torque = 0" for a scene that set input_torque_Nm.
    scene = COMPOUND
    assert '"datasheet"]' in scene  # the template makes the datasheet
    line = _refused(tmp_path, _run(tmp_path, scene.replace("input_torque_Nm = 22.0", given)))
    assert line.split(": error: ")[1].startswith(f"[load] {key} = ")
    assert f"e.g. {key} = 22" in line


def test_the_time_estimate_counts_the_bearing_clearance_of_the_drive_monte_carlo():
    # A 1e6-sample drive Monte Carlo with 2 um bearing clearance was estimated at
    # 14 minutes and ran at 40-100 samples/s (3-7 hours): the clearance slows the
    # drive's datasheet pass about five times and the estimate did not know it.
    import tomllib

    from corr_cad.run.budget.costs_montecarlo import DRIVE_DATASHEET_SECONDS, datasheet_pass
    from corr_cad.run.scene.scene import parse_scene

    text = DRIVE.replace('formats = ["datasheet"]', 'formats = ["montecarlo"]')
    text += "[tolerances]\nroller_radius = { uniform = 0.001 }\n[montecarlo]\nsamples = 1000\n"
    loose = parse_scene(tomllib.loads(text))
    tight = parse_scene(tomllib.loads(text.replace("diametral_clearance = 0.002", "")))
    (s_loose, grid), (s_tight, grid_t) = (
        datasheet_pass(loose, 10**6, 2),
        datasheet_pass(tight, 10**6, 2),
    )
    assert grid == grid_t > 0
    law = DRIVE_DATASHEET_SECONDS[loose.solver.contact_model]
    assert (s_loose - 1.0) == pytest.approx(law[2] / law[1] * (s_tight - 1.0))
    assert law[2] > law[1]  # the clearance slows the pass (measured per law)


def test_the_positions_warning_under_the_datasheet_does_not_name_the_datasheet_as_its_user():
    # formats = ["datasheet"] with [solver] positions warned "only forces, datasheet,
    # inspection and [checks] use it": the datasheet was listed, the key still had no effect.
    import tomllib

    from corr_cad.run.scene.scene import parse_scene

    scene = parse_scene(tomllib.loads(DRIVE))
    (line,) = [w for w in scene.warnings if "[solver] positions" in w]
    assert '"datasheet"' not in line.split("use it")[0], line
    assert "positions_per_mesh" in line


def test_inspection_with_ring_b_s_file_alone_says_to_set_row_b(tmp_path):
    # It said only "[errors] measured_profile is not set", with ring B's file in the scene.
    pts = _working_points()
    text = "x,y\n" + "".join(f"{x:.9f},{y:.9f}\n" for x, y in pts)
    scene = DRIVE.replace('formats = ["datasheet"]', 'formats = ["inspection"]')
    scene = scene.replace("[errors.row_b]\n", '[errors.row_b]\nmeasured_profile = "m.csv"\n')
    line = _refused(tmp_path, _run(tmp_path, scene, {"m.csv": text}))
    assert "[errors] measured_profile is not set" in line and '[inspection] row = "b"' in line


FRICTION = f"""
[design]
tooth_count = {Z}
cam_radius = {RJ}
roller_radius = {R}
eccentricity = {E}
[export]
formats = ["datasheet"]
[load]
input_torque = 2.0e4
[datasheet]
positions_per_mesh = 2
transmission_error_positions_per_turn = 36
[friction]
mu_cam = 0.05
efficiency_torques = [0.5, 1.0]
efficiency_speeds_rpm = [1000.0]
[life]
rated_life_h = 6000.0
"""


@pytest.mark.parametrize("key", ["efficiency_torques", "efficiency_speeds_rpm"])
def test_an_empty_efficiency_map_axis_is_refused_in_one_line(tmp_path, key):
    # An empty list ended in an internal error (exit 3, "zero-size array to reduction").
    scene = re.sub(rf"{key} = \[.*\]", f"{key} = []", FRICTION)
    line = _refused(tmp_path, _run(tmp_path, scene))
    assert f"[friction] {key} = []" in line and f"e.g. {key} = [" in line


@pytest.mark.parametrize(
    ("extra", "names"),
    [
        ("dynamic_load_rating_N = 1e-300", "dynamic_load_rating_N = 1e-300"),  # was exit 3
        ("rated_speed_rpm = 1e-300", "rated_speed_rpm = 1e-300"),  # no key was named
    ],
)
def test_a_life_no_torque_can_give_is_refused_naming_the_life_keys(tmp_path, extra, names):
    scene = FRICTION.replace("rated_life_h = 6000.0", f"rated_life_h = 6000.0\n{extra}")
    line = _refused(tmp_path, _run(tmp_path, scene))
    assert "[life] rated_life_h = 6000" in line and names in line and "e.g." in line
