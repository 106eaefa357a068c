"""Scene sections of the profile modification (issue 20): ``[modification]`` and
``[assembly]`` (part of :data:`corr_cad.run.scene_schema.SCHEMA`).

Parsed by :func:`corr_cad.run.scene_modification.parse_modification`.
"""

from __future__ import annotations

from corr_cad.run.scene_key import Key

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
