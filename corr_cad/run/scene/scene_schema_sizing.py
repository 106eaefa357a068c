"""Scene sections of the design search: ``[sizing]``, ``[sizing.requirements]`` and
``[sizing.variables]`` (part of :data:`corr_cad.run.scene.scene_schema.SCHEMA`).

Parsed by :func:`parse_sizing`; they act with ``[export] formats = ["sizing"]``
(or ``corr-cad size FILE``). The search itself is
:mod:`corr_cad.run.stages.stages_sizing`.
"""

from __future__ import annotations

import math

from corr_cad.bounds import show
from corr_cad.errors import SceneError
from corr_cad.geometry.design import BOUNDS as DESIGN_BOUNDS
from corr_cad.run.scene.scene_key import Key

__all__ = [
    "SECTIONS",
    "OBJECTIVES",
    "VARIABLES",
    "NEEDLE_DIAMETERS_MM",
    "NEEDLE_LENGTHS_MM",
    "MODULES_MM",
    "split_sizing_tables",
    "parse_sizing",
    "variable_levels",
]

#: Objective -> (sense, unit, what): ``min`` is minimised, ``max`` maximised.
OBJECTIVES: dict[str, tuple[str, str, str]] = {
    "mass": ("min", "kg", "mass of the parts (steel)"),
    "rigidity": ("max", "N*m/arcmin", "torsional rigidity (the datasheet's catalogue figure)"),
    "lost_motion": ("min", "arcmin", "lost motion at +-[datasheet] lost_motion_band of T_R"),
    "efficiency": ("max", "", "smallest forward efficiency over the [friction] map"),
    "life_margin": ("max", "", "system L10 at T_R over rated_life_h"),
    "input_inertia": ("min", "kg m^2", "moment of inertia reflected to the input"),
}

#: Standard needle roller diameters D_w of ISO 3096, mm.
NEEDLE_DIAMETERS_MM = (1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0)
#: Standard needle roller lengths L_w of ISO 3096, mm (used as the contact length).
NEEDLE_LENGTHS_MM = (
    5.8,
    6.8,
    7.8,
    9.8,
    11.8,
    13.8,
    15.8,
    17.8,
    19.8,
    21.8,
    23.8,
    25.8,
    27.8,
    29.8,
    34.8,
    39.8,
)
#: Modules of ISO 54, series I, mm.
MODULES_MM = (1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)

#: Variable -> (scene section, kind, grid step or standard list, static range).
VARIABLES: dict[str, tuple[str, str, object, tuple[float, float]]] = {
    "tooth_count": ("design", "int", 1, (3.0, 1000.0)),
    "cam_radius": ("design", "float", 0.5, DESIGN_BOUNDS["cam_radius"]),
    "roller_radius": ("design", "float", 0.1, DESIGN_BOUNDS["roller_radius"]),
    "roller_length": ("design", "float", 0.5, DESIGN_BOUNDS["roller_length"]),
    "eccentricity": ("design", "float", 0.05, DESIGN_BOUNDS["eccentricity"]),
    "needles": ("bearing", "int", 1, (3.0, 1000.0)),
    "needle_diameter": ("bearing", "list", NEEDLE_DIAMETERS_MM, (0.0, 100.0)),
    "needle_length": ("bearing", "list", NEEDLE_LENGTHS_MM, (0.0, 1000.0)),
    "pinion_teeth": ("first_stage", "int", 1, (4.0, 1000.0)),
    "wheel_teeth": ("first_stage", "int", 1, (4.0, 1000.0)),
    "crank_gear_teeth": ("first_stage", "int", 1, (4.0, 3000.0)),
    "module": ("first_stage", "list", MODULES_MM, (0.0, 100.0)),
    "shift_pinion": ("first_stage", "float", 0.05, (-2.0, 3.0)),
    "shift_wheel": ("first_stage", "float", 0.05, (-2.0, 3.0)),
    "shift_crank_gear": ("first_stage", "float", 0.05, (-2.0, 3.0)),
}


def _limit(help_: str, example: float, high: float = 1e9) -> Key:
    return Key("float", None, help_, low=0, high=high, example=example)


def _variable(name: str) -> Key:
    section, kind, step, (lo, hi) = VARIABLES[name]
    where = {"design": "[design]", "bearing": "the eccentric needle bearing's",
             "first_stage": "[first_stage]"}[section]  # fmt: skip
    if kind == "list":
        grid = f"from the standard sizes {', '.join(f'{v:g}' for v in step)} in the range"
    elif kind == "int":
        grid = "every whole number in the range"
    else:
        grid = f"a {step:g} grid in the range"
    return Key(
        "list[float]",
        None,
        f"[min, max] of {where} {name}: {grid}",
        low=lo,
        low_open=lo == 0.0,
        high=hi,
        max_len=2,
        example={
            "tooth_count": [23.0, 29.0],
            "cam_radius": [120.0, 150.0],
            "roller_radius": [6.0, 10.0],
            "roller_length": [10.0, 16.0],
            "eccentricity": [3.0, 4.5],
            "needles": [30.0, 44.0],
            "needle_diameter": [4.0, 6.0],
            "needle_length": [9.8, 15.8],
            "pinion_teeth": [16.0, 20.0],
            "wheel_teeth": [30.0, 40.0],
            "crank_gear_teeth": [84.0, 96.0],
            "module": [1.25, 2.0],
        }.get(name, [0.0, 0.5]),
    )


SECTIONS: dict[str, dict[str, Key]] = {
    "sizing": {
        "objectives": Key(
            "list[str]",
            ["mass", "rigidity"],
            "two or three objectives of the search's front",
            choices=tuple(OBJECTIVES),
            max_len=3,
        ),
        "evaluations": Key(
            "int",
            2000,
            "candidates the search evaluates (each through the tool's checks)",
            low=0,
            high=1_000_000,
        ),
        "population": Key("int", 40, "NSGA-II population per generation", low=3, high=10_000),
        "seed": Key("int", 1, "random seed (runs are reproducible)", low=-1, high=1e9),
        "designs": Key(
            "int", 5, "designs of the front written as scenes (design_01.toml ...)", low=0, high=99
        ),
    },
    "sizing.requirements": {
        "rated_torque_Nm": _limit("T_R, rated output torque (required), N*m", 3000.0),
        "rated_life_h": _limit("system L10 at T_R and rated_speed_rpm (default: none), h", 6000.0),
        "rated_speed_rpm": Key(
            "float", 15.0, "output speed of the rated life, rpm", low=0, high=1e5
        ),
        "total_ratio": Key(
            "list[float]",
            None,
            "|input turns / output turns|: [exact] or [min, max] (with [first_stage]: "
            "i1 (z + 1), else z + 1)",
            low=0,
            high=1e6,
            max_len=2,
            example=[130.0],
        ),
        "max_outer_diameter_mm": _limit(
            "envelope: largest outer diameter of the parts (ring, frame, first stage), mm", 320.0
        ),
        "max_length_mm": _limit("envelope: largest axial length of the parts' stack, mm", 120.0),
        "min_torsional_rigidity_Nm_per_arcmin": _limit(
            "smallest torsional rigidity, N*m/arcmin", 1000.0
        ),
        "max_lost_motion_arcmin": _limit("largest lost motion, arcmin", 1.0, 21600),
        "min_efficiency": _limit("smallest forward efficiency over the [friction] map", 0.8, 1),
        "max_mass_kg": _limit("largest mass of the parts, kg", 40.0),
        "max_contact_pressure_MPa": _limit("allowable Hertz pressure of the rollers, MPa", 1500.0),
        "max_first_stage_bending_MPa": _limit(
            "allowable tooth-root stress of the first stage (Lewis), MPa", 300.0
        ),
        "max_first_stage_contact_MPa": _limit(
            "allowable contact stress of the first stage (Hertz), MPa", 1200.0
        ),
    },
    "sizing.variables": {name: _variable(name) for name in VARIABLES},
}

#: Requirement -> the ``[checks]`` key of each candidate scene that judges it.
CHECK_OF = {
    "rated_life_h": "min_life_h",
    "min_torsional_rigidity_Nm_per_arcmin": "min_torsional_rigidity_Nm_per_arcmin",
    "max_lost_motion_arcmin": "max_lost_motion_arcmin",
    "min_efficiency": "min_efficiency",
    "max_contact_pressure_MPa": "max_contact_pressure",
    "max_first_stage_bending_MPa": "max_first_stage_bending_MPa",
    "max_first_stage_contact_MPa": "max_first_stage_contact_MPa",
}


def split_sizing_tables(data: dict) -> dict:
    """``[sizing.requirements]`` and ``[sizing.variables]`` as sections of their own."""
    sz = data.get("sizing") if isinstance(data, dict) else None
    if not isinstance(sz, dict):
        return data
    out = dict(data)
    out["sizing"] = {k: v for k, v in sz.items() if k not in ("requirements", "variables")}
    for k in ("requirements", "variables"):
        if k in sz:
            out[f"sizing.{k}"] = sz[k]
    return out


def variable_levels(name: str, lo: float, hi: float) -> tuple[float, ...]:
    """The values a variable takes in ``[lo, hi]``: whole numbers, a grid or standard sizes.

    >>> variable_levels("eccentricity", 3.0, 3.2)
    (3.0, 3.05, 3.1, 3.15, 3.2)
    >>> variable_levels("needle_diameter", 3.2, 6.0)
    (3.5, 4.0, 5.0, 6.0)
    """
    _, kind, step, _ = VARIABLES[name]
    if kind == "list":
        return tuple(v for v in step if lo - 1e-9 <= v <= hi + 1e-9)
    n = int(math.floor((hi - lo) / step + 1e-9))
    return tuple(round(lo + k * step, 10) for k in range(n + 1))


def _refuse(where: str, value, why: str, works: str) -> None:
    raise SceneError(f"{where} = {show(value)}: {why}, e.g. {works}")


def parse_sizing(values: dict, data: dict, formats: tuple, first_stage, bearing) -> dict:
    """``Scene.sizing``: the three sections checked against the scene (empty without them).

    ``first_stage`` and ``bearing`` are the scene's (None when it has none): a
    variable of either needs the section it varies.
    """
    if "sizing" not in formats:
        return {}
    sz = dict(values["sizing"])
    req = dict(values["sizing.requirements"])
    var = {k: v for k, v in values["sizing.variables"].items() if v is not None}
    objectives = sz["objectives"]
    if not 2 <= len(objectives) <= 3 or len(set(objectives)) != len(objectives):
        _refuse(
            "[sizing] objectives",
            objectives,
            "give two or three different objectives",
            'objectives = ["mass", "rigidity"]',
        )
    if req["rated_torque_Nm"] is None:
        raise SceneError(
            '[export] formats lists "sizing" but [sizing.requirements] rated_torque_Nm is not '
            "set; give the rated output torque, e.g. rated_torque_Nm = 3000.0"
        )
    need_life = req["rated_life_h"] is None and (
        "life_margin" in objectives or "efficiency" in objectives
    )
    if need_life:
        raise SceneError(
            f"[sizing] objectives = {show(objectives)} needs [sizing.requirements] "
            "rated_life_h (the life and the efficiency are computed with it), e.g. "
            "rated_life_h = 6000.0"
        )
    ratio = req["total_ratio"]
    if ratio is not None and not (len(ratio) == 1 or (len(ratio) == 2 and ratio[0] <= ratio[1])):
        _refuse(
            "[sizing.requirements] total_ratio",
            ratio,
            "give [exact] or [min, max] with min <= max",
            "total_ratio = [120.0, 140.0]",
        )
    if not var:
        raise SceneError(
            "[sizing.variables] gives no variable; give a [min, max] range of at least one, "
            "e.g. eccentricity = [3.0, 4.5]"
        )
    levels = {}
    for name, rng in var.items():
        section, kind, _, _ = VARIABLES[name]
        works = f"{name} = {show(SECTIONS['sizing.variables'][name].example)}"
        if len(rng) != 2 or not rng[0] <= rng[1]:
            _refuse(f"[sizing.variables] {name}", rng, "give [min, max] with min <= max", works)
        if kind == "int" and any(v != int(v) for v in rng):
            _refuse(f"[sizing.variables] {name}", rng, "the ends must be whole numbers", works)
        if section == "first_stage" and first_stage is None:
            raise SceneError(
                f"[sizing.variables] {name} varies the first stage but the scene has no "
                "[first_stage]; add it (e.g. from templates/compound.toml) or remove the range"
            )
        if section == "bearing" and bearing is None and "life" not in data:
            raise SceneError(
                f"[sizing.variables] {name} varies the eccentric needle bearing but the scene "
                'gives none; add [bearings.eccentric] (model = "drive") or [life] needles, '
                "needle_diameter and needle_length"
            )
        levels[name] = variable_levels(name, rng[0], rng[1])
        if not levels[name]:
            _refuse(
                f"[sizing.variables] {name}",
                rng,
                "no standard size lies in the range ("
                + ", ".join(f"{v:g}" for v in VARIABLES[name][2])
                + ")",
                works,
            )
    if sz["evaluations"] < sz["population"]:
        raise SceneError(
            f"[sizing] evaluations = {sz['evaluations']}: allowed range is at least population "
            f"({sz['population']}), e.g. evaluations = {max(2000, sz['population'])}"
        )
    base = {k: v for k, v in data.items() if not k.startswith("sizing")}
    return {**sz, "requirements": req, "variables": levels, "ranges": var, "base": base}
