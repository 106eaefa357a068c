"""The scene schema: every section and key, with its type, default, range and help.

:data:`SCHEMA` is the single source of truth: the loader (:mod:`corr_cad.run.scene`),
the commented template, the README's bounds table and the JSON Schema are all
generated from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from corr_cad.bounds import range_text
from corr_cad.geometry.design import BOUNDS as DESIGN_BOUNDS
from corr_cad.geometry.sampling import REPRESENTATIONS
from corr_cad.mechanics.solver import VARIANTS
from corr_cad.tolerance.montecarlo import TOLERANCE_KINDS
from corr_cad.tolerance.sweeps import PAPER_SWEEPS

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
    "edm",
    "cmm",
    "inspection",
    "report",
)

#: ``[export] interference_method``: exact 2D clearances, mesh booleans, or both.
INTERFERENCE_METHODS = ("exact", "mesh", "both")
#: Upper bound of the mesh-boolean sweep (each position costs ~0.8 s).
MESH_POSITIONS_MAX = 3600


@dataclass(frozen=True)
class Key:
    kind: str  # "int", "float", "bool", "str", "list[str]", "list[float]"
    default: Any
    help: str
    choices: tuple[str, ...] | None = None
    low: float | None = None  # exclusive lower bound for numbers (list items too)
    high: float | None = None  # inclusive upper bound
    example: Any = None
    high_open: bool = False  # the upper bound itself is not allowed
    low_open: bool = True  # the lower bound itself is not allowed
    max_len: int | None = None  # most entries a list may hold
    note: str = ""  # a range that depends on the design, shown in the README table


#: Most entries of a list key whose length the design does not fix.
MAX_LIST = 1000
#: Largest |angle| in degrees anywhere in a scene (ten turns).
MAX_ANGLE_DEG = 3600.0
#: Largest scene file (bytes) and deepest nesting of arrays/tables read.
MAX_SCENE_BYTES = 10 * 1024 * 1024
MAX_NESTING = 32
#: Longest string value (a measured profile path).
MAX_STR = 4096


def _dk(name: str) -> dict:
    """Schema bounds of a design key, the same numbers ``GearDesign`` checks."""
    lo, hi = DESIGN_BOUNDS[name]
    return {"low": lo, "high": hi}


#: Ranges of the tolerance scales that depend on the design (like the errors).
_TOL_NOTE = {
    "cam_radius": "[0, r/2)",
    "eccentricity": "[0, r/2)",
    "roller_radius": "[0, r/2)",
    "slot_angle": "[0, 90/(z+1)) deg",
    "cam_phase": "[0, 180] deg",
}

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
            "gear ring outer radius, mm (default: rim of max(10, 3r))",
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
            "cam eccentric bore radius, mm (default: min(0.35 Rj, (Rj - e)/2))",
            **_dk("cam_bore_radius"),
            note="(0, Rj - e - 1]",
            example=47.2,
        ),
        "frame_inner_radius": Key(
            "float",
            None,
            "slotted frame plate inner radius, mm",
            **_dk("frame_inner_radius"),
            example=122.5,
            note="(0, Rj - e - 2]: 1 mm inside the slot ends",
        ),
        "frame_outer_radius": Key(
            "float",
            None,
            "slotted frame plate outer radius, mm",
            **_dk("frame_outer_radius"),
            example=163.5,
            note="1 mm beyond the slot ends to 10 times their radius",
        ),
        "frame_thickness": Key(
            "float",
            None,
            "thickness of each slotted frame plate, mm",
            **_dk("frame_thickness"),
            example=8.0,
        ),
        "allow_undercut": Key(
            "bool", False, "accept an undercut design; the profile is then the swept boundary"
        ),
    },
    "material": {
        "young_modulus": Key("float", 2.06e5, "E, MPa", **_dk("young_modulus")),
        "poisson_ratio": Key("float", 0.3, "Poisson's ratio", low=-1, high=0.5, high_open=True),
    },
    "export": {
        "formats": Key("list[str]", ["dxf", "png"], "outputs to produce", choices=FORMATS),
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
            note="and within the memory budget (2 GB)",
        ),
        "load_share": Key("float", 0.55, "share of M0 carried by one cam (Eq. 8)", low=0, high=1),
        "crank_angles_deg": Key(
            "list[float]",
            None,
            "solve only at these crank angles, deg",
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
            "float", 0.0, "cam phase error against the other cam, deg", low=-180.0, high=180.0
        ),
        "measured_profile": Key(
            "str",
            None,
            "measured gear profile: CSV x,y (mm) or DXF, path relative to the scene",
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
            "float", None, "allowable output lost motion, arcmin", low=0, high=21600, example=1.0
        ),
        "max_failure_probability": Key(
            "float",
            None,
            "gate the Monte Carlo too: largest allowed probability of breaking each limit, "
            "in [0, 1] (default: only the nominal design is gated)",
            high=1,
            example=0.01,
        ),
    },
    "tolerances": {
        kind: Key(
            "distribution",
            None,
            f"{kind.replace('_', ' ')} tolerance, {unit}: "
            "{ normal = sigma } or { uniform = half width }",
            example={"normal": 0.001 if unit == "mm" else 0.01},
            note=_TOL_NOTE[kind],
        )
        for kind, (_, unit) in TOLERANCE_KINDS.items()
    },
    "montecarlo": {
        "samples": Key(
            "int",
            1000,
            "Monte Carlo samples",
            low=0,
            high=10_000_000,
            note="and within the memory budget (2 GB)",
        ),
        "seed": Key("int", 1, "random seed (runs are reproducible)", low=-1, high=1e9),
        "positions": Key(
            "int",
            360,
            "crank positions per sample (full cycle)",
            low=0,
            high=100_000,
            note="and within the memory budget (2 GB)",
        ),
        "percentile": Key(
            "float", 95.0, "percentile the allocation keeps under the limits", low=0, high=100
        ),
        "allocation_samples": Key(
            "int", 200, "samples per step of the allocation search", low=0, high=100_000
        ),
    },
    "sweeps": {
        "points": Key("int", 7, "points per sweep", low=1, high=1000),
        "positions": Key("int", 720, "crank positions per sweep point", low=0, high=100_000),
        **{
            name: Key(
                "list[float]",
                None,
                f"[min, max] of the {name.replace('_', ' ')} sweep, mm (default: "
                + (
                    "+-20 % of the design value"
                    if where == "design"
                    else "+-0.02 mm around the [errors] value"
                )
                + "; the paper's range for its Table 1 design; clipped to the valid design space)",
                example=[lo, hi],
                max_len=2,
            )
            for name, (where, lo, hi) in PAPER_SWEEPS.items()
        },
    },
    "edm": {
        "wire_diameter": Key("float", 0.25, "wire diameter, mm", low=0, high=1.0),
        "spark_gap": Key("float", 0.02, "spark gap (overcut per side), mm", low=0, high=0.5),
        "start_hole_diameter": Key("float", 3.0, "start hole diameter, mm", low=0, high=50.0),
        "lead_in_length": Key(
            "float", 2.0, "lead-in: start hole centre to the wire path, mm", low=0, high=50.0
        ),
        "feed_mm_per_min": Key("float", 2.0, "cutting feed F, mm/min", low=0, high=10000.0),
    },
    "budget": {
        "memory_gb": Key(
            "float",
            None,
            "largest memory the run may plan to use, GB: this process and its pool workers "
            "(default 3; --max-memory overrides)",
            low=0,
            high=1024.0,
            example=3.0,
            note="and at most this machine's memory",
        ),
        "output_gb": Key(
            "float",
            None,
            "largest total size of the files the run may write, GB (default 1; "
            "--max-output overrides)",
            low=0,
            high=100_000.0,
            example=1.0,
        ),
        "time_warning_s": Key(
            "float",
            None,
            "warn (and still run) when the run is estimated to take longer, s (default 60; "
            "--warn-time overrides)",
            low=0,
            high=1e7,
            example=60.0,
        ),
    },
    "dask": {
        "connect_timeout_s": Key(
            "float",
            None,
            "--executor dask: give up when the scheduler has not answered within this, s "
            "(default 5; --dask-connect-timeout overrides)",
            low=0,
            high=600.0,
            example=5.0,
        ),
        "no_workers_timeout_s": Key(
            "float",
            None,
            "--executor dask: give up when the scheduler has had no worker for this long, s "
            "(default 30; --dask-no-workers-timeout overrides)",
            low=0,
            high=86400.0,
            example=30.0,
        ),
        "stall_timeout_s": Key(
            "float",
            None,
            "--executor dask: give up when no task has finished for this long, s (default "
            "120, and at least 3 times the estimated time of one task; "
            "--dask-stall-timeout overrides)",
            low=0,
            high=86400.0,
            example=120.0,
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
    },
}


def key_range(spec: Key) -> str:
    """The allowed range of a numeric key, as every message and the README state it."""
    return range_text(spec.low, spec.high, low_open=spec.low_open, high_open=spec.high_open)
