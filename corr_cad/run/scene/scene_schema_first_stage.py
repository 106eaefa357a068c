"""Scene section ``[first_stage]``: the gear stage between the input pinion and the
crankshaft (part of :data:`corr_cad.run.scene.scene_schema.SCHEMA`)."""

from __future__ import annotations

from corr_cad.geometry.design import MIN_AXIAL_LENGTH
from corr_cad.geometry.first_stage import MIN_MODULE
from corr_cad.run.scene.scene_key import Key

#: Keys a ``[first_stage]`` section must give (the rest have defaults).
REQUIRED = ("pinion_teeth", "wheel_teeth", "crank_gear_teeth", "module", "face_width")

_SHIFT = {"low": -2.0, "high": 3.0, "low_open": False}

SECTIONS: dict[str, dict[str, Key]] = {
    "first_stage": {
        "pinion_teeth": Key(
            "int", None, "teeth of the input pinion (required)", low=4, high=1000, example=18
        ),
        "wheel_teeth": Key(
            "int",
            None,
            "teeth of each of the three wheels on fixed axes (required)",
            low=4,
            high=1000,
            example=36,
        ),
        "crank_gear_teeth": Key(
            "int",
            None,
            "teeth of the internal gear on the crankshaft (required)",
            low=4,
            high=3000,
            example=90,
            note="(pinion_teeth + crank_gear_teeth) / 3 whole",
        ),
        "module": Key(
            "float",
            None,
            "module, mm (required)",
            low=MIN_MODULE,
            low_open=False,
            high=100.0,
            example=1.5,
        ),
        "pressure_angle_deg": Key(
            "float", 20.0, "pressure angle of the basic rack, deg", low=10.0, high=35.0
        ),
        "shift_pinion": Key("float", 0.0, "profile shift coefficient of the pinion", **_SHIFT),
        "shift_wheel": Key("float", 0.0, "profile shift coefficient of the wheels", **_SHIFT),
        "shift_crank_gear": Key(
            "float",
            0.0,
            "profile shift coefficient of the crank gear (+ = away from the axis)",
            **_SHIFT,
        ),
        "face_width": Key(
            "float",
            None,
            "face width of the gears, mm (required)",
            low=MIN_AXIAL_LENGTH,
            low_open=False,
            high=1e4,
            example=15.0,
        ),
        "addendum": Key("float", 1.0, "addendum factor of the basic rack", low=0, high=2.0),
        "dedendum": Key(
            "float", 1.25, "dedendum factor of the basic rack", low=0, high=3.0, note="> addendum"
        ),
        "backlash_allowance": Key(
            "float",
            0.0,
            "thinning of every gear's circular tooth thickness at the reference circle, mm",
            low=0,
            low_open=False,
            high=10.0,
        ),
    },
}
