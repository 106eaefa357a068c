"""One scene key's description, and the limits every key shares.

:class:`Key` is the row type of :data:`corr_cad.run.scene.scene_schema.SCHEMA`; the
section tables live in ``scene_schema`` (design, export, load, solver, errors,
checks), ``scene_schema_tolerance`` (datasheet, tolerances, Monte Carlo,
sweeps) and ``scene_schema_shop`` (EDM, inspection).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from corr_cad.bounds import out_of_range, range_text


@dataclass(frozen=True)
class Key:
    kind: str  # "int", "float", "bool", "str", "list[str]", "list[float]"
    default: Any
    help: str
    choices: tuple[str, ...] | None = None
    low: float | None = None  # exclusive lower bound for numbers (list items too)
    high: float | None = None  # inclusive upper bound
    example: Any = None
    high_open: bool = False  # the upper bound itself is not allowed
    low_open: bool = True  # the lower bound itself is not allowed
    max_len: int | None = None  # most entries a list may hold
    note: str = ""  # a range that depends on the design, shown in the README table

    def works(self) -> str | None:
        """A value inside the key's own range, for refusals: example, default or a bound."""
        candidates = [self.example, self.default]
        if self.low is not None and self.high is not None:
            step = 1 if self.kind == "int" else 0
            candidates += [self.low + step, self.high, (self.low + self.high) / 2]
        for v in candidates:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                continue
            if not out_of_range(
                v, self.low, self.high, low_open=self.low_open, high_open=self.high_open
            ):
                return str(int(v)) if self.kind == "int" else f"{v:g}"
        return None

    def hint(self) -> str:
        """``, e.g. VALUE`` with a value the key accepts, for a refusal (empty when none)."""
        if self.kind == "str":
            works = self.default if isinstance(self.default, str) and self.default else None
            works = works or (self.choices[0] if self.choices else None)
            return f', e.g. "{works}"' if works else ""
        works = self.works()
        return f", e.g. {works}" if works is not None else ""


#: Most entries of a list key whose length the design does not fix.
MAX_LIST = 1000
#: Largest |angle| in degrees anywhere in a scene (ten turns).
MAX_ANGLE_DEG = 3600.0
#: Largest scene file (bytes) and deepest nesting of arrays/tables read.
MAX_SCENE_BYTES = 10 * 1024 * 1024
MAX_NESTING = 32
#: Longest string value (a measured profile path).
MAX_STR = 4096


def key_range(spec: Key) -> str:
    """The allowed range of a numeric key, as every message and the README state it."""
    return range_text(spec.low, spec.high, low_open=spec.low_open, high_open=spec.high_open)


def nesting_depth(text: str) -> int:
    """Deepest nesting of ``[`` and ``{`` outside strings and comments (a cheap pre-check)."""
    if text.count("[") + text.count("{") <= MAX_NESTING:
        return 0
    depth = deepest = 0
    quote = ""
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if quote:
            if c == "\\" and quote == '"':
                i += 1
            elif c == quote:
                quote = ""
        elif c in "\"'":
            quote = c
        elif c == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth = max(0, depth - 1)
        i += 1
    return deepest
