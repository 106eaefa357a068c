"""One way to state and check a number's allowed range, used by every validator.

A range is written the same everywhere a key is checked (scene loader,
design classes, CLI): ``allowed range is (0, 1e+04]`` -- round brackets for
an open end, square for a closed one, numbers in ``%g``.
"""

from __future__ import annotations

import math

__all__ = ["range_text", "out_of_range", "show"]


def range_text(
    low: float | None, high: float | None, *, low_open: bool = True, high_open: bool = False
) -> str:
    """``(low, high]`` with ``-inf``/``inf`` for a missing end."""
    no_low = low is None or low == -math.inf
    no_high = high is None or high == math.inf
    lo = "-inf" if no_low else f"{low:g}"
    hi = "inf" if no_high else f"{high:g}"
    # An infinite end is never part of the range: always an open bracket.
    return f"{'(' if low_open or no_low else '['}{lo}, {hi}{')' if high_open or no_high else ']'}"


def out_of_range(
    v: float,
    low: float | None,
    high: float | None,
    *,
    low_open: bool = True,
    high_open: bool = False,
) -> bool:
    """True when ``v`` lies outside the range (NaN is always outside)."""
    if v != v:
        return True
    if low is not None and (v <= low if low_open else v < low):
        return True
    return high is not None and (v >= high if high_open else v > high)


def show(value: object, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters, so one bad value stays one short line."""
    if isinstance(value, float):
        return f"{value:g}"
    try:
        text = repr(value)
    except RecursionError:
        text = f"<deeply nested {type(value).__name__}>"
    text = text.replace("\n", " ")
    return text if len(text) <= limit else text[: limit - 5] + " ...)"
