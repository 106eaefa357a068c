"""Scene sections of the two-row drive: ``[errors.row_b]``, ``[bearings.eccentric]``,
``[bearings.eccentric_b]``, ``[crankshaft]`` and ``[bearings.crank]`` (part of
:data:`corr_cad.run.scene.scene_schema.SCHEMA`).

Parsed by :func:`corr_cad.run.scene.scene_drive.parse_drive`; they act under
``[solver] model = "drive"`` only.
"""

from __future__ import annotations

from corr_cad.run.scene.scene_key import Key
from corr_cad.run.scene.scene_schema_crank import CRANK_SECTIONS

#: Smallest needle diameter and length, mm: half of ISO 3096's smallest needle
#: roller (1 mm by 5.8 mm). At 1e-3 mm the needles' Palmgren stiffness leaves
#: the drive's solver at an infinite residual, at 1e-300 a NaN.
MIN_NEEDLE_MM = 0.5


def _bearing(override: bool) -> dict[str, Key]:
    what = "cam B's bearing (default: [bearings.eccentric])" if override else "each cam's bearing"
    return {
        "needles": Key(
            "int", None, f"needles of {what}", low=3, low_open=False, high=1000, example=40
        ),
        "needle_diameter": Key(
            "float",
            None,
            f"needle diameter of {what}, mm",
            low=MIN_NEEDLE_MM,
            low_open=False,
            high=100,
            example=6.0,
        ),
        "needle_length": Key(
            "float",
            None,
            f"needle contact length of {what}, mm",
            low=MIN_NEEDLE_MM,
            low_open=False,
            high=1000,
            example=12.0,
        ),
        "diametral_clearance": Key(
            "float",
            None if override else 0.0,
            f"diametral clearance Pd of {what}, mm",
            low=0,
            low_open=False,
            high=1.0,
            example=0.0,
        ),
    }


#: The keys of ``[errors]`` that ``[errors.row_b]`` takes (the slots are the
#: frame's, the cam phase is cam B's against A: both stay in ``[errors]``).
ROW_B_KEYS = (
    "cam_radius_error",
    "eccentricity_error",
    "roller_radius_error",
    "roller_radius_errors",
    "profile_deviation_harmonics",
    "measured_profile",
)

SECTIONS: dict[str, dict[str, Key]] = {
    "errors.row_b": {
        "cam_radius_error": Key(
            "float", 0.0, "row B: cam B radius error, mm (+ = oversize)", note="(-r/2, r/2)"
        ),
        "eccentricity_error": Key(
            "float", 0.0, "row B: eccentricity error of cam B, mm", note="(-r/2, r/2)"
        ),
        "roller_radius_error": Key(
            "float", 0.0, "row B: radius error of every roller, mm", note="(-r/2, r/2)"
        ),
        "roller_radius_errors": Key(
            "list[float]",
            None,
            "row B: per-roller radius errors, z + 1 values, mm",
            example=[0.0],
            note="each (-r/2, r/2)",
        ),
        "profile_deviation_harmonics": Key(
            "list[list[float]]",
            None,
            "row B: ring B profile deviation, rows [order, amplitude mm, phase deg]",
            example=[[3.0, 0.002, 0.0]],
            max_len=100,
            note="order an integer in [1, 10000], amplitude in (-r/2, r/2), phase in [-3600, 3600]",
        ),
        "measured_profile": Key(
            "str",
            None,
            "row B: ring B's measured gear profile: CSV x,y (mm), DXF, or a ring mesh (STL, "
            "PLY; sliced at mid face width), path relative to the scene",
            example="measured_b.csv",
        ),
    },
    "bearings.eccentric": _bearing(False),
    "bearings.eccentric_b": _bearing(True),
    **CRANK_SECTIONS,
}
