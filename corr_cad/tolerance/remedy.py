"""What to change when a design check fails: the nearest single-parameter change that passes.

For each failed check, each of eccentricity, roller radius, cam radius,
roller length (the contact length every pressure is computed over) and the
input torque is moved alone, both ways, with the bracketed search of
:func:`~corr_cad.geometry.remedies.nearest_passing`; the nearer passing
value of each parameter is reported. Every value reported was solved with
the scene's own solver settings and errors and passed that check (and is a
valid, non-undercut design). Pure: the caller passes the solve as a function.
"""

from __future__ import annotations

from collections.abc import Callable

from corr_cad.errors import CorrCadError
from corr_cad.geometry.design import GearDesign
from corr_cad.geometry.remedies import Remedy, design_is_valid, nearest_passing
from corr_cad.tolerance.checks import Checks, evaluate_checks

__all__ = ["REMEDY_KNOBS", "check_remedies"]

#: The parameters a remedy moves: unit, and how far it may go (factor of the
#: current value, down and up). The load may only go down.
REMEDY_KNOBS = {
    "eccentricity": ("mm", 0.5, 2.0),
    "roller_radius": ("mm", 0.5, 2.0),
    "cam_radius": ("mm", 0.5, 2.0),
    "roller_length": ("mm", 0.5, 4.0),
    "input_torque": ("N*mm", 0.01, 1.0),
}


def check_remedies(
    design: GearDesign,
    design_kwargs: dict,
    input_torque: float,
    checks: Checks,
    failed: list[str],
    metrics: Callable[[GearDesign, float], dict[str, float]],
    progress: Callable[[str], None] | None = None,
) -> dict[str, list[Remedy]]:
    """For each check in ``failed``: the nearest passing value of each knob that has one.

    ``design_kwargs`` are the keyword arguments ``design`` was built from
    (the scene's ``[design]``): a changed design is built anew from them, so
    that derived sizes the user left to their defaults (ring, bore, frame)
    follow. ``metrics(design, input_torque)`` returns the check metrics (as
    :func:`~corr_cad.tolerance.checks.sample_metrics` names them) of one
    solve with the scene's settings. Evaluations are shared between checks.
    """

    def build(knob: str, x: float) -> GearDesign | None:
        try:
            d = GearDesign(material=design.material, **{**design_kwargs, knob: x})
        except (CorrCadError, ValueError, TypeError, OverflowError, ZeroDivisionError):
            return None
        return d if design_is_valid(d) else None

    memo: dict[tuple[str, float], dict[str, float] | None] = {}

    def values(knob: str, x: float) -> dict[str, float] | None:
        k = (knob, x)
        if k not in memo:
            if knob == "input_torque":
                memo[k] = metrics(design, x)
            else:
                d = build(knob, x)
                memo[k] = None if d is None else metrics(d, input_torque)
        return memo[k]

    out: dict[str, list[Remedy]] = {}
    for name in failed:
        one = Checks(**{name: getattr(checks, name)})
        found = []
        if progress:
            progress(f"      {name} failed: searching the nearest single change that passes")
        for knob, (unit, down, up) in REMEDY_KNOBS.items():
            current = float(input_torque if knob == "input_torque" else getattr(design, knob))

            def passes(x: float, knob=knob, one=one, name=name) -> bool:
                v = values(knob, x)
                return v is not None and evaluate_checks(v, one)[name]["passed"]

            step = 1.0 if knob == "input_torque" else 0.01
            best = None
            for direction, sense, limit in ((-1, "<=", current * down), (+1, ">=", current * up)):
                if limit == current:
                    continue
                v = nearest_passing(current, passes, direction, limit=limit, step=step)
                if v is not None and (best is None or abs(v - current) < abs(best[0] - current)):
                    best = (v, sense)
            if best is not None:
                found.append(Remedy(knob, best[1], best[0], unit, current))
        out[name] = found
    return out
