"""``[first_stage]`` read from a scene: the gear stage's keys, checked and built.

The geometry's refusals (:mod:`corr_cad.geometry.first_stage`) become one
line naming the section and the key to change.
"""

from __future__ import annotations

from corr_cad.errors import DesignError, SceneError
from corr_cad.geometry.first_stage import FirstStage, FirstStageGeometry, first_stage_geometry
from corr_cad.run.scene.scene_schema_first_stage import REQUIRED, SECTIONS

__all__ = ["parse_first_stage", "first_stage_load", "FIRST_STAGE_CHECKS"]

#: ``[checks]`` limits the first stage's loads answer.
FIRST_STAGE_CHECKS = ("max_first_stage_bending_MPa", "max_first_stage_contact_MPa")


def parse_first_stage(values: dict, data: dict) -> FirstStageGeometry | None:
    """The first stage of a scene, or None when it has no ``[first_stage]`` section."""
    if "first_stage" not in data:
        return None
    fs = values["first_stage"]
    missing = [k for k in REQUIRED if fs[k] is None]
    if missing:
        keys = SECTIONS["first_stage"]
        example = ", ".join(f"{k} = {keys[k].example}" for k in missing)
        raise SceneError(f"[first_stage] needs {', '.join(missing)} (e.g. {example})")
    if fs["dedendum"] <= fs["addendum"]:
        raise SceneError(
            f"[first_stage] dedendum = {fs['dedendum']:g}: allowed range is > addendum "
            f"({fs['addendum']:g}), a value that works: dedendum = {fs['addendum'] + 0.25:g}"
        )
    try:
        return first_stage_geometry(FirstStage(**fs))
    except DesignError as exc:
        raise SceneError(f"[first_stage] {exc}") from exc


def first_stage_load(values: dict, load, fs: FirstStageGeometry | None, make):
    """The crank moment from ``[load] input_torque_Nm`` at the pinion (``eta1 = 1``).

    Returns ``load`` unchanged when the key is not set, else ``make(M0)``
    (the scene's ``LoadSpec``); checks the first stage's ``[checks]`` limits
    have a first stage and a torque.
    """
    t_nm = values["load"]["input_torque_Nm"]
    limits = [k for k in FIRST_STAGE_CHECKS if values["checks"][k] is not None]
    if fs is None and (t_nm is not None or limits):
        key = "[load] input_torque_Nm" if t_nm is not None else f"[checks] {limits[0]}"
        raise SceneError(f"{key} needs a [first_stage] section (the gears it refers to)")
    if t_nm is None:
        if limits and load is None:
            raise SceneError(
                f"[checks] {limits[0]} needs a torque: set [load] input_torque_Nm (e.g. 22.0)"
            )
        return load
    if load is not None:
        raise SceneError(
            "[load] give input_torque_Nm (at the pinion) or input_torque / pinion_torque, not both"
        )
    return make(t_nm * 1e3 * fs.stage.crank_gear_teeth / fs.stage.pinion_teeth)


#: The [load] keys that set the crank moment, each with a value that works.
_TORQUE_KEYS = {"input_torque_Nm": "22", "pinion_torque": "22000", "input_torque": "1.1e5"}


def small_torque_refusal(ld: dict, m0: float) -> str:
    """The refusal of a crank moment ``m0`` (N*mm) below 1 N*mm under the datasheet,
    naming the ``[load]`` key the scene gave (``ld``: the section's values)."""
    given = next((k for k in _TORQUE_KEYS if ld.get(k) is not None), "input_torque")
    if given == "input_torque":
        return (
            f"[load] input_torque = {m0:g}: the datasheet's rated torque "
            "(z + 1) * input_torque would be below 0.001 N*m; set [datasheet] "
            "rated_torque_Nm (N*m, e.g. 2860) or input_torque >= 1 N*mm"
        )
    return (
        f"[load] {given} = {ld[given]:g}: the crank moment it gives, {m0:g} N*mm, makes the "
        "datasheet's rated torque (z + 1) * M0 below 0.001 N*m; set [datasheet] "
        f"rated_torque_Nm (N*m, e.g. 2860) or {given} so that M0 >= 1 N*mm, "
        f"e.g. {given} = {_TORQUE_KEYS[given]}"
    )
