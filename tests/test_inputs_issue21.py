"""Bad input, issue 21: one line naming the key, its value, the range and a value that works.

Each test runs ``python -m corr_cad run`` in its own process, in a folder
that holds the user's other files; a refused run must leave them alone,
print exactly one line of at most 300 characters and exit 2, with no
traceback and no raw numpy or matplotlib warning before it.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers import without_progress

DESIGN = """
[design]
tooth_count = 8
cam_radius = 40.0
roller_radius = 4.0
roller_length = 6.0
eccentricity = 1.5
"""


def cli(folder: Path, scene: str, *extra: str, timeout: int = 600):
    (folder / "s.toml").write_text(scene)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", *extra],
        capture_output=True,
        text=True,
        cwd=folder,
        timeout=timeout,
    )


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "notes.txt").write_text("mine\n")
    return tmp_path


def refused(folder: Path, r) -> str:
    assert r.returncode == 2, (r.returncode, r.stderr[-3000:])
    assert "Traceback" not in r.stderr and "Warning" not in r.stderr, r.stderr[-3000:]
    lines = without_progress(r.stderr).strip().splitlines()
    assert len(lines) == 1, r.stderr[-3000:]
    assert len(lines[0]) <= 300, lines[0]
    assert lines[0].startswith("corr-cad: error: ")
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt", "s.toml"]
    return lines[0]


def _export(formats: str, key: str, value: str) -> str:
    return DESIGN + f"[export]\nformats = {formats}\n{key} = {value}\n"


TOLERANCES = [
    ('["dxf"]', "tolerance", "5e-324"),
    ('["dxf"]', "tolerance", "1e-300"),
    ('["edm"]', "tolerance", "5e-324"),
    ('["edm"]', "tolerance", "1e-300"),
    ('["stl"]', "chord_tolerance", "1e-300"),
    ('["stl"]', "chord_tolerance", "5e-324"),
    ('["step"]', "chord_tolerance", "1e-17"),
    ('["dxf", "stl"]', "tolerance", "1e-30"),
]


@pytest.mark.parametrize("formats,key,value", TOLERANCES)
def test_tiny_tolerance_states_the_real_lower_bound(folder, formats, key, value):
    """OverflowError, ZeroDivisionError, math domain error: one line with a value that works."""
    line = refused(folder, cli(folder, _export(formats, key, value)))
    assert f"[export] {key} = {float(value):g}:" in line
    num = "([0-9.e+-]+)"
    m = re.search(rf"allowed range (?:here )?is \[{num}, 10\]", line)
    assert m and 1e-13 < float(m.group(1)) < 1e-3, line
    works = re.search(rf"(?:{key} = {num} would work|e\.g\. {key} = {num})$", line)
    assert works and float(works.group(1) or works.group(2)) >= float(m.group(1)), line


@pytest.mark.slow
def test_the_suggested_tolerance_works(folder):
    line = refused(folder, cli(folder, _export('["dxf"]', "tolerance", "1e-30")))
    ok = re.search(r"tolerance = ([0-9.e+-]+) would work", line).group(1)
    r = cli(folder, _export('["dxf"]', "tolerance", ok), "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr[-3000:]


@pytest.mark.slow
def test_huge_tolerances_run_clean(folder):
    scene = DESIGN + '[export]\nformats = ["dxf", "edm", "stl"]\ntolerance = 10\n'
    r = cli(folder, scene + "chord_tolerance = 10\n", "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr[-3000:]
    # the EDM path is held to [export] tolerance: it is not "without effect" there
    r = cli(folder, DESIGN + '[export]\nformats = ["edm"]\ntolerance = 0.01\n', "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr[-3000:]


SUBNORMAL = [
    ("design", "roller_length", "[design] roller_length = 4.94066e-324"),
    ("design", "face_width", "[design] face_width = 4.94066e-324"),
    ("design", "frame_thickness", "[design] frame_thickness = 4.94066e-324"),
    ("design", "eccentricity", "[design] eccentricity = 4.94066e-324"),
    ("design", "roller_radius", "[design] roller_radius = 4.94066e-324"),
    ("material", "young_modulus", "[material] young_modulus = 4.94066e-324"),
    ("edm", "lead_in_length", "[edm] lead_in_length = 4.94066e-324"),
]


@pytest.mark.parametrize("section,key,needle", SUBNORMAL)
def test_subnormal_values_name_their_key(folder, section, key, needle):
    """RuntimeWarnings leaked, then an error naming no parameter (or the wrong one)."""
    scene = DESIGN.replace(f"{key} = ", f"# {key} = ")
    if section != "design":
        scene += f"[{section}]\n"
    scene += f"{key} = 5e-324\n"
    scene += '[export]\nformats = ["dxf", "forces", "stl", "edm"]\n[load]\ninput_torque = 1e4\n'
    line = refused(folder, cli(folder, scene))
    assert needle in line and "allowed range" in line, line
    assert "would work" in line or "steel" in line, line


@pytest.mark.slow
@pytest.mark.parametrize("value", ["1e-9", "1e-6"])
def test_a_micrometre_roller_is_the_floor(folder, value):
    """1e-9: 'manifold3d could not build the solid'; 1e-6: a zero-volume mesh; with
    [tolerances] the refusal named [tolerances] cam_radius. Now roller_radius, one line."""
    scene = DESIGN.replace("roller_radius = 4.0", f"roller_radius = {value}")
    scene += '[export]\nformats = ["stl"]\n[tolerances]\ncam_radius = { normal = 0.001 }\n'
    line = refused(folder, cli(folder, scene))
    assert f"[design] roller_radius = {float(value):g}: allowed range is [0.001, 1000]" in line
    assert "roller_radius = 0.001 would work" in line
    ok = DESIGN + '[export]\nformats = ["dxf"]\n'
    assert cli(folder, ok, "--quiet").returncode == 0


def test_nul_byte_in_measured_profile(folder):
    """os.stat raised ValueError: embedded null byte."""
    scene = DESIGN + '[errors]\nmeasured_profile = "a\\u0000b.csv"\n[export]\nformats = ["dxf"]\n'
    line = refused(folder, cli(folder, scene))
    assert "[errors] measured_profile" in line and "NUL" in line


def test_stray_quote_in_a_measured_csv_is_quoted_briefly(folder):
    """The error line held the rest of the file (117 KB)."""
    body = "x,y\n40.0,0.0\n" + '"41.0,1.0\n' + "".join(f"{i}.5,{i}.25\n" for i in range(20000))
    (folder / "m.csv").write_text(body)
    scene = DESIGN + '[errors]\nmeasured_profile = "m.csv"\n[export]\nformats = ["dxf"]\n'
    r = cli(folder, scene)
    assert r.returncode == 2, r.stderr[-3000:]
    (line,) = r.stderr.strip().splitlines()
    assert len(line) <= 300 and "line 3" in line and "m.csv" in line, line
    assert "19999.5" not in line and line.count("\\n") <= 12


@pytest.mark.parametrize("angles", ["[0, 0]", "[5.0]"])
def test_one_crank_angle_plots_without_warning(folder, angles):
    """matplotlib: 'Attempting to set identical low and high xlims' (a UserWarning)."""
    scene = DESIGN + '[export]\nformats = ["forces"]\n[load]\ninput_torque = 1e4\n'
    r = cli(folder, scene + f"[solver]\ncrank_angles_deg = {angles}\n", "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr


def test_report_with_the_monte_carlo_gate(folder):
    """report.html read a 'limit' the Monte Carlo gate does not have (KeyError)."""
    scene = DESIGN + (
        '[export]\nformats = ["montecarlo", "report"]\n[load]\ninput_torque = 1e4\n'
        "[tolerances]\ncam_radius = { normal = 0.005 }\n[montecarlo]\nsamples = 8\n"
        "positions = 24\n[checks]\nmax_gear_force = 1e9\nmax_failure_probability = 0.5\n"
    )
    r = cli(folder, scene, "--quiet")
    assert r.returncode == 0 and r.stderr == "", r.stderr[-3000:]
    assert "montecarlo max_gear_force" in (folder / "out" / "report.html").read_text()


def test_long_paths_give_a_bounded_line(folder):
    (folder / "file.txt").write_text("x")
    deep = "file.txt/" + "/".join(["d" * 200] * 20)
    (folder / "s.toml").write_text(DESIGN + '[export]\nformats = ["dxf"]\n')
    r = subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", deep],
        capture_output=True,
        text=True,
        cwd=folder,
    )
    assert r.returncode == 2
    (line,) = r.stderr.strip().splitlines()
    assert len(line) <= 300 and "--out" in line, line


WARN_THEN = """
import sys, warnings
import numpy as np
from corr_cad.export import plots
real = plots.preview_png
def noisy(*a, **k):
    np.float64(1.0) / np.float64(0.0)  # numpy: RuntimeWarning, divide by zero
    warnings.warn("a library's note", UserWarning)
    if sys.argv[1] == "fail":
        raise OSError(28, "No space left on device")
    return real(*a, **k)
plots.preview_png = noisy
from corr_cad.run.cli import main
sys.exit(main(["run", *sys.argv[2:]]))
"""


@pytest.mark.parametrize("outcome", ["ok", "fail"])
def test_library_warnings_never_reach_the_terminal_raw(folder, outcome):
    """A numpy or matplotlib warning printed its two raw lines before the error line."""
    (folder / "s.toml").write_text(DESIGN + '[export]\nformats = ["png"]\n')
    r = subprocess.run(
        [sys.executable, "-c", WARN_THEN, outcome, "s.toml", "--out", "out", "--quiet"],
        capture_output=True,
        text=True,
        cwd=folder,
        timeout=600,
    )
    lines = r.stderr.strip().splitlines()
    if outcome == "fail":
        assert r.returncode == 2 and len(lines) == 1, r.stderr
        assert lines[0].startswith("corr-cad: error: ") and "No space" in lines[0], lines
        return
    assert r.returncode == 0, r.stderr
    assert len(lines) == 2 and all(x.startswith("corr-cad: warning: ") for x in lines), lines
    assert "RuntimeWarning" in lines[0] and "UserWarning" in lines[1], lines
    assert all(len(x) <= 300 for x in lines)
