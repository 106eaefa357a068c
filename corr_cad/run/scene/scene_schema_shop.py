"""Scene sections for the shop and the lab: ``[edm]`` and ``[inspection]``
(part of :data:`corr_cad.run.scene.scene_schema.SCHEMA`)."""

from __future__ import annotations

from corr_cad.export.gcode import DIALECT_NAMES
from corr_cad.run.scene.scene_key import Key
from corr_cad.shop.edm import COMPENSATIONS

SECTIONS: dict[str, dict[str, Key]] = {
    "edm": {
        "wire_diameter": Key("float", 0.25, "wire diameter, mm", low=0, high=1.0),
        "spark_gap": Key("float", 0.02, "spark gap (overcut per side), mm", low=0, high=0.5),
        "start_hole_diameter": Key("float", 3.0, "start hole diameter, mm", low=0, high=50.0),
        "lead_in_length": Key(
            "float", 2.0, "lead-in: start hole centre to the wire path, mm", low=0, high=50.0
        ),
        "feed_mm_per_min": Key(
            "float",
            2.0,
            "cutting feed F, mm/min (written with 2 decimals)",
            low=0.01,
            low_open=False,
            high=10000.0,
        ),
        "dialect": Key(
            "str",
            "iso",
            "G-code dialect of the control: iso (generic ISO 6983, as before), fanuc "
            "(Fanuc-style wire EDM) or linuxcnc",
            choices=DIALECT_NAMES,
        ),
        "compensation": Key(
            "str",
            "path",
            "wire offset: path (in the programmed path) or G41 / G42 (by the control from "
            "the D register; the path is then the finished part contour)",
            choices=COMPENSATIONS,
        ),
        "d_register": Key(
            "int",
            1,
            "G41/G42 offset register D (LinuxCNC: tool number)",
            low=1,
            low_open=False,
            high=99,
        ),
        "program_number": Key(
            "int", 1000, "program number O of the fanuc dialect", low=1, low_open=False, high=7999
        ),
        "slug_stop_mm": Key(
            "float",
            None,
            "program stop this far before the contour closes, to secure the slug, mm; 0 = none "
            "(default: 0 for iso, 1 for fanuc and linuxcnc)",
            low=0,
            low_open=False,
            high=50.0,
            example=1.0,
            note="0 or at least 0.1, and under half the contour",
        ),
        "wire_thread_mcode": Key(
            "int",
            None,
            "M-code that threads the wire at the start hole, from the machine's own list "
            "(default: a program stop for the operator)",
            low=3,
            low_open=False,
            high=999,
            example=50,
            note="not M30, M98, M99; linuxcnc: 100 to 199",
        ),
        "wire_cut_mcode": Key(
            "int",
            None,
            "M-code that cuts the wire at the end, from the machine's own list (default: none)",
            low=3,
            low_open=False,
            high=999,
            example=60,
            note="not M30, M98, M99; linuxcnc: 100 to 199",
        ),
    },
    "inspection": {
        "point_spacing": Key(
            "float", 0.5, "CMM nominal points: spacing along the curve, mm", low=0, high=100.0
        ),
        "evaluation_psi_deg": Key(
            "float",
            180.0,
            "evaluated flank: |psi| up to this from the tooth-space centre, deg",
            low=0,
            high=180.0,
        ),
        "profile_tolerance": Key(
            "float",
            None,
            "profile: half-band around the nominal, mm",
            low=0,
            high=10.0,
            example=0.01,
        ),
        "position_tolerance_arcsec": Key(
            "float", None, "tooth position, arcsec", low=0, high=36000.0, example=20.0
        ),
        "single_pitch_tolerance_arcsec": Key(
            "float", None, "single pitch deviation, arcsec", low=0, high=36000.0, example=20.0
        ),
        "cumulative_pitch_tolerance_arcsec": Key(
            "float",
            None,
            "cumulative pitch over any span, arcsec",
            low=0,
            high=36000.0,
            example=40.0,
        ),
        "runout_tolerance": Key(
            "float", None, "runout of the tooth spaces, mm", low=0, high=10.0, example=0.02
        ),
        "row": Key(
            "str",
            None,
            'the measured ring inspected: "a" ([errors] measured_profile, the default) or '
            '"b" ([errors.row_b] measured_profile, model = "drive"); the drive\'s play is '
            "predicted with it in its row",
            choices=("a", "b"),
            example="a",
        ),
    },
}
