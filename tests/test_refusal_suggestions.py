"""Every refusal that suggests a value: the value, fed back, passes the same checks.

A property test over first stages drawn around the compound template's: each
refusal of :func:`first_stage_geometry` that says "a value that works: key = v
(with key2 = v2)" is fed its own suggestion, and the stage then passes every
check. Then the scene keys' floors and the CLI, as a user meets them.
"""

from __future__ import annotations

import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from corr_cad.errors import DesignError
from corr_cad.geometry.first_stage import FirstStage, first_stage_geometry

GOOD = FirstStage(18, 36, 90, 1.5, 15.0, shift_pinion=0.5, shift_crank_gear=0.5)

SUGGESTION = re.compile(r"a value that works: (.+)$")


def suggested(message: str) -> dict | None:
    """``{key: value}`` of a refusal's "a value that works: k = v with k2 = v2", or None."""
    m = SUGGESTION.search(message)
    if m is None:
        return None
    change = {}
    for part in m.group(1).split(" with "):
        key, value = (t.strip() for t in part.split("="))
        change[key] = int(value) if re.fullmatch(r"-?\d+", value) else float(value)
    return change


stages = st.builds(
    lambda zp, zw, dz, xp, xw, xc, b: replace(
        GOOD,
        pinion_teeth=zp,
        wheel_teeth=zw,
        crank_gear_teeth=zp + 2 * zw + dz,
        shift_pinion=xp,
        shift_wheel=xw,
        shift_crank_gear=xc,
        backlash_allowance=b,
    ),
    st.integers(8, 30),
    st.integers(12, 50),
    st.integers(-4, 7),
    st.floats(-1.0, 3.0).map(lambda x: round(x, 2)),
    st.floats(-0.5, 1.0).map(lambda x: round(x, 2)),
    st.floats(-1.0, 3.0).map(lambda x: round(x, 2)),
    st.sampled_from([0.0, 0.03, 0.3, 1.0]),
)


@settings(max_examples=150, deadline=None)
@given(stages)
def test_every_suggested_value_of_a_first_stage_refusal_passes_every_check(stage):
    try:
        first_stage_geometry(stage)
    except DesignError as exc:
        message = str(exc)
        change = suggested(message)
        if change is None:
            # no value claimed to work: the refusal says what does instead
            assert "no single change of one key passes every check here" in message or (
                "a value that works" not in message
            ), message
            return
        assert "(not looked for)" not in message
        first_stage_geometry(replace(stage, **change))  # raises if the suggestion fails


@pytest.mark.parametrize(
    "change,gives",
    [
        ({"shift_pinion": 3.0}, {"shift_pinion": 0.5}),  # was shift_crank_gear = 3 (refused)
        ({"crank_gear_teeth": 91}, {"crank_gear_teeth": 90}),  # was 93 (refused)
        ({"crank_gear_teeth": 93}, {"crank_gear_teeth": 90}),
        ({"backlash_allowance": 1.0}, {"backlash_allowance": 0.362}),
    ],
)
def test_the_reported_suggestions_are_ones_that_work(change, gives):
    with pytest.raises(DesignError) as exc:
        first_stage_geometry(replace(GOOD, **change))
    assert suggested(str(exc.value)) == gives
    first_stage_geometry(replace(GOOD, **{**change, **gives}))


def _compound(tmp_path: Path, old: str, new: str) -> subprocess.CompletedProcess:
    text = (Path(__file__).parents[1] / "templates" / "compound.toml").read_text()
    assert old in text
    text = re.sub(r"^formats = .*$", 'formats = ["dxf"]', text.replace(old, new), flags=re.M)
    (tmp_path / "s.toml").write_text(text)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=600,
    )


@pytest.mark.parametrize(
    "old,new,says",
    [
        ("module = 1.5", "module = 1e-300", "allowed range is [0.001, 100], e.g. 1.5"),
        ("face_width = 15.0", "face_width = 1e-300", "allowed range is [1e-06, 10000], e.g. 15"),
    ],
)
def test_first_stage_floors_refuse_in_one_line_not_exit_3(tmp_path, old, new, says):
    r = _compound(tmp_path, old, new)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert lines == [f"corr-cad: error: [first_stage] {new}: {says}"]
    assert not (tmp_path / "out").exists()


def test_a_failed_check_never_prints_hundreds_of_digits():
    from corr_cad.run.console import failed_checks

    line = failed_checks(
        {
            "checks": {
                "max_first_stage_bending_MPa": {"passed": False, "value": 1.096e300, "limit": 300.0}
            }
        }
    )[0]
    assert line == "max_first_stage_bending_MPa (value 1.096e+300, limit 300)", line


def _drive(tmp_path: Path, scene: str) -> subprocess.CompletedProcess:
    (tmp_path / "s.toml").write_text(scene)
    return subprocess.run(
        [sys.executable, "-m", "corr_cad", "run", "s.toml", "--out", "out", "--quiet"],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=600,
    )


def _harmonics(amplitude: float, rows: int = 100) -> str:
    return "[" + ", ".join(f"[{k}, {amplitude!r}, 0.0]" for k in range(1, rows + 1)) + "]"


def _row_b_harmonics(amplitude: float) -> str:
    from tests.test_redteam_drive import DRIVE

    old = "[errors.row_b]\nroller_radius_error = -0.001\n"
    assert old in DRIVE
    return DRIVE.replace(old, old + f"profile_deviation_harmonics = {_harmonics(amplitude)}\n")


@pytest.mark.parametrize(
    "old,new,says",
    [
        ("needle_length = 10.0", "needle_length = 1e-300", "allowed range is [0.5, 1000], e.g. 12"),
        ("needle_diameter = 4.0", "needle_diameter = 0.001", "allowed range is [0.5, 100], e.g. 6"),
    ],
)
def test_needles_the_drive_cannot_solve_are_refused_naming_the_key(tmp_path, old, new, says):
    """A needle of 1e-300 mm ended in "equilibrium not reached ... residual nan", naming
    no key; the floor is half of ISO 3096's smallest needle."""
    from tests.test_redteam_drive import DRIVE

    r = _drive(tmp_path, DRIVE.replace(old, new))
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == [f"corr-cad: error: [bearings.eccentric] {new}: {says}"]


def test_row_b_harmonics_that_add_up_past_half_the_roller_are_refused_with_a_scale():
    import tomllib

    from corr_cad.run.scene.scene import parse_scene

    data = tomllib.loads(_row_b_harmonics(1.9))  # 100 rows: 190 mm on a 4 mm roller
    with pytest.raises(Exception) as exc:
        parse_scene(data)
    line = str(exc.value)
    assert line.startswith(
        "[errors.row_b] profile_deviation_harmonics: the amplitudes' magnitudes sum to 190 mm"
    ), line
    scale = float(re.search(r"every amplitude times (\S+) ", line).group(1))
    assert scale == 0.0105
    parse_scene(tomllib.loads(_row_b_harmonics(1.9 * scale)))  # the value given passes


@pytest.mark.slow
def test_the_suggested_harmonics_run_through_the_drive_solver(tmp_path):
    """The scale the refusal gives: 100 rows summing to just below r/2 solve (~25 s)."""
    r = _drive(tmp_path, _row_b_harmonics(1.9 * 0.0105))
    assert r.returncode == 0, r.stderr


def _bases() -> list[dict]:
    """Scenes that set most sections: the compound template, the drive with its bearings and
    row B, the friction and life scene."""
    import tomllib

    from tests.test_redteam_drive import DRIVE, FRICTION

    root = Path(__file__).parents[1]
    return [
        tomllib.loads((root / "templates" / "compound.toml").read_text()),
        tomllib.loads(DRIVE),
        tomllib.loads(FRICTION),
    ]


def _bounded_keys() -> list[tuple[int, str, str]]:
    from corr_cad.run.scene.scene_schema import SCHEMA

    out = []
    for i, base in enumerate(_bases()):
        for section, keys in SCHEMA.items():
            table = base
            for part in section.split("."):
                table = table.get(part, {}) if isinstance(table, dict) else {}
            if not table and section not in base:
                continue
            for key, spec in keys.items():
                if spec.kind in ("int", "float") and spec.low is not None:
                    out.append((i, section, key))
    return out


@pytest.mark.parametrize("base,section,key", _bounded_keys())
def test_a_range_refusal_s_example_fed_back_passes_its_check(base, section, key):
    """Below its floor every bounded key is refused naming ``e.g. V``; ``key = V`` then
    passes the same loader (whatever else the scene still lacks, never this key)."""
    import copy

    from corr_cad.errors import CorrCadError
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.scene.scene_schema import SCHEMA

    spec = SCHEMA[section][key]
    data = copy.deepcopy(_bases()[base])
    table = data
    for part in section.split("."):
        table = table.setdefault(part, {})
    table[key] = spec.low - 1 if spec.kind == "int" else spec.low - max(1.0, abs(spec.low))
    with pytest.raises(CorrCadError) as exc:
        parse_scene(data, base_dir=Path("."))
    line = str(exc.value)
    assert line.startswith(f"[{section}] {key} = "), line
    if "no value of it passes in this scene: " in line:
        return  # the scene refuses the key whatever its value, and says why
    m = re.search(r"e\.g\. (\S+)$", line)
    assert m is not None, line
    table[key] = int(m.group(1)) if spec.kind == "int" else float(m.group(1))
    try:
        parse_scene(data, base_dir=Path("."))
    except CorrCadError as again:  # another key may still be wrong, never this one
        text = str(again)
        assert not text.startswith(f"[{section}] {key} = "), (line, text)
        assert f" {key} = " not in text, (line, text)  # nor named in another's fix


def _paper_law_drive(phase: str) -> str:
    from tests.test_redteam_drive import DRIVE

    scene = DRIVE.replace('contact_law = "palmgren"\n', "")
    old = "[errors]\nroller_radius_error = -0.002\n"
    assert old in scene
    return scene.replace(old, old + f"cam_phase_error_deg = {phase}\n")


@pytest.mark.parametrize("phase", ["180", "-179.999", "120"])
def test_a_cam_phase_error_past_a_quarter_turn_is_refused_naming_the_key(tmp_path, phase):
    """The drive's solver found no equilibrium (residual inf) from about 110 deg on."""
    r = _drive(tmp_path, _paper_law_drive(phase))
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == [
        f"corr-cad: error: [errors] cam_phase_error_deg = {float(phase):g}: allowed range is "
        "[-90, 90], e.g. 0"
    ]


@pytest.mark.slow
@pytest.mark.parametrize("phase", ["90", "-90"])
def test_the_ends_of_the_cam_phase_range_solve(tmp_path, phase):
    r = _drive(tmp_path, _paper_law_drive(phase))
    assert r.returncode == 0, r.stderr
