"""What a scene is told beyond its own keys: near misses, refusals that say what passes, "all".

:func:`did_you_mean` names the nearest valid key or section;
:func:`design_refusal` rewrites a refusal of the geometry so that it names
the keys the scene set and the nearest values that pass
(:mod:`corr_cad.geometry.remedies`); :func:`every_format` expands
``formats = ["all"]`` into what this scene can make.
"""

from __future__ import annotations

from corr_cad.bounds import show
from corr_cad.run.scene.scene_schema import FORMATS

__all__ = ["did_you_mean", "design_refusal", "every_format"]


def did_you_mean(word: object, choices) -> str:
    """``"; did you mean 'x'?"`` for the closest valid name, or nothing."""
    import difflib

    if not isinstance(word, str):
        return ""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


#: Design keys whose combination the geometry judges (collision, undercut, webs).
_GEOMETRY_KEYS = ("tooth_count", "eccentricity", "cam_radius", "roller_radius")


def design_refusal(message: str, key: str, design: dict, given: dict) -> str:
    """The geometry's refusal, blamed on what the user set, with the nearest changes that pass.

    When the key the geometry names was left at its default, the line says
    so and names the keys the scene did set; then each of eccentricity, cam
    radius and roller radius moved alone to its nearest valid value
    (:func:`~corr_cad.geometry.remedies.design_remedies`).
    """
    from corr_cad.geometry.remedies import design_remedies

    if key in design and key not in given:
        setters = [f"{k} = {given[k]}" for k in _GEOMETRY_KEYS if k in given]
        by = f"; the scene sets {', '.join(setters)}" if setters else ""
        message = f"{key} = {design[key]} (the default{by}): " + message.split(": ", 1)[-1]
    if key not in _GEOMETRY_KEYS:
        return f"[design] {message}"
    remedies = design_remedies({k: v for k, v in design.items() if v is not None})
    if remedies:
        message += "; passes with " + " or ".join(r.text() for r in remedies)
    return f"[design] {message}"


def every_format(
    values: dict, data: dict | None = None
) -> tuple[tuple[str, ...], tuple[tuple[str, str], ...]]:
    """``formats = ["all"]``: every format this scene can make, and why each other is left out.

    Left out: what needs an input the scene lacks (a torque for the forces
    and the studies built on them, tolerances, a limit for the allocation, a
    measured profile for the inspection), ``step`` without Open CASCADE, and
    the studies on samples (montecarlo, allocation, modification) under
    Palmgren's law on the paper's row.
    """
    import importlib.util

    ld, chk = values["load"], values["checks"]
    load = (
        ld["input_torque"] is not None
        or ld["pinion_torque"] is not None
        or ld["input_torque_Nm"] is not None,
        "no [load] torque",
    )
    tol = (any(v is not None for v in values["tolerances"].values()), "no [tolerances]")
    limit = (
        any(v is not None for k, v in chk.items() if k != "max_failure_probability"),
        "no limit in [checks]",
    )
    measured = (values["errors"]["measured_profile"] is not None, "no [errors] measured_profile")
    if (values["inspection"].get("row") or "a") == "b":  # ring B inspected
        ring_b = (values.get("errors.row_b") or {}).get("measured_profile")
        measured = (ring_b is not None, "no [errors.row_b] measured_profile")
    ocp = (
        importlib.util.find_spec("OCP") is not None,
        "Open CASCADE is not installed (the step extra: pip install -e '.[step]')",
    )
    rated = (
        load[0] or values.get("datasheet", {}).get("rated_torque_Nm") is not None,
        "no [load] torque and no [datasheet] rated_torque_Nm",
    )
    sv = values["solver"]
    paper_law = (
        sv["model"] == "drive" or sv["contact_law"] == "paper",
        'its samples solve the paper\'s contact law or the drive: contact_law = "palmgren" '
        'needs model = "drive"',
    )
    needs = {
        "forces": (load,),
        "datasheet": (rated,),
        "montecarlo": (load, tol, paper_law),
        "allocation": (load, tol, limit, paper_law),
        "sweeps": (load,),
        "inspection": (measured,),
        "step": (ocp,),
        "modification": (
            paper_law,
            rated,
            tol,
            (
                values.get("modification.design", {}).get("target_backlash_arcmin") is not None,
                "no [modification.design] target_backlash_arcmin",
            ),
        ),
    }
    sized = values.get("sizing.requirements", {}).get("rated_torque_Nm") is not None
    needs["sizing"] = ((sized, "no [sizing.requirements] rated_torque_Nm"),)
    why = {f: next((w for ok, w in needs.get(f, ()) if not ok), None) for f in FORMATS}
    made = tuple(f for f in FORMATS if why.get(f) is None)
    return made, tuple((f, why[f]) for f in FORMATS if why.get(f) is not None)


def long_number(text: str, name: str) -> str:
    """The refusal of a scene whose longest number has more digits than Python reads."""
    import re
    import sys

    runs = [(len(m.group().replace("_", "")), m.start()) for m in re.finditer(r"\d[\d_]*", text)]
    digits, at = max(runs, default=(0, 0))
    row = text.count("\n", 0, at) + 1
    line = text.splitlines()[row - 1] if text.splitlines() else ""
    key = line.split("=", 1)[0].strip() if "=" in line else "a value"
    limit = sys.get_int_max_str_digits() or 4300
    return (
        f"{name} line {row}: {show(key, 40)} is a number of {digits} digits; Python reads at "
        f"most {limit} and no key needs more than 10 (e.g. tooth_count = 39)"
    )
