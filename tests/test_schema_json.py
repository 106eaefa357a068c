"""`corr-cad schema`: a JSON Schema (draft 2020-12) that agrees with the scene loader."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from corr_cad.errors import SceneError
from corr_cad.run.scene.scene import SCHEMA, parse_scene

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def validator(tmp_path_factory):
    """The schema as the user gets it: printed by the CLI in a separate process."""
    out = subprocess.run(
        [sys.executable, "-m", "corr_cad", "schema"], capture_output=True, text=True, check=True
    )
    schema = json.loads(out.stdout)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def test_schema_names_every_key_with_help_and_rejects_unknown_ones(validator):
    props = validator.schema["properties"]
    # [bearings] only holds tables ([bearings.eccentric], [bearings.eccentric_b]).
    assert [p for p in props if p != "bearings"] == list(SCHEMA)
    for section, keys in SCHEMA.items():
        assert props[section]["additionalProperties"] is False
        assert list(props[section]["properties"]) == list(keys)
        for key, spec in keys.items():
            assert props[section]["properties"][key]["description"].startswith(spec.help)
    assert props["export"]["properties"]["representation"]["enum"] == ["polyline", "arcs", "spline"]


def test_bundled_scenes_and_the_new_template_validate(validator, tmp_path):
    scenes = sorted((ROOT / "templates").glob("*.toml"))
    assert scenes
    for path in scenes:
        data = tomllib.loads(path.read_text())
        assert not list(validator.iter_errors(data)), path.name
    new = tmp_path / "my_design.toml"
    subprocess.run([sys.executable, "-m", "corr_cad", "new", str(new)], check=True)
    assert not list(validator.iter_errors(tomllib.loads(new.read_text())))
    # The template with every commented example switched on validates too.
    # (Sections that do nothing with the template's formats are commented whole.)
    on = re.compile(r"# ([a-z_]+ = |\[[a-z_.]+\]$)")
    lines = [ln[2:] if on.match(ln) else ln for ln in new.read_text().splitlines()]
    full = tomllib.loads("\n".join(lines))
    assert full["sweeps"]["eccentricity"] and full["tolerances"]
    assert not list(validator.iter_errors(full))


BAD = [
    {"desing": {}},
    {"design": {"tooth_cont": 25}},
    {"design": {"tooth_count": 2}},
    {"design": {"tooth_count": "25"}},
    {"design": {"roller_radius": -1.0}},
    {"design": {"allow_undercut": 1}},
    {"material": {"poisson_ratio": 0.6}},
    {"export": {"formats": ["dxf", "pdf"]}},
    {"export": {"formats": ["dxf", "dxf"]}},
    {"export": {"formats": []}},
    {"export": {"representation": "nurbs"}},
    {"tolerances": {"cam_radius": {"normal": 0.001, "uniform": 0.001}}},
    {"tolerances": {"cam_radius": {"gauss": 0.001}}},
    {"tolerances": {"cam_radius": {"normal": -0.001}}},
    {"sweeps": {"eccentricity": [3.0]}},
    {"errors": {"profile_deviation_harmonics": [[3.0, 0.001]]}},
]


@pytest.mark.parametrize("data", BAD, ids=[json.dumps(b) for b in BAD])
def test_bad_scenes_fail_both(validator, data):
    assert list(validator.iter_errors(data))
    with pytest.raises(SceneError):
        parse_scene(data)


# --- schema and loader agree on random scenes ---------------------------------

#: Keys whose validity depends on no other key (given a torque in the base scene).
LOCAL = {
    "material": None,
    "solver": None,
    "montecarlo": None,
    # The Monte Carlo gates need a limit and the montecarlo format (other keys).
    "checks": {
        k
        for k in SCHEMA["checks"]
        if k not in ("max_failure_probability", "max_binding_probability")
        # The first stage's checks need a [first_stage] section (another key).
        and k not in ("max_first_stage_bending_MPa", "max_first_stage_contact_MPa")
    },
    # Not "tolerances": their upper bounds depend on the design (r/2, 90/(z+1) deg).
    "friction": None,
    "life": None,
    "budget": None,
    "dask": None,
    # Not "tolerance": with "dxf" in the formats, a tolerance below ~5e-7 mm
    # passes the 200,000-vertex limit, which the JSON Schema cannot state.
    "export": {
        "representation",
        "chord_tolerance",
        "assembly_angles_deg",
        "interference_positions",
    },
    "sweeps": {"points", "positions"},
}
BASE = {"export": {"formats": ["dxf"]}, "load": {"input_torque": 1.0e5}}

_scalar = st.one_of(
    st.integers(-10, 10**7),
    st.floats(-1e7, 1e7, allow_nan=False, allow_infinity=False),
    st.booleans(),
    st.sampled_from(["", "dxf", "arcs", "eq3_printed", "normal", "x"]),
)
_value = st.one_of(
    _scalar,
    st.lists(_scalar, max_size=4),
    st.lists(st.lists(_scalar, min_size=2, max_size=4), max_size=2),
    st.dictionaries(st.sampled_from(["normal", "uniform", "sigma"]), _scalar, max_size=2),
)
_keys = [(s, k) for s, keys in SCHEMA.items() for k in keys]


def _loads(data) -> bool:
    try:
        parse_scene(data)
    except SceneError:
        return False
    return True


@settings(max_examples=400)
@given(st.lists(st.tuples(st.sampled_from(_keys), _value), min_size=1, max_size=3))
def test_schema_and_loader_agree_on_random_scenes(validator, entries):
    data = json.loads(json.dumps(BASE))
    for (section, key), value in entries:
        spec = SCHEMA[section][key]
        # JSON Schema counts 3.0 as an integer; TOML (and the loader) does not.
        if spec.kind == "int" and isinstance(value, float) and math.isfinite(value):
            value = int(value) if value.is_integer() else value
        data.setdefault(section, {})[key] = value
    schema_ok = validator.is_valid(data)
    loader_ok = _loads(data)
    # Whatever the loader accepts, the schema accepts.
    assert schema_ok or not loader_ok, data
    local = all(
        section in LOCAL and (LOCAL[section] is None or key in LOCAL[section])
        for (section, key), _ in entries
    )
    if local:
        # For keys that depend on no other key, the schema is exact.
        assert schema_ok == loader_ok, data


def test_schema_out_writes_the_printed_text(tmp_path, validator):
    path = tmp_path / "editor" / "scene.schema.json"
    subprocess.run(
        [sys.executable, "-m", "corr_cad", "schema", "--out", str(path)],
        check=True,
        capture_output=True,
    )
    assert json.loads(path.read_text()) == validator.schema
