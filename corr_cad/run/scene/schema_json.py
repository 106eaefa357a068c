"""JSON Schema (draft 2020-12) of scene files, from :data:`corr_cad.run.scene.scene.SCHEMA`.

``corr-cad schema`` prints it. TOML editors that read JSON Schemas (e.g.
Taplo / "Even Better TOML": put ``#:schema ./scene.schema.json`` on the
first line of a scene) then complete keys, show each key's help and flag
wrong types, unknown keys and values out of range. Every type, enum, bound
and description comes from the scene schema's ``Key`` fields, so the JSON
Schema follows when they change. Rules that tie several keys together (a
torque needed for forces, z + 1 per-roller values, a roller that fits the
design) are the loader's alone.
"""

from __future__ import annotations

import json
from typing import Any

__all__ = ["scene_json_schema", "schema_text"]

SCHEMA_URI = "https://json-schema.org/draft/2020-12/schema"

#: Lists the loader refuses when empty.
_NON_EMPTY = {
    ("export", "formats"),
    ("export", "assembly_angles_deg"),
    ("solver", "crank_angles_deg"),
}


def _number(kind: str, spec) -> dict:
    out: dict[str, Any] = {"type": "integer" if kind == "int" else "number"}
    if spec.low is not None:
        out["exclusiveMinimum" if spec.low_open else "minimum"] = spec.low
    if spec.high is not None:
        out["exclusiveMaximum" if spec.high_open else "maximum"] = spec.high
    return out


def _key_schema(section: str, key: str, spec) -> dict:
    from corr_cad.tolerance.sweeps import PAPER_SWEEPS

    kind = spec.kind
    if kind in ("int", "float"):
        out = _number(kind, spec)
    elif kind == "bool":
        out = {"type": "boolean"}
    elif kind == "str":
        out = {"type": "string"}
        if spec.choices:
            out["enum"] = list(spec.choices)
    elif kind == "list[str]":
        item: dict[str, Any] = {"type": "string"}
        if spec.choices:
            item["enum"] = list(spec.choices)
        out = {"type": "array", "items": item, "uniqueItems": True}
    elif kind == "list[float]":
        # each item within the key's bounds, as the loader checks them
        out = {"type": "array", "items": _number("float", spec)}
        if section == "sweeps" and key in PAPER_SWEEPS:
            out.update({"minItems": 2, "maxItems": 2})
    elif kind == "list[list[float]]":
        row = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}
        out = {"type": "array", "items": row}
    elif kind == "distribution":
        scale = {"type": "number", "minimum": 0}
        out = {
            "type": "object",
            "properties": {"normal": scale, "uniform": scale},
            "additionalProperties": False,
            "minProperties": 1,
            "maxProperties": 1,
        }
    else:  # pragma: no cover - a new kind must be mapped here
        raise AssertionError(f"no JSON Schema mapping for kind {kind!r}")
    if (section, key) in _NON_EMPTY:
        out["minItems"] = 1
    out["description"] = spec.help + (
        f" (one of: {', '.join(spec.choices)})" if spec.choices else ""
    )
    if spec.default is not None:
        out["default"] = spec.default
    elif spec.example is not None:
        out["examples"] = [spec.example]
    return out


def scene_json_schema() -> dict:
    """The scene schema as a JSON Schema (draft 2020-12) dictionary.

    >>> s = scene_json_schema()
    >>> s["properties"]["design"]["properties"]["roller_radius"]["exclusiveMinimum"]
    0.0
    >>> s["additionalProperties"], s["properties"]["export"]["additionalProperties"]
    (False, False)
    """
    from corr_cad.run.scene.scene import SCHEMA

    out = {
        "$schema": SCHEMA_URI,
        "title": "corr_cad scene",
        "description": (
            "Scene file of corr-cad (TOML). Units: mm, N, N*mm, MPa; angles in degrees."
        ),
        "type": "object",
        "properties": {
            section: {
                "type": "object",
                "description": f"[{section}]",
                "properties": {k: _key_schema(section, k, spec) for k, spec in keys.items()},
                "additionalProperties": False,
            }
            for section, keys in SCHEMA.items()
        },
        "additionalProperties": False,
    }
    # A dotted section ([modification.design]) is a table inside its parent in TOML.
    for section in [s for s in SCHEMA if "." in s]:
        parent, child = section.split(".", 1)
        holder = out["properties"].setdefault(  # [bearings] holds tables only
            parent,
            {"type": "object", "description": f"[{parent}]", "additionalProperties": False},
        )
        nested = holder.setdefault("patternProperties", {})
        nested[f"^{child}$"] = dict(out["properties"][section])
    return out


def schema_text() -> str:
    """The JSON Schema as indented JSON text (what ``corr-cad schema`` prints)."""
    return json.dumps(scene_json_schema(), indent=2) + "\n"
