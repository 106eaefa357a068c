"""What to change: the nearest value of one parameter that makes a test pass.

A bracketed search along one parameter, the others held: steps of growing
size away from the current value in one direction until the test passes
(or a limit is reached), then bisection between the last failing and the
first passing value. The value returned was itself evaluated and passed;
it is rounded outwards (away from the failing side) to ``step`` and
evaluated again, so the number a message prints is a number that passes.

Used for designs the geometry refuses (collision, undercut, frame webs:
:func:`design_remedies`) and, by :mod:`corr_cad.tolerance.remedy`, for
failed design checks. Pure: no files.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import MISSING, dataclass, fields, replace

from corr_cad.errors import CorrCadError
from corr_cad.geometry.design import GearDesign

__all__ = ["Remedy", "nearest_passing", "design_is_valid", "design_remedies", "DESIGN_KNOBS"]

#: Design parameters a remedy may move, with their unit. The tooth count
#: sets the ratio and is never proposed.
DESIGN_KNOBS = {
    "eccentricity": "mm",
    "cam_radius": "mm",
    "roller_radius": "mm",
    "roller_length": "mm",
}


@dataclass(frozen=True)
class Remedy:
    """``parameter`` ``sense`` ``value`` passes (``sense`` is ">=" or "<=")."""

    parameter: str
    sense: str
    value: float
    unit: str
    current: float

    def text(self) -> str:
        return f"{self.parameter} {self.sense} {self.value:.6g} {self.unit}".rstrip()

    def as_dict(self) -> dict:
        return {
            "parameter": self.parameter,
            "sense": self.sense,
            "value": self.value,
            "unit": self.unit,
            "current": self.current,
        }


def nearest_passing(
    current: float,
    passes: Callable[[float], bool],
    direction: int,
    *,
    limit: float,
    step: float,
    rel_precision: float = 0.0,
    max_evaluations: int = 60,
) -> float | None:
    """Nearest value from ``current`` towards ``direction`` (+1 or -1) where ``passes``.

    ``limit`` bounds the search (inclusive); None when nothing up to it
    passes, or after ``max_evaluations``. The result is a multiple of
    ``step``, rounded away from ``current``, and ``passes`` holds there.

    >>> nearest_passing(10.0, lambda x: x >= 12.345, +1, limit=100.0, step=0.01)
    12.35
    >>> nearest_passing(10.0, lambda x: x <= 7.0, -1, limit=1.0, step=0.1)
    7.0
    >>> nearest_passing(10.0, lambda x: x <= 0.5, -1, limit=1.0, step=0.1) is None
    True
    """
    evals = 0

    def ok(x: float) -> bool:
        nonlocal evals
        evals += 1
        return passes(x)

    span = abs(limit - current)
    if span == 0.0:
        return None
    delta = max(abs(current) * 0.01, step)
    fail = current
    found = None
    while evals < max_evaluations:
        x = current + direction * min(delta, span)
        if ok(x):
            found = x
            break
        fail = x
        if delta >= span:
            return None
        delta *= 2.0
    if found is None:
        return None
    resolution = max(rel_precision * abs(found), 0.5 * step)
    while abs(found - fail) > resolution and evals < max_evaluations:
        mid = 0.5 * (found + fail)
        if ok(mid):
            found = mid
        else:
            fail = mid
    # Round away from the failing side to the step, and make sure it still passes.
    q = found / step
    value = (math.ceil(q - 1e-9) if direction > 0 else math.floor(q + 1e-9)) * step
    value = round(value, 12)
    for _ in range(3):
        if (direction > 0 and value > limit) or (direction < 0 and value < limit):
            return None
        if ok(value):
            return value
        value = round(value + direction * step, 12)
    return None


def design_is_valid(design: GearDesign, **changes: float) -> bool:
    """``design`` with ``changes`` builds, and is not undercut unless that is allowed."""
    from corr_cad.geometry.profile import undercut_analysis

    try:
        d = replace(design, **changes)
        return d.allow_undercut or not undercut_analysis(d).undercut
    except (CorrCadError, ValueError, OverflowError, ZeroDivisionError):
        return False


def design_remedies(
    design_kwargs: dict, keys: tuple[str, ...] = ("eccentricity", "cam_radius", "roller_radius")
) -> list[Remedy]:
    """For a design the geometry refuses: the nearest valid value of each of ``keys``.

    ``design_kwargs`` are the keyword arguments of :class:`GearDesign` (as a
    scene gives them). Each key is moved alone, down and up within a factor
    of 100 of its value; the nearer passing side is kept. Values to 0.01 mm.

    >>> [r.text() for r in design_remedies(dict(tooth_count=31, eccentricity=3.0,
    ...                                          cam_radius=120.0, roller_radius=7.0))]
    ['eccentricity <= 2.48 mm', 'cam_radius >= 133.08 mm', 'roller_radius <= 5.58 mm']
    """
    defaults = {f.name: f.default for f in fields(GearDesign) if f.default is not MISSING}
    kwargs = {**{k: v for k, v in defaults.items() if v is not None}, **design_kwargs}
    out = []
    for key in keys:
        current = kwargs.get(key)
        if not isinstance(current, (int, float)) or current <= 0:
            continue

        def passes(x: float, key=key) -> bool:
            try:
                d = GearDesign(**{**kwargs, key: x})
            except (CorrCadError, ValueError, TypeError, OverflowError, ZeroDivisionError):
                return False
            return design_is_valid(d)

        best = None
        for direction, sense, limit in ((-1, "<=", current / 100.0), (+1, ">=", current * 100.0)):
            v = nearest_passing(current, passes, direction, limit=limit, step=0.01)
            if v is not None and (best is None or abs(v - current) < abs(best[0] - current)):
                best = (v, sense)
        if best is not None:
            out.append(Remedy(key, best[1], best[0], DESIGN_KNOBS[key], float(current)))
    return out
