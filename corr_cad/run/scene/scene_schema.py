"""The scene schema: every section and key, with its type, default, range and help.

:data:`SCHEMA` is the single source of truth: the loader (:mod:`corr_cad.run.scene.scene`),
the commented template, the README's bounds table and the JSON Schema are all
generated from it.
"""

from __future__ import annotations

from corr_cad.geometry.design import BOUNDS as DESIGN_BOUNDS
from corr_cad.geometry.sampling import REPRESENTATIONS
from corr_cad.mechanics.row.solver import VARIANTS
from corr_cad.run.scene import (
    scene_schema_drive,
    scene_schema_first_stage,
    scene_schema_friction,
    scene_schema_lubrication,
    scene_schema_modification,
    scene_schema_run,
    scene_schema_shop,
    scene_schema_sizing,
    scene_schema_tolerance,
)
from corr_cad.run.scene.scene_key import (  # noqa: F401  (re-exported)
    MAX_ANGLE_DEG,
    MAX_LIST,
    MAX_NESTING,
    MAX_SCENE_BYTES,
    MAX_STR,
    Key,
    key_range,
)

#: Output formats a scene may list in ``[export] formats``.
FORMATS = (
    "dxf",
    "png",
    "forces",
    "stl",
    "3mf",
    "glb",
    "ply",
    "step",
    "interference",
    "montecarlo",
    "allocation",
    "sweeps",
    "datasheet",
    "edm",
    "cmm",
    "inspection",
    "modification",
    "sizing",
    "report",
)

#: ``[solver] model``: the paper's one row, or both rows of the drive together.
SOLVER_MODELS = ("paper", "drive")
#: ``[solver] contact_law``: the paper's Eqs. 9-12, or Palmgren's line contact.
CONTACT_LAWS = ("paper", "palmgren")
#: ``[solver] bodies``: the ring and the frame rigid, or elastic (finite elements).
BODIES = ("rigid", "elastic")

#: ``formats = ["all"]``: every format the scene can make (those that need an
#: input the scene lacks are left out, and the run says which and why).
ALL = "all"

#: ``[export] interference_method``: exact 2D clearances, mesh booleans, or both.
INTERFERENCE_METHODS = ("exact", "mesh", "both")
#: Upper bound of the mesh-boolean sweep (each position costs ~0.8 s).
MESH_POSITIONS_MAX = 3600


def _dk(name: str) -> dict:
    """Schema bounds of a design key, the same numbers ``GearDesign`` checks."""
    lo, hi = DESIGN_BOUNDS[name]
    return {"low": lo, "high": hi}


SCHEMA: dict[str, dict[str, Key]] = {
    "design": {
        "tooth_count": Key(
            "int", 25, "z, teeth of the fixed inner gear (z + 1 rollers)", **_dk("tooth_count")
        ),
        "cam_radius": Key("float", 135.0, "Rj, disk cam radius, mm", **_dk("cam_radius")),
        "roller_radius": Key("float", 8.0, "r, roller radius, mm", **_dk("roller_radius")),
        "roller_length": Key("float", 12.0, "roller contact length, mm", **_dk("roller_length")),
        "eccentricity": Key(
            "float", 3.5, "e, cam eccentricity, mm", **_dk("eccentricity"), note="< cam_radius"
        ),
        "ring_outer_radius": Key(
            "float",
            None,
            "gear ring outer radius, mm (default: e + Rj + 2r + max(10, 3r), rounded up to 5 mm)",
            **_dk("ring_outer_radius"),
            note="[e + Rj + 2r + 1, 10 (e + Rj + 2r)]",
            example=180.0,
        ),
        "face_width": Key(
            "float",
            None,
            "gear ring / cam face width, mm (default: roller_length)",
            **_dk("face_width"),
            example=12.0,
        ),
        "cam_bore_radius": Key(
            "float",
            None,
            "cam eccentric bore radius, mm (default: min(0.35 Rj, (Rj - e)/2) rounded to "
            "0.1 mm, a half to the even digit)",
            **_dk("cam_bore_radius"),
            note="(0, Rj - e - 1]",
            example=47.2,
        ),
        "frame_inner_radius": Key(
            "float",
            None,
            "slotted frame plate inner radius, mm (default: max(Rj - e - 1 - max(5, r), "
            "(Rj - e - 1)/2), max(5, r) inside the slot ends)",
            **_dk("frame_inner_radius"),
            example=122.5,
            note="(0, Rj - e - 2]: 1 mm inside the slot ends",
        ),
        "frame_outer_radius": Key(
            "float",
            None,
            "slotted frame plate outer radius, mm (default: Rj + e + 2r + 1 + max(5, r), "
            "max(5, r) beyond the slot ends)",
            **_dk("frame_outer_radius"),
            example=163.5,
            note="1 mm beyond the slot ends to 10 times their radius",
        ),
        "frame_thickness": Key(
            "float",
            None,
            "thickness of each slotted frame plate, mm (default: max(5, r))",
            **_dk("frame_thickness"),
            example=8.0,
        ),
        "allow_undercut": Key(
            "bool", False, "accept an undercut design; the profile is then the swept boundary"
        ),
        "slot_clearance": Key(
            "float",
            None,
            'diametral clearance of each frame slot over its roller (model = "drive"; '
            "default 0: a roller error goes into both flanks), mm",
            low=-1.0,
            low_open=False,
            high=1.0,
            example=0.0,
        ),
    },
    "material": {
        "young_modulus": Key("float", 2.06e5, "E, MPa", **_dk("young_modulus")),
        "poisson_ratio": Key("float", 0.3, "Poisson's ratio", low=-1, high=0.5, high_open=True),
    },
    "export": {
        "formats": Key(
            "list[str]",
            ["dxf", "png"],
            'outputs to produce; ["all"]: every format this scene can make',
            choices=(*FORMATS, ALL),
        ),
        "representation": Key(
            "str", "polyline", "DXF profile representation", choices=REPRESENTATIONS
        ),
        "chord_tolerance": Key(
            "float",
            None,
            "max deviation of mesh and STEP geometry from the exact curves, mm "
            "(default: tolerance)",
            low=0,
            high=10.0,
            example=0.001,
            note="and the mesh at most 5e6 triangles per file",
        ),
        "assembly_angles_deg": Key(
            "list[float]",
            [0.0],
            "crank angles of the assembly meshes, deg (relative to the frame)",
            low=-MAX_ANGLE_DEG,
            low_open=False,
            high=MAX_ANGLE_DEG,
            max_len=360,
        ),
        "interference_method": Key(
            "str",
            "exact",
            "interference check: exact 2D clearances (clearance.csv), mesh booleans "
            "(interference.csv) or both",
            choices=INTERFERENCE_METHODS,
        ),
        "interference_positions": Key(
            "int",
            None,
            "crank positions of the interference check over a full cycle "
            "(default 3600 exact, 36 mesh)",
            low=0,
            high=100000,
            example=3600,
        ),
        "tolerance": Key(
            "float",
            0.001,
            "max deviation of exported geometry from the exact curve, mm",
            low=0,
            high=10.0,
            note="and at most 1e6 DXF vertices per profile",
        ),
    },
    "load": {
        "input_torque": Key(
            "float",
            None,
            "M0, torque on the crankshaft, N*mm",
            low=-1e12,
            high=1e12,
            example=1.0e6,
        ),
        "pinion_torque": Key(
            "float",
            None,
            "input pinion torque, N*mm (with first_stage_ratio)",
            low=-1e12,
            high=1e12,
            example=1.0e5,
        ),
        "input_torque_Nm": Key(
            "float",
            None,
            "torque on the input pinion, N*m (needs [first_stage]; M0 = T_in crank_gear_teeth "
            "/ pinion_teeth)",
            low=-1e9,
            high=1e9,
            example=22.0,
        ),
        "first_stage_ratio": Key(
            "float",
            None,
            "first-stage ratio: M0 = pinion_torque * ratio",
            low=0,
            high=1e4,
            example=10.0,
        ),
    },
    "solver": {
        "positions": Key(
            "int",
            3600,
            "crank positions per cycle",
            low=0,
            high=10_000_000,
            note="and within the memory budget ([budget] memory_gb, default 3 GB)",
        ),
        "model": Key(
            "str",
            "paper",
            'the force model: "paper", one row carrying load_share of M0 (Eq. 8); "drive", '
            "both rows and both cams together (no load_share)",
            choices=SOLVER_MODELS,
        ),
        "contact_law": Key(
            "str",
            "paper",
            'roller contact law: "paper" (Eqs. 9-12), "palmgren" (steel line contact, '
            "delta = 3.84e-5 Q^0.9 / l^0.8)",
            choices=CONTACT_LAWS,
        ),
        "bodies": Key(
            "str",
            "rigid",
            'the gear ring and the slotted frame: "rigid", or "elastic" (plane-stress finite '
            'elements of the drawn outlines, model = "drive" only)',
            choices=BODIES,
        ),
        "load_share": Key(
            "float",
            0.55,
            'share of M0 carried by one cam (Eq. 8), model = "paper" only',
            low=0,
            high=1,
        ),
        "crank_angles_deg": Key(
            "list[float]",
            None,
            "solve only at these crank angles, deg (default: positions over a full cycle)",
            low=-MAX_ANGLE_DEG,
            low_open=False,
            high=MAX_ANGLE_DEG,
            max_len=100_000,
            example=[0.0, 5.0, 10.0],
        ),
        "variants": Key("list[str]", [], "printed-paper variants to switch on", choices=VARIANTS),
    },
    "errors": {
        "cam_radius_error": Key(
            "float", 0.0, "cam radius error dRj, mm (+ = oversize)", note="(-r/2, r/2)"
        ),
        "eccentricity_error": Key(
            "float", 0.0, "eccentricity (installation) error de, mm", note="(-r/2, r/2)"
        ),
        "roller_radius_error": Key(
            "float", 0.0, "roller radius error dr for every roller, mm", note="(-r/2, r/2)"
        ),
        "roller_radius_errors": Key(
            "list[float]",
            None,
            "per-roller radius errors, z + 1 values, mm",
            example=[0.0],
            note="each (-r/2, r/2)",
        ),
        "slot_angle_errors_deg": Key(
            "list[float]",
            None,
            "per-slot angular position errors, z + 1 values, deg",
            example=[0.0],
            note="each within a quarter slot pitch, (-90/(z+1), 90/(z+1))",
        ),
        "cam_phase_error_deg": Key(
            "float",
            0.0,
            "cam phase error against the other cam, deg (a quarter turn at most: at 180 the "
            "cams stand in phase and the drive's solver finds no equilibrium)",
            low=-90.0,
            low_open=False,
            high=90.0,
        ),
        "measured_profile": Key(
            "str",
            None,
            "measured gear profile: CSV x,y (mm), DXF, or a ring mesh (STL, PLY; sliced at mid "
            "face width), path relative to the scene",
            example="measured.csv",
        ),
        "measured_exaggeration": Key(
            "float",
            200.0,
            "deviation scale of the picture in measured_profile.dxf",
            low=0,
            high=1e6,
        ),
        "profile_deviation_harmonics": Key(
            "list[list[float]]",
            None,
            "gear profile deviation: rows [order, amplitude mm, phase deg] (+ = material added)",
            example=[[3.0, 0.002, 0.0]],
            max_len=100,
            note="order an integer in [1, 10000], amplitude in (-r/2, r/2), phase in [-3600, 3600]",
        ),
    },
    **scene_schema_drive.SECTIONS,
    "checks": {
        "max_contact_pressure": Key(
            "float", None, "allowable Hertz pressure, MPa", low=0, high=1e6, example=1500.0
        ),
        "max_gear_force": Key(
            "float", None, "allowable peak gear force F_n, N", low=0, high=1e10, example=5000.0
        ),
        "min_loaded_rollers": Key(
            "int",
            None,
            "fewest rollers that must carry load",
            low=-1,
            high=1001,
            example=4,
            note="[0, z + 1]",
        ),
        "max_lost_motion_arcmin": Key(
            "float",
            None,
            "allowable lost motion at +-[datasheet] lost_motion_band of the rated torque, arcmin "
            "(its meaning before the datasheet, the free play, is max_backlash_arcmin; with "
            "[first_stage] the whole drive's)",
            low=0,
            high=21600,
            example=1.0,
        ),
        "max_backlash_arcmin": Key(
            "float",
            None,
            "allowable output backlash (free rotation at zero torque), arcmin (with "
            "[first_stage] the whole drive's)",
            low=0,
            high=21600,
            example=1.0,
        ),
        "min_torsional_rigidity_Nm_per_arcmin": Key(
            "float",
            None,
            "smallest allowed torsional rigidity (with the series rigidity), N*m/arcmin (with "
            "[first_stage] the whole drive's)",
            low=0,
            high=1e9,
            example=1000.0,
        ),
        "max_transmission_error_arcsec": Key(
            "float",
            None,
            "allowable transmission error, peak-to-peak over one output revolution, arcsec",
            low=0,
            high=1296000,
            example=60.0,
        ),
        "min_efficiency": Key(
            "float",
            None,
            "smallest allowed forward efficiency over the [friction] map (with [first_stage] "
            "the whole drive's)",
            low=0,
            high=1,
            example=0.8,
        ),
        "min_life_h": Key(
            "float",
            None,
            "smallest allowed system L10 at the rated torque and [life] rated_speed_rpm, h",
            low=0,
            high=1e9,
            example=6000.0,
        ),
        "max_first_stage_bending_MPa": Key(
            "float",
            None,
            "allowable tooth-root bending stress of the first stage's gears (Lewis), MPa",
            low=0,
            high=1e6,
            example=300.0,
        ),
        "max_first_stage_contact_MPa": Key(
            "float",
            None,
            "allowable contact stress of the first stage's meshes (Hertz), MPa",
            low=0,
            high=1e6,
            example=1200.0,
        ),
        "max_failure_probability": Key(
            "float",
            None,
            "gate the Monte Carlo too: largest allowed probability of breaking each limit, "
            "in [0, 1] (default: only the nominal design is gated)",
            low=0,
            low_open=False,
            high=1,
            example=0.01,
        ),
        "max_binding_probability": Key(
            "float",
            None,
            "gate the Monte Carlo on binding: largest allowed probability that a sample binds "
            "at zero torque (preload pressure above [montecarlo] binding_pressure_MPa), in [0, 1]",
            low=0,
            low_open=False,
            high=1,
            example=0.01,
        ),
    },
    **scene_schema_tolerance.SECTIONS,
    **scene_schema_friction.SECTIONS,
    **scene_schema_lubrication.SECTIONS,
    **scene_schema_shop.SECTIONS,
    **scene_schema_modification.SECTIONS,
    **scene_schema_first_stage.SECTIONS,
    **scene_schema_sizing.SECTIONS,
    **scene_schema_run.SECTIONS,
}
