"""Scene files: keys, types, ranges, and the generated template."""

import tomllib

import pytest

from corr_cad import SceneError
from corr_cad.run.scene.scene import SCHEMA, parse_scene, template_text


def test_template_parses_to_prototype_defaults():
    scene = parse_scene(tomllib.loads(template_text()))
    assert scene.design.tooth_count == 25 and scene.design.cam_radius == 135.0
    assert scene.formats == ("dxf", "png") and scene.tolerance == 0.001
    assert scene.load is None and not scene.errors.any


def test_every_schema_key_is_in_the_template():
    text = template_text()
    for section, keys in SCHEMA.items():
        assert f"[{section}]" in text
        for k in keys:
            assert f"{k} = " in text


@pytest.mark.parametrize(
    "data,pattern",
    [
        ({"desing": {}}, r"unknown section \[desing\] \(did you mean 'design'\?\); valid"),
        ({"design": {"teeth": 25}}, r"unknown key 'teeth' in \[design\]; valid keys: tooth_count"),
        ({"design": {"tooth_count": 25.5}}, r"\[design\] tooth_count = 25.5: must be an integer"),
        ({"design": {"tooth_count": "25"}}, r"must be an integer"),
        (
            {"design": {"cam_radius": -1.0}},
            r"\[design\] cam_radius = -1: allowed range is \(0, 10000\]",
        ),
        ({"design": {"cam_radius": float("nan")}}, r"cam_radius = nan: must be a finite number"),
        ({"design": {"eccentricity": 200.0}}, r"eccentricity = 200: allowed range is \(0, 135\)"),
        ({"design": {"tooth_count": 2}}, r"tooth_count = 2: allowed range"),
        ({"design": {"roller_radius": 30.0}}, r"roller_radius = 30: adjacent rollers collide"),
        ({"design": {"allow_undercut": 1}}, r"allow_undercut = 1: must be true or false"),
        (
            {"material": {"poisson_ratio": 0.7}},
            r"\[material\] poisson_ratio = 0.7: allowed range is \(-1, 0.5\)",
        ),
        (
            {"export": {"formats": ["dxf", "stp"]}},
            r"formats = 'stp': must be one of dxf, png, forces, stl, 3mf, glb, ply, step",
        ),
        ({"export": {"formats": []}}, r"formats is empty"),
        ({"export": {"representation": "nurbs"}}, r"must be one of polyline, arcs, spline"),
        ({"export": {"tolerance": 0.0}}, r"tolerance = 0: allowed range"),
        ({"export": {"chord_tolerance": -1e-3}}, r"chord_tolerance = -0.001: allowed range"),
        ({"export": {"assembly_angles_deg": []}}, r"assembly_angles_deg is empty"),
        ({"export": {"interference_positions": 0}}, r"interference_positions = 0: allowed range"),
        ({"export": {"formats": ["forces"]}}, r"lists 'forces' but \[load\] gives no torque"),
        ({"load": {"input_torque": 1.0, "pinion_torque": 1.0}}, r"not both"),
        ({"load": {"pinion_torque": 1.0}}, r"pinion_torque needs first_stage_ratio"),
        ({"solver": {"positions": 0}}, r"positions = 0: allowed range"),
        ({"solver": {"variants": ["eq99"]}}, r"must be one of eq3_printed"),
        (
            {"errors": {"roller_radius_errors": [0.0, 0.1]}},
            r"has 2 values; the design has 26 rollers",
        ),
        (
            {"errors": {"cam_radius_error": 5.0}},
            r"cam_radius_error = 5: allowed range is \(-4, 4\)",
        ),
        ({"design": []}, r"\[design\] must be a table"),
    ],
)
def test_bad_scenes_name_the_problem(data, pattern):
    with pytest.raises(SceneError, match=pattern):
        parse_scene(data)


def test_pinion_torque_times_ratio():
    s = parse_scene({"load": {"pinion_torque": 2.0e4, "first_stage_ratio": 5.5}})
    assert s.load.input_torque == pytest.approx(1.1e5)


# --- formats = ["all"] ---------------------------------------------------------------
EVERY = ["dxf", "png", "forces", "stl", "3mf", "glb", "ply", "step", "interference"]
EVERY += ["montecarlo", "allocation", "sweeps", "datasheet", "edm", "cmm", "inspection", "report"]


def _has_ocp() -> bool:
    import importlib.util

    return importlib.util.find_spec("OCP") is not None


def test_all_formats_leave_out_what_the_scene_cannot_make():
    s = parse_scene({"export": {"formats": ["all"]}})
    left = dict(s.formats_left_out)
    need_load = {"forces", "montecarlo", "allocation", "sweeps"}
    assert set(left) == need_load | {"datasheet", "inspection", "modification", "sizing"} | (
        set() if _has_ocp() else {"step"}
    )
    assert left["sizing"] == "no [sizing.requirements] rated_torque_Nm"
    assert all(left[f] == "no [load] torque" for f in need_load)
    assert left["datasheet"] == "no [load] torque and no [datasheet] rated_torque_Nm"
    assert left["inspection"] == "no [errors] measured_profile"
    assert list(s.formats) == [f for f in EVERY if f not in left]
    assert s.warnings == ()


def test_all_formats_with_every_input_is_every_format(tmp_path):
    (tmp_path / "m.csv").write_text("x,y\n0,1\n")
    data = {
        "export": {"formats": ["all"]},
        "load": {"input_torque": 1.1e5},
        "tolerances": {"cam_radius": {"normal": 0.001}},
        "checks": {"max_gear_force": 5000.0},
        "errors": {"measured_profile": "m.csv"},
    }
    s = parse_scene(data, base_dir=tmp_path)
    want = EVERY if _has_ocp() else [f for f in EVERY if f != "step"]
    assert list(s.formats) == want
    # tolerances without a limit: allocation alone is left out, and says why
    del data["checks"]
    left = dict(parse_scene(data, base_dir=tmp_path).formats_left_out)
    assert left.pop("allocation") == "no limit in [checks]" and "montecarlo" not in left


def test_all_under_the_drive_model_makes_the_modification_and_the_inspection(tmp_path):
    (tmp_path / "m.csv").write_text("x,y\n0,1\n")
    data = {
        "export": {"formats": ["all"]},
        "load": {"input_torque": 1.1e5},
        "solver": {"model": "drive"},
        "errors": {"measured_profile": "m.csv"},
        "tolerances": {"cam_radius": {"normal": 0.001}},
        "modification.design": {"target_backlash_arcmin": 1.0},
    }
    left = dict(parse_scene(data, base_dir=tmp_path).formats_left_out)
    assert "modification" not in left and "inspection" not in left  # both on the drive
    data["solver"] = {"contact_law": "palmgren"}
    left = dict(parse_scene(data, base_dir=tmp_path).formats_left_out)
    assert {"modification", "montecarlo", "allocation"} <= set(left) and "inspection" not in left
    del data["solver"]
    left = dict(parse_scene(data, base_dir=tmp_path).formats_left_out)
    assert "modification" not in left and "inspection" not in left


def test_all_stands_alone():
    with pytest.raises(SceneError, match=r'"all" stands alone'):
        parse_scene({"export": {"formats": ["all", "dxf"]}})


@pytest.mark.slow
def test_all_prints_one_note_and_records_what_it_left_out(tmp_path):
    import json
    import subprocess
    import sys

    (tmp_path / "s.toml").write_text(
        '[export]\nformats = ["all"]\nchord_tolerance = 0.05\ninterference_positions = 36\n'
    )
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "o", "--quiet"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    notes = r.stderr.splitlines()
    assert len(notes) == 1 and notes[0].startswith('corr-cad: note: formats = ["all"] leaves out ')
    assert "inspection (no [errors] measured_profile)" in notes[0]
    m = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert m["formats_left_out"]["forces"] == "no [load] torque"
    assert "report.html" in m["files"] and "inner_gear_edm.nc" in m["files"]


# --- the template documents every derived default ----------------------------------
DERIVED = {  # the prototype's values, each from the formula written next to it
    "ring_outer_radius": 180.0,  # 5 ceil((3.5 + 135 + 16 + max(10, 24)) / 5) = 5 ceil(35.7)
    "face_width": 12.0,  # roller_length
    "cam_bore_radius": 47.2,  # min(47.25, 65.75) = 47.25, to 0.1 mm, half to even
    "frame_inner_radius": 122.5,  # max(135 - 3.5 - 1 - 8, (135 - 3.5 - 1) / 2)
    "frame_outer_radius": 163.5,  # 135 + 3.5 + 16 + 1 + 8
    "frame_thickness": 8.0,  # max(5, 8)
}


def test_template_states_each_derived_default_and_its_formula():
    text = template_text()
    design_lines = text.split("\n# [material]")[0].splitlines()  # face_width: two sections
    for key, value in DERIVED.items():
        (line,) = [ln for ln in design_lines if ln.startswith(f"# {key} = ")]
        assert line.startswith(f"# {key} = {value!r}   # the default here: "), line
        assert line.rstrip().endswith(f"{value:g}"), line
        (help_,) = [
            p for p, n in zip(text.splitlines(), text.splitlines()[1:], strict=False) if n == line
        ]
        assert "default: " in help_, help_
    assert "47.25, rounded to 47.2" in text and "half to the even digit" in text
    # what the template says is what the run uses: uncommented, the design is the same
    data = tomllib.loads(text)
    uncommented = tomllib.loads(
        "\n".join(
            ln.split("   #")[0][2:]
            if ln[2:].split(" = ")[0] in DERIVED and i < len(design_lines)
            else ln
            for i, ln in enumerate(text.splitlines())
        )
    )
    assert all(k in uncommented["design"] for k in DERIVED)
    assert parse_scene(uncommented).design == parse_scene(data).design
