"""``modified.toml``: the designed ring's shop files, nothing else, through the real CLI.

It lists the formats dxf, edm, cmm and step, only the keys that differ from
the defaults, runs without a single "has no effect" warning, is written by a
TOML writer (a scene file name cannot add a section) and holds its one path
relative to itself (the same scene gives the same bytes from another folder).
"""

import importlib.util
import shutil
import subprocess
import sys
import tomllib

import pytest

from corr_cad.run.scene.scene import load_scene
from corr_cad.run.stages.stages_modification import SHOP_FORMATS, modified_toml

DESIGN = """
[design]
roller_length = 14.0
[export]
formats = ["modification"]
tolerance = 0.002
[load]
input_torque = 1.1e5
[solver]
positions = 720
[errors]
roller_radius_error = 0.001
[tolerances]
cam_radius = { uniform = 0.005 }
roller_radius = { normal = 0.002 }
[edm]
wire_diameter = 0.2
spark_gap = 0.02
[inspection]
point_spacing = 0.4
profile_tolerance = 0.01
[modification.design]
target_backlash_arcmin = 2.0
family = "equidistant+shift"
equidistant_range_mm = [0.0, 0.03]
shift_range_mm = [-0.01, 0.02]
steps = 3
samples = 40
positions = 16
force_candidates = 1
"""

#: A scene file name that tried to add a [budget] section to modified.toml.
HOSTILE = "a\n[budget]\nmemory_gb = 20\n#.toml"


def _cli(cwd, *args):
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
    )


@pytest.mark.slow
def test_modified_toml_writes_the_shop_files_without_a_warning(tmp_path):
    (tmp_path / HOSTILE).write_text(DESIGN)
    r = _cli(tmp_path, HOSTILE, "--out", "out", "--quiet", "--executor", "serial")
    assert r.returncode == 0, r.stderr
    text = (tmp_path / "out" / "modified.toml").read_text()
    data = tomllib.loads(text)
    ocp = importlib.util.find_spec("OCP") is not None
    want = [f for f in SHOP_FORMATS if f != "step" or ocp]
    assert data["export"] == {"formats": want, "tolerance": 0.002}
    assert data["design"] == {"roller_length": 14.0}  # only what differs from the defaults
    assert data["edm"] == {"wire_diameter": 0.2}  # spark_gap = 0.02 is the default
    assert data["inspection"] == {"point_spacing": 0.4}  # the limits act only in inspection
    mod = data.pop("modification")
    assert set(data) == {"design", "export", "edm", "inspection"}  # no [budget], no studies
    assert set(mod) <= {"equidistant_mm", "shift_mm"} and all(v != 0 for v in mod.values())
    # the real CLI runs it: every shop file, not one warning
    r = _cli(tmp_path / "out", "modified.toml", "--out", "../shop")
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr, r.stderr
    shop = tmp_path / "shop"
    for name in ("inner_gear.dxf", "inner_gear_edm.nc", "inner_gear_nominal.csv"):
        assert (shop / name).is_file()
    assert (shop / "inner_gear.step").is_file() == ocp
    nc = (shop / "inner_gear_edm.nc").read_text()
    assert "profile: modified" in nc and "wire diameter 0.2 mm" in nc


def test_modified_toml_escapes_every_string_and_keeps_paths_relative(tmp_path):
    """Two copies of one scene in different folders give the same bytes; a path
    with a newline and control characters stays one string."""
    texts = []
    for where in ("one/deep", "two"):
        folder = tmp_path / where
        (folder / "data").mkdir(parents=True)
        prof = folder / "data" / "ring\n[budget]\x01.csv"
        shutil.copy(__file__, prof)  # any file: the loader only records its path
        (folder / "s.toml").write_text(
            '[export]\nformats = ["dxf"]\n[errors]\n'
            'measured_profile = "data/ring\\n[budget]\\u0001.csv"\n'
        )
        scene = load_scene(folder / "s.toml")
        texts.append(modified_toml(scene, 0.01, 0.0, folder=folder / "out"))
    assert texts[0] == texts[1]
    data = tomllib.loads(texts[0])
    assert data["errors"]["measured_profile"] == "../data/ring\n[budget]\x01.csv"
    assert data["modification"] == {"equidistant_mm": 0.01}
    assert "budget" not in data
