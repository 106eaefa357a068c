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
