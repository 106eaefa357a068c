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

from .design import GearDesign, Material
from .deviations import ManufacturingErrors as ErrorSpec
from .deviations import harmonic_deviation
from .errors import CorrCadError, SceneError
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
    "report",
)


@dataclass(frozen=True)
class Key:
    kind: str  # "int", "float", "bool", "str", "list[str]", "list[float]"
    default: Any
    help: str
    choices: tuple[str, ...] | None = None
    low: float | None = None  # exclusive lower bound for numbers
    high: float | None = None  # inclusive upper bound
    example: Any = None


SCHEMA: dict[str, dict[str, Key]] = {
    "design": {
        "tooth_count": Key("int", 25, "z, teeth of the fixed inner gear (z + 1 rollers)", low=2),
        "cam_radius": Key("float", 135.0, "Rj, disk cam radius, mm", low=0),
        "roller_radius": Key("float", 8.0, "r, roller radius, mm", low=0),
        "roller_length": Key("float", 12.0, "roller contact length, mm", low=0),
        "eccentricity": Key("float", 3.5, "e, cam eccentricity, mm", low=0),
        "ring_outer_radius": Key(
            "float",
            None,
            "gear ring outer radius, mm (default: rim of max(10, 3r))",
            low=0,
            example=180.0,
        ),
        "face_width": Key(
            "float",
            None,
            "gear ring / cam face width, mm (default: roller_length)",
            low=0,
            example=12.0,
        ),
        "cam_bore_radius": Key(
            "float",
            None,
            "cam eccentric bore radius, mm (default: min(0.35 Rj, (Rj - e)/2))",
            low=0,
            example=47.2,
        ),
        "frame_inner_radius": Key(
            "float", None, "slotted frame plate inner radius, mm", low=0, example=122.5
        ),
        "frame_outer_radius": Key(
            "float", None, "slotted frame plate outer radius, mm", low=0, example=163.5
        ),
        "frame_thickness": Key(
            "float", None, "thickness of each slotted frame plate, mm", low=0, example=8.0
        ),
        "allow_undercut": Key(
            "bool", False, "accept an undercut design; the profile is then the swept boundary"
        ),
    },
    "material": {
        "young_modulus": Key("float", 2.06e5, "E, MPa", low=0),
        "poisson_ratio": Key("float", 0.3, "Poisson's ratio", low=-1, high=0.5),
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
            example=0.001,
        ),
        "assembly_angles_deg": Key(
            "list[float]", [0.0], "crank angles of the assembly meshes, deg (relative to the frame)"
        ),
        "interference_positions": Key(
            "int", 36, "crank positions of the interference sweep (full cycle)", low=0, high=100000
        ),
        "tolerance": Key(
            "float", 0.001, "max deviation of exported geometry from the exact curve, mm", low=0
        ),
    },
    "load": {
        "input_torque": Key("float", None, "M0, torque on the crankshaft, N*mm", example=1.0e6),
        "pinion_torque": Key(
            "float", None, "input pinion torque, N*mm (with first_stage_ratio)", example=1.0e5
        ),
        "first_stage_ratio": Key(
            "float", None, "first-stage ratio: M0 = pinion_torque * ratio", low=0, example=10.0
        ),
    },
    "solver": {
        "positions": Key("int", 3600, "crank positions per cycle", low=0, high=10_000_000),
        "load_share": Key("float", 0.55, "share of M0 carried by one cam (Eq. 8)", low=0, high=1),
        "crank_angles_deg": Key(
            "list[float]", None, "solve only at these crank angles, deg", example=[0.0, 5.0, 10.0]
        ),
        "variants": Key("list[str]", [], "printed-paper variants to switch on", choices=VARIANTS),
    },
    "errors": {
        "cam_radius_error": Key("float", 0.0, "cam radius error dRj, mm (+ = oversize)"),
        "eccentricity_error": Key("float", 0.0, "eccentricity (installation) error de, mm"),
        "roller_radius_error": Key("float", 0.0, "roller radius error dr for every roller, mm"),
        "roller_radius_errors": Key(
            "list[float]", None, "per-roller radius errors, z + 1 values, mm", example=[0.0]
        ),
        "slot_angle_errors_deg": Key(
            "list[float]",
            None,
            "per-slot angular position errors, z + 1 values, deg",
            example=[0.0],
        ),
        "cam_phase_error_deg": Key("float", 0.0, "cam phase error against the other cam, deg"),
        "measured_profile": Key(
            "str",
            None,
            "measured gear profile: CSV x,y (mm) or DXF, path relative to the scene",
            example="measured.csv",
        ),
        "measured_exaggeration": Key(
            "float", 200.0, "deviation scale of the picture in measured_profile.dxf", low=0
        ),
        "profile_deviation_harmonics": Key(
            "list[list[float]]",
            None,
            "gear profile deviation: rows [order, amplitude mm, phase deg] (+ = material added)",
            example=[[3.0, 0.002, 0.0]],
        ),
    },
    "checks": {
        "max_contact_pressure": Key(
            "float", None, "allowable Hertz pressure, MPa", low=0, example=1500.0
        ),
        "max_gear_force": Key(
            "float", None, "allowable peak gear force F_n, N", low=0, example=5000.0
        ),
        "min_loaded_rollers": Key(
            "int", None, "fewest rollers that must carry load", low=-1, example=4
        ),
        "max_lost_motion_arcmin": Key(
            "float", None, "allowable output lost motion, arcmin", example=1.0
        ),
    },
    "tolerances": {
        kind: Key(
            "distribution",
            None,
            f"{kind.replace('_', ' ')} tolerance, {unit}: "
            "{ normal = sigma } or { uniform = half width }",
            example={"normal": 0.001 if unit == "mm" else 0.01},
        )
        for kind, (_, unit) in TOLERANCE_KINDS.items()
    },
    "montecarlo": {
        "samples": Key("int", 1000, "Monte Carlo samples", low=0, high=10_000_000),
        "seed": Key("int", 1, "random seed (runs are reproducible)", low=-1),
        "positions": Key(
            "int", 360, "crank positions per sample (full cycle)", low=0, high=100_000
        ),
        "percentile": Key(
            "float", 95.0, "percentile the allocation keeps under the limits", low=0, high=100
        ),
        "allocation_samples": Key("int", 200, "samples per step of the allocation search", low=0),
    },
    "sweeps": {
        "points": Key("int", 7, "points per sweep", low=1, high=1000),
        "positions": Key("int", 720, "crank positions per sweep point", low=0, high=1_000_000),
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
            )
            for name, (where, lo, hi) in PAPER_SWEEPS.items()
        },
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
    interference_positions: int = 36
    load: LoadSpec | None = None
    solver: SolverSpec = field(default_factory=SolverSpec)
    errors: ErrorSpec = field(default_factory=ErrorSpec)
    checks: Checks = field(default_factory=Checks)
    measured_profile: Path | None = None
    measured_exaggeration: float = 200.0
    tolerances: dict = field(default_factory=dict)
    montecarlo: dict = field(default_factory=dict)
    sweeps: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)


def _where(section: str, key: str) -> str:
    return f"[{section}] {key}"


def _coerce(section: str, key: str, spec: Key, value: Any) -> Any:
    where = _where(section, key)
    if spec.kind == "bool":
        if not isinstance(value, bool):
            raise SceneError(f"{where} = {value!r}: must be true or false")
        return value
    if spec.kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(f"{where} = {value!r}: must be an integer")
        _bounds(where, value, spec)
        return value
    if spec.kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(f"{where} = {value!r}: must be a number")
        v = float(value)
        if not math.isfinite(v):
            raise SceneError(f"{where} = {value!r}: must be a finite number")
        _bounds(where, v, spec)
        return v
    if spec.kind == "str":
        if not isinstance(value, str):
            raise SceneError(f"{where} = {value!r}: must be a string")
        if spec.choices and value not in spec.choices:
            raise SceneError(f"{where} = {value!r}: must be one of {', '.join(spec.choices)}")
        return value
    if spec.kind == "distribution":
        if not (isinstance(value, dict) and len(value) == 1):
            raise SceneError(
                f"{where} = {value!r}: must be {{ normal = sigma }} or {{ uniform = half width }}"
            )
        ((dist, scale),) = value.items()
        if dist not in ("normal", "uniform"):
            raise SceneError(f"{where}: distribution {dist!r} must be one of normal, uniform")
        v = _coerce(section, key, Key("float", None, spec.help), scale)
        if v < 0:
            raise SceneError(f"{where} = {v:g}: allowed range is [0, inf)")
        return Distribution(dist, v)
    if spec.kind == "list[list[float]]":
        if not isinstance(value, list) or not all(
            isinstance(r, list) and len(r) == 3 for r in value
        ):
            raise SceneError(
                f"{where} = {value!r}: must be a list of [order, amplitude, phase] rows"
            )
        return [_coerce(section, key, Key("list[float]", None, spec.help), r) for r in value]
    if spec.kind in ("list[str]", "list[float]"):
        if not isinstance(value, list):
            raise SceneError(f"{where} = {value!r}: must be a list")
        inner = Key(spec.kind[5:-1], None, spec.help, spec.choices)
        out = [_coerce(section, key, inner, v) for v in value]
        if spec.kind == "list[str]" and len(set(out)) != len(out):
            raise SceneError(f"{where} = {value!r}: lists an entry twice")
        return out
    raise AssertionError(spec.kind)


def _bounds(where: str, v: float, spec: Key) -> None:
    lo, hi = spec.low, spec.high
    if (lo is not None and v <= lo) or (hi is not None and v > hi):
        rng = f"({'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}]"
        raise SceneError(f"{where} = {v:g}: allowed range is {rng}")


def parse_scene(data: dict, name: str = "scene", base_dir: Path | None = None) -> Scene:
    """Validate a scene given as a dictionary (as read from TOML)."""
    if not isinstance(data, dict):
        raise SceneError("a scene must be a table of sections")
    unknown = [s for s in data if s not in SCHEMA]
    if unknown:
        raise SceneError(f"unknown section [{unknown[0]}]; valid sections: {', '.join(SCHEMA)}")
    values: dict[str, dict[str, Any]] = {}
    for section, keys in SCHEMA.items():
        given = data.get(section, {})
        if not isinstance(given, dict):
            raise SceneError(f"[{section}] must be a table, got {given!r}")
        bad = [k for k in given if k not in keys]
        if bad:
            raise SceneError(
                f"unknown key {bad[0]!r} in [{section}]; valid keys: {', '.join(keys)}"
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
    for key in ("cam_radius_error", "eccentricity_error", "roller_radius_error"):
        limit = 0.5 * design.roller_radius
        if abs(er[key]) >= limit:
            raise SceneError(
                f"[errors] {key} = {er[key]:g}: allowed range is (-{limit:g}, {limit:g}) mm "
                "(half the roller radius; the small-displacement model needs errors far smaller)"
            )
    slots = er["slot_angle_errors_deg"]
    if slots is not None and len(slots) != design.roller_count:
        raise SceneError(
            f"[errors] slot_angle_errors_deg has {len(slots)} values; the design has "
            f"{design.roller_count} slots (tooth_count + 1)"
        )
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
    tolerances = {k: v for k, v in values["tolerances"].items() if v is not None}
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
    return Scene(
        name=name,
        design=design,
        formats=formats,
        representation=ex["representation"],
        tolerance=ex["tolerance"],
        chord_tolerance=(
            ex["chord_tolerance"] if ex["chord_tolerance"] is not None else ex["tolerance"]
        ),
        assembly_angles_deg=tuple(ex["assembly_angles_deg"]),
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
        source={
            s: {
                k: (v.__dict__ if isinstance(v, Distribution) else v)
                for k, v in vals.items()
                if v is not None
            }
            for s, vals in values.items()
        },
    )


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
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as exc:
        raise SceneError(f"scene file {str(path)!r} does not exist") from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"scene file {str(path)!r} cannot be read: {exc}") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path.name}: not valid TOML ({exc})") from exc
    return parse_scene(data, name=path.stem, base_dir=path.parent)


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
    """A commented scene with every section and key (optional ones commented out)."""
    lines = [
        "# corr_cad scene. Units: mm, N, N*mm, MPa; angles in degrees.",
        "# Run it with:  corr-cad run THIS_FILE --out outputs/NAME",
        "",
    ]
    for section, keys in SCHEMA.items():
        lines.append(f"[{section}]")
        for k, spec in keys.items():
            choices = f" (one of: {', '.join(spec.choices)})" if spec.choices else ""
            lines.append(f"# {spec.help}{choices}")
            if spec.default is None:
                lines.append(f"# {k} = {_toml_value(spec.example)}")
            elif section in ("errors",) or (section == "solver" and k == "variants"):
                lines.append(f"# {k} = {_toml_value(spec.default)}")
            else:
                lines.append(f"{k} = {_toml_value(spec.default)}")
        lines.append("")
    return "\n".join(lines)
