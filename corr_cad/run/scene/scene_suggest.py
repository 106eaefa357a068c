"""A range refusal's example, verified by the scene's own checks before it is printed.

A key's static range gives an example (``[design] cam_bore_radius = -1:
allowed range is (0, 10000], e.g. 47.2``), but the scene may refuse that
example by a range that depends on other keys (a 47.2 mm bore in a 45 mm
cam) or by a check between keys (a first-stage shift that parts the two
meshes). Here the scene is parsed again with the example; where the key is
refused again, other candidates are tried (the key's example and default,
the ends and middle of its own range and of the range the second refusal
states) and the first the scene accepts is printed instead. Where none is
accepted, the refusal says so and quotes what the scene says of the key.
"""

from __future__ import annotations

import copy
import functools
import re
from collections.abc import Callable

from corr_cad.errors import CorrCadError, SceneError

__all__ = ["verified", "verified_examples"]

#: A range refusal that ends with an example: ``[section] key = value: ... e.g. V``.
_REFUSAL = re.compile(r"^\[(?P<section>[\w.]+)\] (?P<key>\w+) = .*, e\.g\. (?P<eg>[-+\w.]+)$")
#: A range as a refusal states it: ``(0, 42.5]``, ``[0.5, 1000]``.
_RANGE = re.compile(r"allowed range is [\[(](?P<lo>[-+\w.]+), (?P<hi>[-+\w.]+)[\])]")

_CHECKING: list[bool] = []


def _number(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _candidates(spec, eg: str, again: str) -> list[float]:
    out = [_number(eg)]
    for v in (spec.example, spec.default):
        out.append(v if isinstance(v, (int, float)) and not isinstance(v, bool) else None)
    ranges = [(spec.low, spec.high)]
    m = _RANGE.search(again)
    if m:
        ranges.insert(0, (_number(m["lo"]), _number(m["hi"])))
    for lo, hi in ranges:
        if lo is not None and hi is not None:
            out += [hi, (lo + hi) / 2, lo + (hi - lo) / 4]
    seen, vals = set(), []
    for v in out:
        if v is None:
            continue
        v = int(round(v)) if spec.kind == "int" else float(f"{v:.4g}")
        if v not in seen:
            seen.add(v)
            vals.append(v)
    return vals


def _with(data: dict, section: str, key: str, value) -> dict:
    out = copy.deepcopy(data)
    table = out
    for part in section.split("."):
        table = table.setdefault(part, {})
    table[key] = value
    return out


def _refuses(parse: Callable, data: dict, prefix: str) -> str | None:
    """The scene's refusal that names the key (``prefix``: ``[section] key =``; or names
    ``key = ...`` in its fix, as a first-stage check between keys does), or None."""
    key = prefix.split("] ", 1)[1].removesuffix(" =")
    _CHECKING.append(True)
    try:
        parse(data)
    except CorrCadError as exc:
        text = str(exc)
        return text if text.startswith(prefix) or f" {key} = " in text else None
    finally:
        _CHECKING.pop()
    return None


def verified(parse: Callable, data: dict):
    """``parse(data)``; a range refusal's example is first checked by ``parse`` itself."""
    try:
        return parse(data)
    except SceneError as exc:
        m = _REFUSAL.match(str(exc))
        if _CHECKING or m is None or not isinstance(data, dict):
            raise
        from corr_cad.run.scene.scene_schema import SCHEMA

        spec = SCHEMA.get(m["section"], {}).get(m["key"])
        if spec is None or spec.kind not in ("int", "float"):
            raise
        prefix = f"[{m['section']}] {m['key']} ="
        again = _refuses(parse, _with(data, m["section"], m["key"], _number(m["eg"])), prefix)
        if again is None:
            raise
        for v in _candidates(spec, m["eg"], again):
            if _refuses(parse, _with(data, m["section"], m["key"], v), prefix) is None:
                raise SceneError(f"{str(exc)[: m.start('eg')]}{v:g}") from exc
        head = str(exc)[: m.start("eg") - len(", e.g. ")]
        raise SceneError(f"{head}; no value of it passes in this scene: {again}") from exc


def verified_examples(parse: Callable) -> Callable:
    """``parse(data, *args)`` through :func:`verified` (a decorator of ``parse_scene``)."""

    @functools.wraps(parse)
    def wrapper(data, *args, **kw):
        return verified(lambda d: parse(d, *args, **kw), data)

    return wrapper
