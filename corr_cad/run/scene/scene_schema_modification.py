"""Scene sections of the profile modification (issue 20): ``[modification]`` and
``[assembly]`` (part of :data:`corr_cad.run.scene.scene_schema.SCHEMA`).

Parsed by :func:`corr_cad.run.scene.scene_modification.parse_modification`.
"""

from __future__ import annotations

from corr_cad.run.scene.scene_key import Key
from corr_cad.tolerance.modification_design import FAMILIES, OBJECTIVES

#: Inspect a measured ring against the modified profile or the conjugate one.
INSPECT_AGAINST = ("modified", "conjugate")

SECTIONS: dict[str, dict[str, Key]] = {
    "modification": {
        "equidistant_mm": Key(
            "float",
            0.0,
            "equidistant modification: the working profile is the locus offset by "
            "r + equidistant_mm, mm (+ = clearance, material removed from the ring)",
            low=-1.0,
            high=1.0,
            example=0.01,
        ),
        "shift_mm": Key(
            "float",
            0.0,
            "shift modification: the locus is generated with L + shift_mm, mm (+ = clearance)",
            low=-1.0,
            high=1.0,
            example=0.01,
        ),
        "normal_table": Key(
            "str",
            None,
            "extra normal modification along the tooth space: CSV psi_deg,normal_mm (psi 0 "
            "tooth space, 180 tip; [0, 180] symmetric or [-180, 180]), path relative to the scene",
            example="modification.csv",
        ),
        "inspect_against": Key(
            "str",
            "modified",
            "nominal of the inspection: the modified profile or the conjugate one",
            choices=INSPECT_AGAINST,
        ),
    },
    "modification.design": {
        "target_backlash_arcmin": Key(
            "float",
            None,
            "design the modification (format modification): largest backlash at "
            "backlash_percentile under [tolerances], arcmin",
            low=0.0,
            high=600.0,
            example=2.0,
        ),
        "backlash_percentile": Key(
            "float", 95.0, "percentile the backlash target applies to", low=50.0, high=100.0
        ),
        "max_binding_probability": Key(
            "float",
            0.05,
            "largest probability that the drive binds (preloaded rollers) under [tolerances]",
            low=0.0,
            low_open=False,
            high=1.0,
        ),
        "family": Key(
            "str",
            "equidistant+shift",
            "search space: equidistant, equidistant+shift, or free (a symmetric normal curve "
            "through control points at psi 0, 60, 120, 180 deg, each on the "
            "equidistant_range_mm grid: steps^4 candidates)",
            choices=FAMILIES,
        ),
        "objective": Key(
            "str",
            "peak_pressure",
            "objective at rated torque: peak_pressure (p95, smallest), loaded_rollers "
            "(p5 of the fewest loaded rollers, largest) or transmission_error (nominal, "
            "smallest)",
            choices=OBJECTIVES,
        ),
        "equidistant_range_mm": Key(
            "list[float]",
            [0.0, 0.03],
            "equidistant_mm searched from, to (mm)",
            low=-1.0,
            high=1.0,
            max_len=2,
            note="two values, from < to",
        ),
        "shift_range_mm": Key(
            "list[float]",
            [-0.02, 0.02],
            "shift_mm searched from, to (mm; family equidistant+shift)",
            low=-1.0,
            high=1.0,
            max_len=2,
            note="two values, from < to",
        ),
        "steps": Key("int", 7, "grid points per parameter", low=2, low_open=False, high=101),
        "samples": Key("int", 200, "tolerance samples", low=10, low_open=False, high=100_000),
        "seed": Key("int", 1, "seed of the tolerance samples", low=0, low_open=False, high=2**31),
        "positions": Key("int", 64, "crank positions per cycle", low=8, low_open=False, high=3600),
        "force_candidates": Key(
            "int",
            5,
            "feasible candidates solved for forces (spread over the backlash range)",
            low=1,
            low_open=False,
            high=100,
        ),
    },
    "assembly": {
        "roller_classes_um": Key(
            "list[float]",
            None,
            "roller size classes the user can buy: roller radius deviation of each class, um",
            low=-1000.0,
            high=1000.0,
            max_len=100,
            example=[-4.0, -2.0, 0.0, 2.0],
        ),
        "target_backlash_arcmin": Key(
            "float",
            1.0,
            "selective assembly: largest backlash a class may give, arcmin",
            low=0.0,
            high=600.0,
        ),
    },
}
