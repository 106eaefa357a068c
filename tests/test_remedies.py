"""What to change: every change a message proposes passes when run, and is the nearest.

Each test runs the real CLI in its own process. A proposed value is checked
the way a user would: a scene with that value is run and must pass; the
value one rounding step nearer the original must still fail (so the value
is the nearest to the printed resolution, not just some value that passes).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest


def _run(tmp: Path, name: str, text: str, *extra: str) -> subprocess.CompletedProcess:
    scene = tmp / f"{name}.toml"
    scene.write_text(text)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", str(scene), "--out", str(tmp / name), *extra],
        capture_output=True,
        text=True,
        timeout=600,
    )


UNDERCUT = (
    "[design]\ntooth_count = 31\neccentricity = {e}\ncam_radius = {rj}\nroller_radius = 7.0\n"
)
DXF = '[export]\nformats = ["png"]\n'


@pytest.mark.slow
def test_undercut_names_the_e_and_rj_that_keep_the_roller(tmp_path):
    """The template's example (z = 31, e = 3, Rj = 120, r = 7) is undercut."""
    r = _run(tmp_path, "u", UNDERCUT.format(e=3.0, rj=120.0) + DXF)
    assert r.returncode == 2
    line = r.stderr.strip()
    assert len(line.splitlines()) == 1 and "undercut" in line
    e = float(re.search(r"eccentricity <= ([\d.]+) mm", line)[1])
    rj = float(re.search(r"cam_radius >= ([\d.]+) mm", line)[1])
    assert _run(tmp_path, "e_ok", UNDERCUT.format(e=e, rj=120.0) + DXF).returncode == 0
    assert _run(tmp_path, "e_bad", UNDERCUT.format(e=e + 0.01, rj=120.0) + DXF).returncode == 2
    assert _run(tmp_path, "rj_ok", UNDERCUT.format(e=3.0, rj=rj) + DXF).returncode == 0
    assert _run(tmp_path, "rj_bad", UNDERCUT.format(e=3.0, rj=rj - 0.01) + DXF).returncode == 2


def test_a_bound_is_blamed_on_the_key_the_user_set(tmp_path):
    r = _run(tmp_path, "z", "[design]\ntooth_count = 200\n" + DXF)
    assert r.returncode == 2
    assert "roller_radius = 8.0 (the default; the scene sets tooth_count = 200)" in r.stderr
    assert "passes with" in r.stderr


@pytest.mark.parametrize(
    ("text", "hint"),
    [
        ("[design]\ntooth_cont = 25\n", "did you mean 'tooth_count'?"),
        ("[desing]\ntooth_count = 25\n", "did you mean 'design'?"),
        ('[export]\nformat = ["dxf"]\n', "did you mean 'formats'?"),
    ],
)
def test_a_misspelt_key_gets_a_did_you_mean(tmp_path, text, hint):
    r = _run(tmp_path, "k", text)
    assert r.returncode == 2 and hint in r.stderr, r.stderr


CHECKED = """[solver]
positions = 90
[load]
input_torque = {m0}
[design]
roller_length = {length}
cam_radius = {rj}
[checks]
max_contact_pressure = 1100.0
[export]
formats = ["forces"]
"""


def _scene(**kw) -> str:
    v = {"m0": 1.1e5, "length": 12.0, "rj": 135.0} | kw
    return CHECKED.format(**v)


def _passed(tmp: Path, name: str, **kw) -> bool:
    r = _run(tmp, name, _scene(**kw), "--quiet")
    assert r.returncode in (0, 1), r.stderr
    m = json.loads((tmp / name / "manifest.json").read_text())
    return m["checks"]["max_contact_pressure"]["passed"]


@pytest.mark.slow
def test_a_failed_check_names_the_nearest_changes_that_pass(tmp_path):
    r = _run(tmp_path, "fail", _scene(), "--quiet")
    assert r.returncode == 1
    m = json.loads((tmp_path / "fail" / "manifest.json").read_text())
    found = {x["parameter"]: x for x in m["checks"]["max_contact_pressure"]["passes_with"]}
    assert {"roller_length", "cam_radius", "input_torque"} <= set(found)
    assert "passes with" in r.stderr and "roller_length >= " in r.stderr
    # pressure falls with contact length, cam radius (less force) and load
    assert found["roller_length"]["sense"] == ">=" and found["cam_radius"]["sense"] == ">="
    assert found["input_torque"]["sense"] == "<="
    length = found["roller_length"]["value"]
    rj = found["cam_radius"]["value"]
    m0 = found["input_torque"]["value"]
    assert _passed(tmp_path, "l_ok", length=length)
    assert not _passed(tmp_path, "l_bad", length=round(length - 0.01, 2))
    assert _passed(tmp_path, "rj_ok", rj=rj)
    assert not _passed(tmp_path, "rj_bad", rj=round(rj - 0.01, 2))
    assert _passed(tmp_path, "m_ok", m0=m0)
    assert not _passed(tmp_path, "m_bad", m0=m0 + 1.0)


ALLOCATE = """[load]
input_torque = 1.1e5
[checks]
max_contact_pressure = {limit}
[tolerances]
roller_radius = {{ normal = 0.001 }}
[montecarlo]
allocation_samples = 20
positions = 36
[export]
formats = ["allocation"]
"""


def test_of_two_passing_changes_the_nearer_is_proposed():
    """Eccentricity 3.5 mm fails; 3.2 mm (0.3 below) and 3.6 mm (0.1 above) both pass:
    the remedy is the nearer, e >= 3.6 mm. Other knobs never pass."""
    from corr_cad import Checks, GearDesign
    from corr_cad.tolerance.remedy import check_remedies

    def metrics(design, torque):
        e = design.eccentricity
        passing = e <= 3.2 + 1e-9 or e >= 3.6 - 1e-9
        return {"peak_gear_force": 0.0 if passing else 1000.0}

    d = GearDesign()
    checks = Checks(max_gear_force=500.0)
    out = check_remedies(d, {}, 1.1e5, checks, ["max_gear_force"], metrics)
    (rem,) = out["max_gear_force"]
    assert (rem.parameter, rem.sense) == ("eccentricity", ">=")
    assert rem.value == pytest.approx(3.6, abs=0.01)


@pytest.mark.slow
def test_allocation_explains_its_zero(tmp_path):
    r = _run(tmp_path, "a", ALLOCATE.format(limit=1100.0))
    assert r.returncode == 1
    why = "the nominal design already fails max_contact_pressure; no tolerance can pass"
    assert why in r.stdout
    rows = json.loads((tmp_path / "a" / "allocation.json").read_text())["rows"]
    assert rows[0]["tolerance"] == 0.0 and rows[0]["why_zero"] == why


def test_allocation_says_nothing_of_zero_when_it_is_not(tmp_path):
    r = _run(tmp_path, "a", ALLOCATE.format(limit=4000.0))
    assert r.returncode == 0, r.stderr
    rows = json.loads((tmp_path / "a" / "allocation.json").read_text())["rows"]
    assert rows[0]["tolerance"] > 0 and "why_zero" not in rows[0]


@pytest.mark.slow
def test_the_report_names_the_same_changes(tmp_path):
    text = _scene().replace('formats = ["forces"]', 'formats = ["forces", "report"]')
    r = _run(tmp_path, "rep", text, "--quiet")
    assert r.returncode == 1
    m = json.loads((tmp_path / "rep" / "manifest.json").read_text())
    html = (tmp_path / "rep" / "report.html").read_text()
    para = re.search(r'<p class="remedy">max_contact_pressure passes with (.*?) \(', html)[1]
    for x in m["checks"]["max_contact_pressure"]["passes_with"]:
        sense = {">=": "&gt;=", "<=": "&lt;="}[x["sense"]]
        assert f"{x['parameter']} {sense} {x['value']:.6g} {x['unit']}" in para
