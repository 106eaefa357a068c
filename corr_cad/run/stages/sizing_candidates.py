"""One candidate of the design search: its scene, and its figures through the tool's checks.

A candidate is a scene: the sizing scene's own sections (``[sizing]`` left
out) with the variables set, the rated point of ``[sizing.requirements]`` in
``[datasheet]``, ``[life]`` and ``[load]``, and the requirements the tool
checks as ``[checks]`` limits. :func:`evaluate` loads it with the scene
loader (a refusal there, an undercut or a first-stage refusal, makes the
candidate infeasible with the loader's line as its reason; so does a tooth
tip the run would warn of, a knife edge below 0.1 mm) and runs the
stages a ``corr-cad run`` of it runs: ``undercut``, ``profiles``, ``drive``
(with ``[first_stage]``), ``datasheet`` and ``forces``, then the checks on
their figures (:func:`corr_cad.tolerance.checks.evaluate_checks`). The same
scene written as ``design_NN.toml`` gives the same figures.

Screening evaluates the same scene at the resolution of :data:`SCREENING`
(fewer positions); the front is evaluated again at the scene's own.
"""

from __future__ import annotations

import copy
import math
import tempfile
from pathlib import Path

from corr_cad.errors import CorrCadError
from corr_cad.run.scene.scene_schema_sizing import CHECK_OF, VARIABLES

__all__ = [
    "FIGURES",
    "SCREENING",
    "candidate_data",
    "evaluate",
    "evaluate_chunk",
    "second_stage_mass_inertia",
]

#: ``(section, key) -> value``: the screening resolution (each at most the scene's own).
SCREENING = {
    ("solver", "positions"): 360,
    ("datasheet", "positions_per_mesh"): 4,
    ("datasheet", "transmission_error_positions_per_turn"): 36,
    ("friction", "positions_per_mesh"): 1,
}
#: Screening's efficiency map when no objective or requirement reads the efficiency.
SCREENING_EFFICIENCY_TORQUES = [1.0]

#: Figure columns of a candidate (``sizing.csv``, ``pareto.csv``), in order.
FIGURES = (
    "mass_kg",
    "input_inertia_kg_m2",
    "torsional_rigidity_Nm_per_arcmin",
    "lost_motion_arcmin",
    "efficiency",
    "life_h",
    "life_margin",
    "rated_torque_from_life_Nm",
    "peak_contact_pressure_MPa",
    "first_stage_bending_MPa",
    "first_stage_contact_MPa",
    "outer_diameter_mm",
    "length_mm",
    "total_ratio",
)

#: Objective -> its figure column.
OBJECTIVE_FIGURE = {
    "mass": "mass_kg",
    "rigidity": "torsional_rigidity_Nm_per_arcmin",
    "lost_motion": "lost_motion_arcmin",
    "efficiency": "efficiency",
    "life_margin": "life_margin",
    "input_inertia": "input_inertia_kg_m2",
}

#: Requirement -> (figure, "max" or "min" limit): those the sizing judges itself.
_OWN = {
    "max_outer_diameter_mm": ("outer_diameter_mm", "max"),
    "max_length_mm": ("length_mm", "max"),
    "max_mass_kg": ("mass_kg", "max"),
}
_LOAD_KEYS = ("input_torque", "pinion_torque", "input_torque_Nm", "first_stage_ratio")


def candidate_data(
    base: dict, values: dict, req: dict, screening: bool = False, efficiency: bool = True
) -> dict:
    """The scene (as TOML data) of the candidate with ``values`` of the variables.

    ``screening``: at the resolution of :data:`SCREENING`; the friction figures
    at one position per mesh period and the efficiency at T_R alone only where
    the ``efficiency`` is not wanted (it varies less across designs than that
    resolution's error).
    """
    data = copy.deepcopy(base)
    bearing = "bearings.eccentric" if "bearings.eccentric" in data else "life"
    for name, v in values.items():
        section = VARIABLES[name][0]
        where = bearing if section == "bearing" else section
        data.setdefault(where, {})[name] = int(v) if VARIABLES[name][1] == "int" else float(v)
    if bearing == "bearings.eccentric" and "life" in data:  # the bearing's own keys rule
        for k in ("needles", "needle_diameter", "needle_length"):
            data["life"].pop(k, None)
    t_nm = float(req["rated_torque_Nm"])
    z1 = int(data.get("design", {}).get("tooth_count", 25)) + 1
    load = {k: v for k, v in data.get("load", {}).items() if k not in _LOAD_KEYS}
    if "first_stage" in data:
        fs = data["first_stage"]
        load["input_torque_Nm"] = t_nm / (z1 * fs["crank_gear_teeth"] / fs["pinion_teeth"])
    else:
        load["input_torque"] = t_nm * 1000.0 / z1
    data["load"] = load
    data.setdefault("datasheet", {})["rated_torque_Nm"] = t_nm
    if req["rated_life_h"] is not None:
        life = data.setdefault("life", {})
        life["rated_life_h"] = float(req["rated_life_h"])
        life["rated_speed_rpm"] = float(req["rated_speed_rpm"])
    checks = data.setdefault("checks", {})
    for key, check in CHECK_OF.items():
        if req.get(key) is not None and (not key.startswith("max_first") or "first_stage" in data):
            checks[check] = float(req[key])
    if not checks:
        data.pop("checks")
    # the tolerance of the gear outlines (the first stage's mass); else it would act on nothing
    keep = ("tolerance",) if "first_stage" in data else ()
    export = {k: v for k, v in data.get("export", {}).items() if k in keep}
    data["export"] = {"formats": ["datasheet"], **export}
    if screening:
        # [friction] or [life] computes the friction figures; the efficiency, flat across
        # designs, keeps the scene's resolution where it is wanted
        friction = ("friction" in data or "life" in data) and not efficiency
        for (section, key), v in SCREENING.items():
            if section != "friction" or friction:
                sec = data.setdefault(section, {})
                sec[key] = min(int(sec.get(key, v)), v)
        if friction:
            data["friction"]["efficiency_torques"] = SCREENING_EFFICIENCY_TORQUES
    return data


def second_stage_mass_inertia(design, outlines: dict) -> tuple[float, float]:
    """Mass (kg) of the second stage's parts and their inertia at the crank (kg m^2).

    Two rings, three frame plates, two cams, ``2 (z + 1)`` rollers, steel, as
    :func:`corr_cad.mechanics.gears.first_stage_loads.drive_mass_inertia` counts
    them; the inertia: the cams about the crank axis, the rollers (on their
    mean orbit) and the plates times ``(1 / (z + 1))^2``; the ring is fixed.
    """
    from corr_cad.mechanics.gears.first_stage_loads import extrusion_mass_inertia

    def pieces(o) -> list:
        return [(o.outer, list(o.holes), o.thickness, 0.0)]

    n = design.roller_count
    m_ring, _ = extrusion_mass_inertia(pieces(outlines["ring"]))
    m_frame, i_frame = extrusion_mass_inertia(pieces(outlines["frame"]))
    m_cam, i_cam = extrusion_mass_inertia(pieces(outlines["cam"]), shift=(0.0, design.eccentricity))
    m_roller, _ = extrusion_mass_inertia(pieces(outlines["roller"]))
    r, link = design.roller_radius, design.link_length
    i_roller = m_roller * (0.5 * r * r + link * link)
    mass = 2 * m_ring + 3 * m_frame + 2 * m_cam + 2 * n * m_roller
    inertia = 2 * i_cam + (3 * i_frame + 2 * n * i_roller) / n**2
    return mass, inertia * 1e-6


def _envelope(scene) -> tuple[float, float, float]:
    """Outer diameter and axial length of the parts (mm), and the total ratio."""
    d = scene.design
    radius = max(d.ring_outer_radius, d.frame_outer_radius)
    length = 2 * d.face_width + 3 * d.frame_thickness
    ratio = float(d.roller_count)
    fs = scene.first_stage
    if fs is not None:
        from corr_cad.geometry.first_stage_parts import first_stage_layout

        lay = first_stage_layout(d, fs)
        radius = max(radius, lay.rim_outer, fs.centre_distance + fs.wheel.tip)
        length = lay.z_top - lay.z_gears
        ratio = abs(fs.ratio) * d.roller_count
    return 2.0 * radius, length, ratio


def _refused(check: str, reason: str) -> dict:
    return {"feasible": False, "refused_by": check, "reason": reason, "violation": math.inf}


def _ratio_miss(ratio: float, want) -> float:
    """Relative distance of ``ratio`` from ``[exact]`` or ``[min, max]`` (0: inside)."""
    if want is None:
        return 0.0
    lo, hi = (want[0], want[0]) if len(want) == 1 else want
    miss = max(lo - ratio, ratio - hi, 0.0) / lo
    return 0.0 if miss <= 1e-9 else miss


def evaluate(data: dict, req: dict) -> dict:
    """Figures of the candidate scene ``data`` and the requirements it fails.

    Returns ``{"feasible", "refused_by", "reason", "violation", "violations",
    **figures}``; a candidate the loader or a stage refuses has no figures
    and ``refused_by`` names where (``scene``, the stage).
    """
    from corr_cad.run.console import warnings as console_warnings
    from corr_cad.run.scene.scene import parse_scene
    from corr_cad.run.stages.context import RunContext
    from corr_cad.run.stages.stages_datasheet import _datasheet
    from corr_cad.run.stages.stages_drive import drive_check_values
    from corr_cad.run.stages.stages_forces import _forces, check_values
    from corr_cad.run.stages.stages_profile import _profiles, _undercut
    from corr_cad.tolerance.checks import evaluate_checks

    try:
        scene = parse_scene(data, "candidate")
        outer, length, ratio = _envelope(scene)
    except CorrCadError as exc:
        return _refused("scene", str(exc))
    ctx = RunContext(scene=scene, out=Path(tempfile.gettempdir()))
    stage = "undercut"
    try:
        _undercut(ctx)
        doubts = console_warnings({"undercut": ctx.manifest["undercut"]})
        if doubts:  # a knife-edge or trimmed tooth tip: `corr-cad run` would warn of it
            return _refused("geometry", doubts[0].removeprefix("geometry: "))
        stage = "profiles"
        _profiles(ctx)
        if scene.first_stage is not None:
            from corr_cad.run.stages.stages_first_stage import drive

            stage = "drive"
            _with_cached_gears(ctx, drive)
        stage = "datasheet"
        _datasheet(ctx)
        stage = "forces"
        _forces(ctx)
    except CorrCadError as exc:
        return _refused(stage, str(exc))
    res = ctx.results
    if scene.first_stage is not None:
        whole = ctx.manifest["drive"]
        mass, inertia = whole["mass_kg"], whole["input_inertia_kg_m2"]
    else:
        from corr_cad.geometry.parts import part_outlines

        mass, inertia = second_stage_mass_inertia(
            scene.design, part_outlines(scene.design, res.working, scene.tolerance)
        )
    if res.drive is not None:
        values = drive_check_values(res.drive, check_values)
    else:
        values = check_values(res.forces)
    values.update(res.datasheet.check_values())
    fig = {
        "mass_kg": mass,
        "input_inertia_kg_m2": inertia,
        "torsional_rigidity_Nm_per_arcmin": values["torsional_rigidity_Nm_per_arcmin"],
        "lost_motion_arcmin": values["lost_motion_arcmin"],
        "peak_contact_pressure_MPa": values["peak_pressure"],
        "outer_diameter_mm": outer,
        "length_mm": length,
        "total_ratio": ratio,
    }
    if res.friction is not None:
        values.update(res.friction.check_values())
        fig["efficiency"] = values["efficiency"]
        fig["life_h"] = values["life_h"]
        if req["rated_life_h"] is not None:
            fig["life_margin"] = values["life_h"] / req["rated_life_h"]
        fig["rated_torque_from_life_Nm"] = res.friction.figures()["rated_torque_from_life_Nm"][
            "value"
        ]
    checks = dict(evaluate_checks(values, scene.checks))
    checks.update(ctx.manifest.get("checks", {}))  # the first stage's, from the drive stage
    for key, c in checks.items():
        if key == "max_first_stage_bending_MPa":
            fig["first_stage_bending_MPa"] = c["value"]
        elif key == "max_first_stage_contact_MPa":
            fig["first_stage_contact_MPa"] = c["value"]
    return {**fig, **_judge(fig, checks, req, ratio)}


def _judge(fig: dict, checks: dict, req: dict, ratio: float) -> dict:
    """Each requirement's relative violation (> 0: failed) and the verdict."""
    back = {check: key for key, check in CHECK_OF.items()}
    out: dict[str, float] = {}
    for name, c in checks.items():
        limit = c["limit"]
        out[back.get(name, name)] = max(0.0, -c["margin"] / limit) if limit > 0 else 0.0
    for key, (figure, _) in _OWN.items():
        if req.get(key) is not None:
            out[key] = max(0.0, (fig[figure] - req[key]) / req[key])
    out["total_ratio"] = _ratio_miss(ratio, req.get("total_ratio"))
    failed = {k: v for k, v in out.items() if v > 0}
    worst = max(failed, key=failed.get) if failed else ""
    return {
        "feasible": not failed,
        "refused_by": worst,
        "reason": "" if not failed else _reason(worst, fig, checks, req, ratio),
        "violation": float(sum(failed.values())),
        "violations": out,
    }


def _reason(key: str, fig: dict, checks: dict, req: dict, ratio: float) -> str:
    """One phrase: the failed requirement, the candidate's value and the limit."""
    from corr_cad.figure_text import figure

    if key == "total_ratio":
        return f"total ratio {figure(ratio)}, required {req['total_ratio']}"
    if key in _OWN:
        f = _OWN[key][0]
        return f"{f} {figure(fig[f])} above {key} {figure(req[key])}"
    c = checks[CHECK_OF.get(key, key)]
    return f"{key}: value {figure(c['value'])}, limit {figure(c['limit'])}"


#: Gear outlines of the first stage by (first stage, tolerance): its gears do not
#: change while only the second stage's variables do (one process's cache).
_GEARS: dict = {}


def _with_cached_gears(ctx, drive) -> None:
    key = (repr(ctx.scene.first_stage.stage), ctx.scene.tolerance)
    if key in _GEARS:
        ctx.results.gear_outlines = _GEARS[key]
    drive(ctx)
    if len(_GEARS) > 64:
        _GEARS.clear()
    _GEARS[key] = ctx.results.gear_outlines


def needs_efficiency(sizing: dict) -> bool:
    """Does the search read the efficiency (an objective or ``min_efficiency``)?"""
    return (
        "efficiency" in sizing["objectives"] or sizing["requirements"]["min_efficiency"] is not None
    )


def evaluate_chunk(items: list, req: dict) -> list[dict]:
    """A pool or Dask task: :func:`evaluate` of each ``(id, data)``; rows in order."""
    return [evaluate(data, req) for _, data in items]
