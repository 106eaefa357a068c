"""``[first_stage]`` read from a scene: the gear stage's keys, checked and built.

The geometry's refusals (:mod:`corr_cad.geometry.first_stage`) become one
line naming the section and the key to change.
"""

from __future__ import annotations

from corr_cad.errors import DesignError, SceneError
from corr_cad.geometry.first_stage import FirstStage, FirstStageGeometry, first_stage_geometry
from corr_cad.run.scene_schema_first_stage import REQUIRED, SECTIONS

__all__ = ["parse_first_stage"]


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
