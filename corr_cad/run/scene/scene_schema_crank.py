"""Scene sections of the crankshaft and its support bearings: ``[crankshaft]`` and
``[bearings.crank]`` (part of :data:`corr_cad.run.scene.scene_schema_drive.SECTIONS`).

Parsed by :mod:`corr_cad.run.scene.scene_crank`; every key defaults to a value derived
from the design (None here), and they act under ``[solver] model = "drive"`` only.
"""

from __future__ import annotations

from corr_cad.run.scene.scene_key import Key

CRANK_SECTIONS: dict[str, dict[str, Key]] = {
    "crankshaft": {
        "shaft_diameter": Key(
            "float",
            None,
            "crankshaft diameter between the journals, mm",
            low=0,
            high=2000,
            example=60.0,
        ),
        "bore_diameter": Key(
            "float",
            0.0,
            "crankshaft bore (hollow shaft), mm; 0: solid",
            low=0,
            low_open=False,
            high=2000,
            example=0.0,
            note="[0, shaft_diameter)",
        ),
        "eccentric_diameter": Key(
            "float", None, "eccentric journal diameter, mm", low=0, high=2000, example=82.4
        ),
        "eccentric_length": Key(
            "float", None, "eccentric journal length, mm", low=0, high=2000, example=12.0
        ),
        "eccentric_positions": Key(
            "list[float]",
            None,
            "axial positions of eccentrics A and B, mm (row A's rollers at 0 .. face width)",
            low=-1e4,
            high=1e4,
            example=[6.0, 26.0],
            max_len=2,
        ),
        "support_positions": Key(
            "list[float]",
            None,
            "axial positions of the two support bearings' mid-planes, mm",
            low=-1e4,
            high=1e4,
            example=[-27.0, 59.0],
            max_len=2,
        ),
        "gear_position": Key(
            "float",
            None,
            "axial position of the crank gear (the torque's entry), mm",
            low=-1e4,
            high=1e4,
            example=-49.0,
        ),
        "young_modulus_MPa": Key(
            "float",
            2.06e5,
            "crankshaft Young's modulus, MPa (steel)",
            low=0,
            high=1e7,
            example=2.06e5,
        ),
        "poisson_ratio": Key(
            "float",
            0.3,
            "crankshaft Poisson's ratio (steel)",
            low=0,
            low_open=False,
            high=0.5,
            high_open=True,
            example=0.3,
        ),
    },
    "bearings.crank": {
        "type": Key(
            "str",
            "cylindrical",
            "support bearing type (both supports alike)",
            choices=("cylindrical", "tapered_pair", "rigid"),
        ),
        "rollers": Key(
            "int", None, "rollers per row", low=3, low_open=False, high=1000, example=18
        ),
        "roller_diameter": Key("float", None, "roller diameter, mm", low=0, high=500, example=12.0),
        "roller_length": Key(
            "float", None, "roller effective contact length, mm", low=0, high=500, example=12.0
        ),
        "pitch_diameter": Key(
            "float", None, "roller pitch diameter, mm", low=0, high=5000, example=87.0
        ),
        "width": Key(
            "float",
            None,
            "bearing width, mm (places the default supports)",
            low=0,
            high=1000,
            example=22.0,
        ),
        "contact_angle_deg": Key(
            "float",
            None,
            "tapered pair: contact angle, deg (default 15)",
            low=5,
            low_open=False,
            high=45,
            example=15.0,
        ),
        "clearance": Key(
            "float",
            0.0,
            "cylindrical: diametral clearance; tapered pair: axial end play; "
            "mm, negative: a preload",
            low=-1.0,
            high=1.0,
            example=0.0,
        ),
        "dynamic_load_rating_N": Key(
            "float",
            None,
            "C_r, N (default: ISO 281's formula)",
            low=0,
            high=1e8,
            example=120000.0,
        ),
    },
}
