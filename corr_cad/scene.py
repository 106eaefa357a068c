"""Scene files: what to build and which effects to simulate.

A scene is a TOML file. Its sections and keys are an interface that other
tools rely on; unknown sections and keys are rejected with the list of valid
ones. :data:`SCHEMA` is the single source of truth: validation, the commented
template written by ``corr-cad new`` and the README table all come from it.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .bounds import out_of_range, range_text, show
from .design import BOUNDS as DESIGN_BOUNDS
from .design import GearDesign, Material
from .deviations import ManufacturingErrors as ErrorSpec
from .deviations import harmonic_deviation
from .errors import CorrCadError, SceneError
from .inputfiles import read_regular_file
from .profile import working_profile
from .sampling import REPRESENTATIONS
from .solver import VARIANTS
from .sweeps import PAPER_SWEEPS
from .tolerance import TOLERANCE_KINDS, Checks, Distribution

__all__ = [
    "SCHEMA",
    "FORMATS",
    "VARIANTS",
    "Scene",
    "LoadSpec",
    "SolverSpec",
    "ErrorSpec",
    "load_scene",
    "parse_scene",
    "template_text",
]

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


@dataclass(frozen=True)
class LoadSpec:
    """Crankshaft input moment M0, N*mm."""

    input_torque: float


@dataclass(frozen=True)
class SolverSpec:
    positions: int = 3600
    load_share: float = 0.55
    crank_angles_deg: tuple[float, ...] | None = None
    variants: tuple[str, ...] = ()


@dataclass(frozen=True)
class Scene:
    """A validated scene."""

    name: str
    design: GearDesign
    formats: tuple[str, ...] = ("dxf", "png")
    representation: str = "polyline"
    tolerance: float = 0.001
    chord_tolerance: float = 0.001
    assembly_angles_deg: tuple[float, ...] = (0.0,)
    interference_method: str = "exact"
    interference_positions: int | None = None  # None: 3600 exact, 36 mesh

    def positions_for(self, method: str) -> int:
        """Crank positions of the ``exact`` or ``mesh`` interference check."""
        if self.interference_positions is not None:
            return self.interference_positions
        return 3600 if method == "exact" else 36

    load: LoadSpec | None = None
    solver: SolverSpec = field(default_factory=SolverSpec)
    errors: ErrorSpec = field(default_factory=ErrorSpec)
    checks: Checks = field(default_factory=Checks)
    measured_profile: Path | None = None
    measured_exaggeration: float = 200.0
    tolerances: dict = field(default_factory=dict)
    montecarlo: dict = field(default_factory=dict)
    sweeps: dict = field(default_factory=dict)
    edm: dict = field(default_factory=dict)
    inspection: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)
    #: One line per section or key that has no effect in this scene.
    warnings: tuple[str, ...] = ()


def _where(section: str, key: str) -> str:
    return f"[{section}] {key}"


def key_range(spec: Key) -> str:
    """The allowed range of a numeric key, as every message and the README state it."""
    return range_text(spec.low, spec.high, low_open=spec.low_open, high_open=spec.high_open)


def _coerce(section: str, key: str, spec: Key, value: Any) -> Any:
    where = _where(section, key)
    if spec.kind == "bool":
        if not isinstance(value, bool):
            raise SceneError(f"{where} = {show(value)}: must be true or false")
        return value
    if spec.kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(f"{where} = {show(value)}: must be an integer")
        _bounds(where, value, spec)
        return value
    if spec.kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(f"{where} = {show(value)}: must be a number")
        try:
            v = float(value)
        except OverflowError:  # a TOML integer beyond the float range
            v = math.inf
        if not math.isfinite(v):
            bounded = spec.low is not None or spec.high is not None
            rng = f" in {key_range(spec)}" if bounded else ""
            raise SceneError(f"{where} = {show(value)}: must be a finite number{rng}")
        _bounds(where, v, spec)
        return v
    if spec.kind == "str":
        if not isinstance(value, str):
            raise SceneError(f"{where} = {show(value)}: must be a string")
        if spec.choices and value not in spec.choices:
            raise SceneError(f"{where} = {show(value)}: must be one of {', '.join(spec.choices)}")
        if len(value) > MAX_STR:
            raise SceneError(f"{where}: {len(value)} characters; at most {MAX_STR}")
        return value
    if spec.kind == "distribution":
        if not (isinstance(value, dict) and len(value) == 1):
            raise SceneError(
                f"{where} = {show(value)}: must be {{ normal = sigma }} or "
                "{ uniform = half width }"
            )
        ((dist, scale),) = value.items()
        if dist not in ("normal", "uniform"):
            raise SceneError(f"{where}: distribution {show(dist)} must be one of normal, uniform")
        inner = Key("float", None, spec.help, low=0.0, low_open=False)
        return Distribution(dist, _coerce(section, key, inner, scale))
    if spec.kind in ("list[list[float]]", "list[str]", "list[float]"):
        if not isinstance(value, list):
            raise SceneError(f"{where} = {show(value)}: must be a list")
        limit = spec.max_len or MAX_LIST
        if len(value) > limit:
            raise SceneError(f"{where} has {len(value)} entries; at most {limit}")
    if spec.kind == "list[list[float]]":
        if not all(isinstance(r, list) and len(r) == 3 for r in value):
            raise SceneError(
                f"{where} = {show(value)}: must be a list of [order, amplitude, phase] rows"
            )
        return [_coerce(section, key, Key("list[float]", None, spec.help), r) for r in value]
    if spec.kind in ("list[str]", "list[float]"):
        inner = Key(
            spec.kind[5:-1],
            None,
            spec.help,
            spec.choices,
            low=spec.low,
            high=spec.high,
            low_open=spec.low_open,
            high_open=spec.high_open,
        )
        out = [_coerce(section, key, inner, v) for v in value]
        if spec.kind == "list[str]" and len(set(out)) != len(out):
            raise SceneError(f"{where} = {show(value)}: lists an entry twice")
        return out
    raise AssertionError(spec.kind)


def _bounds(where: str, v: float, spec: Key) -> None:
    if out_of_range(v, spec.low, spec.high, low_open=spec.low_open, high_open=spec.high_open):
        shown = v if isinstance(v, int) else f"{v:g}"
        raise SceneError(f"{where} = {shown}: allowed range is {key_range(spec)}")


def _check(where: str, v: float, low: float, high: float, **kw: bool) -> None:
    """A range that depends on the design, worded like the static ones."""
    if out_of_range(v, low, high, **kw):
        raise SceneError(f"{where} = {v:g}: allowed range is {range_text(low, high, **kw)}")


def parse_scene(data: dict, name: str = "scene", base_dir: Path | None = None) -> Scene:
    """Validate a scene given as a dictionary (as read from TOML)."""
    if not isinstance(data, dict):
        raise SceneError("a scene must be a table of sections")
    if not data:
        raise SceneError(
            f"the scene {show(name)} is empty; give at least one section ({', '.join(SCHEMA)}); "
            "'corr-cad new FILE' writes a template"
        )
    unknown = [s for s in data if s not in SCHEMA]
    if unknown:
        raise SceneError(
            f"unknown section [{show(unknown[0])[1:-1]}]; valid sections: {', '.join(SCHEMA)}"
        )
    values: dict[str, dict[str, Any]] = {}
    for section, keys in SCHEMA.items():
        given = data.get(section, {})
        if not isinstance(given, dict):
            raise SceneError(f"[{section}] must be a table, got {show(given)}")
        bad = [k for k in given if k not in keys]
        if bad:
            raise SceneError(
                f"unknown key {show(bad[0])} in [{section}]; valid keys: {', '.join(keys)}"
            )
        values[section] = {
            k: (_coerce(section, k, spec, given[k]) if k in given else spec.default)
            for k, spec in keys.items()
        }

    d, m = values["design"], values["material"]
    try:
        material = Material(m["young_modulus"], m["poisson_ratio"])
        design = GearDesign(material=material, **d)
    except CorrCadError as exc:
        key = str(exc).split(" ", 1)[0]
        section = "material" if key in SCHEMA["material"] else "design"
        raise SceneError(f"[{section}] {exc}") from exc
    try:  # an undercut design is refused here, before anything runs (closed form, ms)
        working_profile(design)
    except CorrCadError as exc:
        raise SceneError(f"[design] {exc}") from exc

    ex = values["export"]
    formats = tuple(ex["formats"])
    if not ex["assembly_angles_deg"]:
        raise SceneError("[export] assembly_angles_deg is empty; give at least one crank angle")
    if not formats:
        raise SceneError(f"[export] formats is empty; choose from {', '.join(FORMATS)}")

    ld = values["load"]
    load = None
    if ld["input_torque"] is not None:
        if ld["pinion_torque"] is not None or ld["first_stage_ratio"] is not None:
            raise SceneError(
                "[load] give input_torque, or pinion_torque with first_stage_ratio, not both"
            )
        load = LoadSpec(ld["input_torque"])
    elif ld["pinion_torque"] is not None or ld["first_stage_ratio"] is not None:
        if ld["pinion_torque"] is None or ld["first_stage_ratio"] is None:
            raise SceneError(
                "[load] pinion_torque needs first_stage_ratio (and the other way round)"
            )
        load = LoadSpec(ld["pinion_torque"] * ld["first_stage_ratio"])
    if "forces" in formats and load is None:
        raise SceneError(
            "[export] formats lists 'forces' but [load] gives no torque; "
            "set [load] input_torque (N*mm)"
        )

    sv = values["solver"]
    angles = sv["crank_angles_deg"]
    if angles is not None and not angles:
        raise SceneError("[solver] crank_angles_deg is empty; omit it to solve a full cycle")
    solver = SolverSpec(
        positions=sv["positions"],
        load_share=sv["load_share"],
        crank_angles_deg=tuple(angles) if angles is not None else None,
        variants=tuple(sv["variants"]),
    )

    er = values["errors"]
    per = er["roller_radius_errors"]
    if per is not None and len(per) != design.roller_count:
        raise SceneError(
            f"[errors] roller_radius_errors has {len(per)} values; the design has "
            f"{design.roller_count} rollers (tooth_count + 1)"
        )
    half_r = 0.5 * design.roller_radius
    for key in ("cam_radius_error", "eccentricity_error", "roller_radius_error"):
        # Half the roller radius: the small-displacement model needs errors far smaller.
        _check(_where("errors", key), er[key], -half_r, half_r, high_open=True)
    for v in per or ():
        _check(_where("errors", "roller_radius_errors"), v, -half_r, half_r, high_open=True)
    slots = er["slot_angle_errors_deg"]
    if slots is not None and len(slots) != design.roller_count:
        raise SceneError(
            f"[errors] slot_angle_errors_deg has {len(slots)} values; the design has "
            f"{design.roller_count} slots (tooth_count + 1)"
        )
    quarter_pitch = 90.0 / design.roller_count
    for v in slots or ():
        where = _where("errors", "slot_angle_errors_deg")
        _check(where, v, -quarter_pitch, quarter_pitch, high_open=True)
    for order, amplitude, phase in er["profile_deviation_harmonics"] or ():
        where = _where("errors", "profile_deviation_harmonics")
        if not (order == int(order) and 1 <= order <= 10000):
            raise SceneError(f"{where}: order {order:g} must be an integer in [1, 10000]")
        _check(f"{where} amplitude", amplitude, -half_r, half_r, high_open=True)
        _check(f"{where} phase", phase, -MAX_ANGLE_DEG, MAX_ANGLE_DEG, low_open=False)
    harmonics = er["profile_deviation_harmonics"]
    errors = ErrorSpec(
        er["cam_radius_error"],
        er["eccentricity_error"],
        er["roller_radius_error"],
        tuple(per) if per is not None else None,
        tuple(math.radians(x) for x in slots) if slots is not None else None,
        math.radians(er["cam_phase_error_deg"]),
        harmonic_deviation(harmonics) if harmonics else None,
    )
    checks = Checks(**{k: v for k, v in values["checks"].items()})
    if checks.min_loaded_rollers is not None:
        _check(
            "[checks] min_loaded_rollers",
            checks.min_loaded_rollers,
            0,
            design.roller_count,
            low_open=False,
        )
    tolerances = {k: v for k, v in values["tolerances"].items() if v is not None}
    tol_high = {
        "cam_radius": (half_r, True),
        "eccentricity": (half_r, True),
        "roller_radius": (half_r, True),
        "slot_angle": (quarter_pitch, True),
        "cam_phase": (180.0, False),
    }
    for kind, dist in tolerances.items():
        high, open_ = tol_high[kind]
        _check(_where("tolerances", kind), dist.scale, 0.0, high, low_open=False, high_open=open_)
    needs_load = {"montecarlo", "allocation", "sweeps"} & set(formats) or checks.active()
    if needs_load and load is None:
        raise SceneError(
            "[checks], montecarlo and allocation need a torque: set [load] input_torque"
        )
    if {"montecarlo", "allocation"} & set(formats) and not tolerances:
        raise SceneError(
            "[export] formats asks for montecarlo/allocation but [tolerances] is empty; "
            f"give one of {', '.join(TOLERANCE_KINDS)}"
        )
    mfp = checks.max_failure_probability
    if mfp is not None:
        if mfp < 0:
            raise SceneError(f"[checks] max_failure_probability = {mfp:g}: allowed range is [0, 1]")
        if not checks.active():
            raise SceneError(
                "[checks] max_failure_probability needs at least one limit in [checks]"
            )
        if "montecarlo" not in formats:
            raise SceneError(
                "[checks] max_failure_probability gates the Monte Carlo: "
                "add 'montecarlo' to [export] formats"
            )
    for swept, (where, _, _) in PAPER_SWEEPS.items():
        rng = values["sweeps"][swept]
        if rng is None:
            continue
        if len(rng) != 2 or not rng[0] < rng[1]:
            raise SceneError(f"[sweeps] {swept} = {rng!r}: must be [min, max] with min < max (mm)")
        if where == "design" and rng[0] <= 0:
            raise SceneError(f"[sweeps] {swept} = {rng!r}: allowed range is min > 0 (mm)")
    if "allocation" in formats and not checks.active():
        raise SceneError("allocation needs at least one limit in [checks]")
    _unique_angle_tags(ex["assembly_angles_deg"])
    ip = ex["interference_positions"]
    if ex["interference_method"] != "exact" and ip is not None and ip > MESH_POSITIONS_MAX:
        raise SceneError(
            f"[export] interference_positions = {ip}: allowed range with interference_method "
            f"= {ex['interference_method']!r} is (0, {MESH_POSITIONS_MAX}] (about 0.8 s of mesh "
            'booleans per position); use interference_method = "exact" for finer sweeps'
        )
    if "inspection" in formats and er["measured_profile"] is None:
        raise SceneError(
            "[export] formats lists 'inspection' but [errors] measured_profile is not set"
        )
    spacing = values["inspection"]["point_spacing"]
    if (
        "cmm" in formats
        and 2 * math.pi * (design.link_length + design.roller_radius) / spacing > 2e6
    ):
        raise SceneError(
            f"[inspection] point_spacing = {spacing:g}: more than 2,000,000 points; "
            "allowed range is at least 1e-6 of the circumference"
        )
    scene = Scene(
        name=name,
        design=design,
        formats=formats,
        representation=ex["representation"],
        tolerance=ex["tolerance"],
        chord_tolerance=(
            ex["chord_tolerance"] if ex["chord_tolerance"] is not None else ex["tolerance"]
        ),
        assembly_angles_deg=tuple(ex["assembly_angles_deg"]),
        interference_method=ex["interference_method"],
        interference_positions=ex["interference_positions"],
        load=load,
        solver=solver,
        errors=errors,
        checks=checks,
        measured_profile=(
            (Path(base_dir or ".") / er["measured_profile"])
            if er["measured_profile"] is not None
            else None
        ),
        measured_exaggeration=er["measured_exaggeration"],
        tolerances=tolerances,
        montecarlo=values["montecarlo"],
        sweeps=values["sweeps"],
        edm=values["edm"],
        inspection=values["inspection"],
        source={
            s: {
                k: (v.__dict__ if isinstance(v, Distribution) else v)
                for k, v in vals.items()
                if v is not None
            }
            for s, vals in values.items()
        },
        warnings=no_effect_warnings(data, formats, bool(checks.active())),
    )
    from .resources import check_scene

    check_scene(scene)
    return scene


def _unique_angle_tags(angles: list[float]) -> None:
    """Two assembly angles must not write the same file name."""
    from .pipeline import _angle_tag

    seen: dict[str, float] = {}
    for a in angles:
        tag = _angle_tag(a)
        if tag in seen:
            raise SceneError(
                f"[export] assembly_angles_deg: {seen[tag]:g} and {a:g} both write "
                f"assembly_{tag}.*; angles must differ by at least 0.001 deg"
            )
        seen[tag] = a


#: Which formats make each section, or key, have an effect. ``None`` for a
#: section means "see the keys"; a key not listed follows its section.
_SOLVER_FORMATS = {"forces", "montecarlo", "allocation", "sweeps"}
_MESH = {"stl", "3mf", "glb", "ply"}


def no_effect_warnings(data: dict, formats: tuple[str, ...], checks: bool) -> tuple[str, ...]:
    """One line for each given section or key that does nothing in this scene."""
    f = set(formats)
    forces = "forces" in f or checks  # the checks run the force solver
    mc = bool({"montecarlo", "allocation"} & f)
    solver = forces or bool(_SOLVER_FORMATS & f)
    measured = "measured_profile" in data.get("errors", {})
    out: list[str] = []

    def warn(what: str, why: str) -> None:
        out.append(f"{what} has no effect in this scene: {why}")

    if "montecarlo" in data and not mc:
        warn("[montecarlo]", 'formats lists neither "montecarlo" nor "allocation"')
    elif mc:
        mcd = data.get("montecarlo", {})
        if "samples" in mcd and "montecarlo" not in f:
            warn("[montecarlo] samples", 'formats does not list "montecarlo"')
        for k in ("percentile", "allocation_samples"):
            if k in mcd and "allocation" not in f:
                warn(f"[montecarlo] {k}", 'formats does not list "allocation"')
    if "tolerances" in data and not mc:
        warn("[tolerances]", 'formats lists neither "montecarlo" nor "allocation"')
    if "sweeps" in data and "sweeps" not in f:
        warn("[sweeps]", 'formats does not list "sweeps"')
    if "load" in data and not solver:
        warn("[load]", "no format needs the mesh forces (forces, montecarlo, allocation, sweeps)")
    if "material" in data and not solver:
        warn("[material]", "only the force solver uses it and no format needs it")
    sv = data.get("solver", {})
    if "solver" in data and not solver:
        warn("[solver]", "no format runs the force solver (forces, montecarlo, allocation, sweeps)")
    elif not forces:
        for k in ("positions", "crank_angles_deg", "variants"):
            if k in sv:
                warn(f"[solver] {k}", 'only "forces" and [checks] use it')
    ex = data.get("export", {})
    if "representation" in ex and "dxf" not in f:
        warn("[export] representation", 'formats does not list "dxf"')
    geometry = bool((_MESH | {"step", "interference"}) & f)
    if "tolerance" in ex and "dxf" not in f and ("chord_tolerance" in ex or not geometry):
        warn("[export] tolerance", 'formats lists no "dxf" (and no mesh/STEP takes it over)')
    if "chord_tolerance" in ex and not geometry:
        warn("[export] chord_tolerance", "formats lists no mesh, step or interference")
    if "assembly_angles_deg" in ex and not _MESH & f:
        warn("[export] assembly_angles_deg", "formats lists no mesh (stl, 3mf, glb, ply)")
    if "interference_positions" in ex and "interference" not in f:
        warn("[export] interference_positions", 'formats does not list "interference"')
    if "interference_method" in ex and "interference" not in f:
        warn("[export] interference_method", 'formats does not list "interference"')
    if "edm" in data and "edm" not in f:
        warn("[edm]", 'formats does not list "edm"')
    insp = data.get("inspection", {})
    if "inspection" in data and not {"cmm", "inspection"} & f:
        warn("[inspection]", 'formats lists neither "cmm" nor "inspection"')
    else:
        if "point_spacing" in insp and "cmm" not in f:
            warn("[inspection] point_spacing", 'only "cmm" uses it')
        for k in insp:
            if k != "point_spacing" and "inspection" not in f:
                warn(f"[inspection] {k}", 'formats does not list "inspection"')
    er = data.get("errors", {})
    if "measured_exaggeration" in er and not (measured and "dxf" in f):
        warn("[errors] measured_exaggeration", 'it scales measured_profile.dxf (needs "dxf")')
    physical = [k for k in er if k not in ("measured_profile", "measured_exaggeration")]
    # The exact clearance takes every error kind, the mesh sweep only roller radii.
    exact = "interference" in f and ex.get("interference_method", "exact") != "mesh"
    roller_only = "interference" in f
    for k in physical:  # the sweeps vary the nominal design: they ignore [errors]
        if not (
            forces
            or mc
            or exact
            or (roller_only and k in ("roller_radius_error", "roller_radius_errors"))
        ):
            warn(f"[errors] {k}", "only forces, checks, montecarlo, allocation, interference")
    return tuple(out)


def _nesting_depth(text: str) -> int:
    """Deepest nesting of ``[`` and ``{`` outside strings and comments (a cheap pre-check)."""
    if text.count("[") + text.count("{") <= MAX_NESTING:
        return 0
    depth = deepest = 0
    quote = ""
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if quote:
            if c == "\\" and quote == '"':
                i += 1
            elif c == quote:
                quote = ""
        elif c in "\"'":
            quote = c
        elif c == "#":
            j = text.find("\n", i)
            i = n if j < 0 else j
            continue
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth = max(0, depth - 1)
        i += 1
    return deepest


def load_scene(path: str | Path) -> Scene:
    """Read and validate a TOML scene file.

    >>> import tempfile, pathlib
    >>> from corr_cad import load_scene
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "mine.toml"
    >>> text = "[design]\\ntooth_count = 39\\neccentricity = 2.0\\nroller_radius = 6.0\\n"
    >>> _ = path.write_text(text)
    >>> scene = load_scene(path)
    >>> scene.name, scene.design.roller_count, scene.formats
    ('mine', 40, ('dxf', 'png'))
    """
    path = Path(path)
    raw = read_regular_file(path, "scene file", MAX_SCENE_BYTES)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SceneError(f"scene file {show(str(path), 120)} is not UTF-8 text ({exc})") from exc
    if not text.strip():
        raise SceneError(
            f"scene file {show(str(path), 120)} is empty; 'corr-cad new FILE' writes a template"
        )
    depth = _nesting_depth(text)
    if depth > MAX_NESTING:
        raise SceneError(
            f"{show(path.name, 120)}: arrays or tables nested {depth} deep; at most {MAX_NESTING}"
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{show(path.name, 120)}: not valid TOML ({exc})") from exc
    except RecursionError as exc:
        raise SceneError(
            f"{show(path.name, 120)}: arrays or tables nested too deep; at most {MAX_NESTING}"
        ) from exc
    return parse_scene(data, name=path.stem, base_dir=path.parent)


def bounds_table() -> str:
    """The README's table of every scene key's allowed range (from :data:`SCHEMA`)."""
    rows = ["| key | type | allowed | also, against the design |", "| --- | --- | --- | --- |"]
    for section, keys in SCHEMA.items():
        for k, spec in keys.items():
            if spec.kind in ("int", "float"):
                allowed = "finite" if spec.low is None and spec.high is None else key_range(spec)
            elif spec.kind == "bool":
                allowed = "true, false"
            elif spec.kind == "str":
                allowed = (
                    ", ".join(spec.choices) if spec.choices else f"a path, <= {MAX_STR} characters"
                )
            elif spec.kind == "distribution":
                allowed = "{ normal = sigma } or { uniform = half width }, scale >= 0"
            elif spec.kind == "list[str]":
                allowed = f"each of {', '.join(spec.choices or ())}, once"
            else:
                item = key_range(spec) if spec.low is not None else "finite numbers"
                if spec.kind == "list[list[float]]":
                    item = "rows [order, amplitude, phase]"
                n = "z + 1" if spec.max_len is None and "per-" in spec.help else None
                allowed = f"{item}; {n or f'1 to {spec.max_len or MAX_LIST}'} entries"
            rows.append(f"| `[{section}] {k}` | {spec.kind} | {allowed} | {spec.note} |")
    return "\n".join(rows) + "\n"


def _toml_value(v: Any) -> str:
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, float):
        return repr(v)
    return str(v)


def template_text() -> str:
    """A commented scene with every section and key (optional ones commented out).

    Sections and keys that would have no effect with the template's own
    formats are written commented out too, so that a fresh scene runs without
    a single "has no effect" warning; uncomment them with the format they need.
    """
    quiet: set[str] = set()
    for _ in range(2):  # pass 1 finds what would warn, pass 2 writes it commented
        lines = [
            "# corr_cad scene. Units: mm, N, N*mm, MPa; angles in degrees.",
            "# Run it with:  corr-cad run THIS_FILE --out outputs/NAME",
            "# Commented sections and keys take effect with the formats they name.",
            "",
        ]
        for section, keys in SCHEMA.items():
            off = f"[{section}]" in quiet
            lines.append(f"{'# ' if off else ''}[{section}]")
            for k, spec in keys.items():
                choices = f" (one of: {', '.join(spec.choices)})" if spec.choices else ""
                lines.append(f"# {spec.help}{choices}")
                commented = (
                    off
                    or f"[{section}] {k}" in quiet
                    or spec.default is None
                    or section == "errors"
                    or (section == "solver" and k == "variants")
                )
                value = spec.example if spec.default is None else spec.default
                lines.append(f"{'# ' if commented else ''}{k} = {_toml_value(value)}")
            lines.append("")
        data = tomllib.loads("\n".join(lines))
        formats = tuple(data.get("export", {}).get("formats", SCHEMA["export"]["formats"].default))
        found = {w.split(" has no effect")[0] for w in no_effect_warnings(data, formats, False)}
        if not found - quiet:
            break
        quiet |= found
    return "\n".join(lines)
