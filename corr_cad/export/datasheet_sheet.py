"""Figures of ``datasheet.json`` made from its other figures and the Monte Carlo's.

* ``whole_drive``: the whole drive's backlash and lost motion at the output (with
  ``[first_stage]``): the second stage's plus the first stage's backlash reflected to it;
* ``as_built``: the Monte Carlo's percentiles of the catalogue figures (with
  ``[tolerances]`` and the ``montecarlo`` format), which the page gives beside the nominal.
"""

from __future__ import annotations

__all__ = ["AS_BUILT_METRICS", "as_built", "whole_drive_play"]


def whole_drive_play(sheet: dict) -> dict:
    """The whole drive's backlash and lost motion at the output: the second stage's (the
    largest over the positions) plus the first stage's backlash reflected to the output
    (``sheet["first_stage"]["lost_motion_arcmin"]``); ``{}`` without a first stage.

    The two plays are in series: with the pinion held the crank turns through the first
    stage's free play, and with the crank held the output turns through the second stage's
    (its lost motion at +-b T_R); the gear teeth are taken rigid (their mesh compliance is
    not in the model)."""
    fs = sheet.get("first_stage")
    if not fs:
        return {}
    first = fs["lost_motion_arcmin"]
    return {
        "whole_drive": {
            "backlash_arcmin": sheet["backlash_arcmin"]["max"] + first,
            "lost_motion_arcmin": sheet["lost_motion_arcmin"]["max"] + first,
            "definition": "at the output, the pinion held: the second stage's backlash and "
            "lost motion (largest over the positions) plus the first stage's backlash "
            "reflected to the output (first_stage.lost_motion_arcmin); gear teeth rigid",
        }
    }


#: The Monte Carlo's metrics the page gives as built (``datasheet.json`` ``as_built``).
AS_BUILT_METRICS = (
    "lost_motion_arcmin",
    "transmission_error_arcsec",
    "torsional_rigidity_Nm_per_arcmin",
)


def as_built(mc: dict | None) -> dict:
    """``{"as_built": ...}``: the Monte Carlo's percentiles of the datasheet metrics
    (``montecarlo_summary.json`` ``percentiles``), or ``{}`` when it has none."""
    pct = (mc or {}).get("percentiles") or {}
    got = {m: pct[m] for m in AS_BUILT_METRICS if m in pct}
    if not got:
        return {}
    return {
        "as_built": {
            "samples": mc["samples"],
            **got,
            "definition": "percentiles over the Monte Carlo's samples of [tolerances] "
            "(montecarlo_summary.json): each sample's catalogue figure, at the Monte Carlo's "
            "positions ([montecarlo] datasheet_positions_per_mesh)",
        }
    }
