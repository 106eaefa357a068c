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
