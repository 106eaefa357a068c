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

from corr_cad.bounds import out_of_range, range_text, show
from corr_cad.errors import CorrCadError, SceneError
from corr_cad.export.gcode import check_edm_scene
from corr_cad.export.inputfiles import read_regular_file
from corr_cad.geometry.design import GearDesign, Material
from corr_cad.geometry.deviations import ManufacturingErrors as ErrorSpec
from corr_cad.geometry.deviations import harmonic_deviation
from corr_cad.geometry.profile import working_profile
from corr_cad.mechanics.datasheet import MIN_SHARE
from corr_cad.mechanics.row.solver import VARIANTS
from corr_cad.run.scene import scene_drive as drv
from corr_cad.run.scene import scene_schema_lubrication as lub
from corr_cad.run.scene.limits import unique_angle_tags
from corr_cad.run.scene.scene_crank import parse_crank
from corr_cad.run.scene.scene_drive import SolverSpec
from corr_cad.run.scene.scene_first_stage import (
    first_stage_load,
    parse_first_stage,
    small_torque_refusal,
)
from corr_cad.run.scene.scene_hints import design_refusal, did_you_mean, every_format, long_number
from corr_cad.run.scene.scene_key import nesting_depth
from corr_cad.run.scene.scene_modification import acts, parse_modification, split_design_table
from corr_cad.run.scene.scene_montecarlo import check_binding_gate
from corr_cad.run.scene.scene_schema import (  # noqa: F401  (re-exported: the schema is part of this interface)
    ALL,
    FORMATS,
    INTERFERENCE_METHODS,
    MAX_ANGLE_DEG,
    MAX_LIST,
    MAX_NESTING,
    MAX_SCENE_BYTES,
    MAX_STR,
    MESH_POSITIONS_MAX,
    SCHEMA,
    Key,
    key_range,
)
from corr_cad.run.scene.scene_schema_friction import friction_sections
from corr_cad.run.scene.scene_schema_sizing import parse_sizing, split_sizing_tables
from corr_cad.run.scene.scene_suggest import verified_examples
from corr_cad.run.scene.scene_text import (  # noqa: F401
    bounds_table,
    no_effect_warnings,
    renamed_key_warnings,
    template_text,
)
from corr_cad.tolerance.checks import Checks
from corr_cad.tolerance.montecarlo import TOLERANCE_KINDS, Distribution
from corr_cad.tolerance.sweeps import PAPER_SWEEPS

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


@dataclass(frozen=True)
class LoadSpec:
    """Crankshaft input moment M0, N*mm."""

    input_torque: float


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
    #: ``[errors.row_b]`` under ``model = "drive"`` (None: ``[errors]`` is both rows').
    errors_b: ErrorSpec | None = None
    #: ``[bearings.eccentric]`` and cam B's (None: the cams are fixed).
    bearing: Any = None
    bearing_b: Any = None
    crank: Any = None  # [crankshaft] / [bearings.crank] (None: the eccentrics rigid)
    checks: Checks = field(default_factory=Checks)
    measured_profile: Path | None = None
    #: ``[errors.row_b] measured_profile``: ring B's measured contour (drive only).
    measured_profile_b: Path | None = None
    measured_exaggeration: float = 200.0
    tolerances: dict = field(default_factory=dict)
    montecarlo: dict = field(default_factory=dict)
    sweeps: dict = field(default_factory=dict)
    edm: dict = field(default_factory=dict)
    inspection: dict = field(default_factory=dict)
    #: ``[datasheet]`` with its defaults (``rated_torque_Nm`` None: from ``[load]``).
    datasheet: dict = field(default_factory=dict)
    #: ``[friction]`` and ``[life]`` with their defaults, empty unless the scene
    #: gives the section (either one makes the datasheet compute efficiency and life).
    friction: dict = field(default_factory=dict)
    life: dict = field(default_factory=dict)
    #: ``lubrication``, ``thermal``, ``thermal_test``: those sections (empty: not given).
    losses: dict = field(default_factory=dict)
    modification: Any = None  # [modification]; None: the conjugate profile
    assembly: dict = field(default_factory=dict)
    modification_design: dict = field(default_factory=dict)
    #: ``[first_stage]``: :class:`~corr_cad.geometry.first_stage.FirstStageGeometry` or None.
    first_stage: Any = None
    #: ``[sizing]`` with its requirements, variables' levels and the scene it varies ({}: none).
    sizing: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)
    #: ``[budget]``: memory_gb, output_gb, time_warning_s (None: the defaults).
    budget: dict = field(default_factory=dict)
    #: ``[dask]``: connect, no-workers and stall time-outs in s (None: the defaults).
    dask: dict = field(default_factory=dict)
    #: One line per section or key that has no effect in this scene.
    warnings: tuple[str, ...] = ()
    #: ``formats = ["all"]``: the formats it left out, each with the reason.
    formats_left_out: tuple[tuple[str, str], ...] = ()


def _where(section: str, key: str) -> str:
    return f"[{section}] {key}"


def _coerce(section: str, key: str, spec: Key, value: Any) -> Any:
    where = _where(section, key)
    if spec.kind == "bool":
        if not isinstance(value, bool):
            raise SceneError(f"{where} = {show(value)}: must be true or false")
        return value
    if spec.kind == "int":
        if isinstance(value, float) and value.is_integer() and abs(value) <= 2**53:
            value = int(value)  # 25.0 is the whole number 25
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(f"{where} = {show(value)}: must be an integer, e.g. {spec.works()}")
        _bounds(where, value, spec)
        return value
    if spec.kind == "float":
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(f"{where} = {show(value)}: must be a number{spec.hint()}")
        try:
            v = float(value)
        except OverflowError:  # a TOML integer beyond the float range
            v = math.inf
        if not math.isfinite(v):
            bounded = spec.low is not None or spec.high is not None
            rng = f" in {key_range(spec)}" if bounded else ""
            raise SceneError(f"{where} = {show(value)}: must be a finite number{rng}{spec.hint()}")
        _bounds(where, v, spec)
        return v
    if spec.kind == "str":
        if not isinstance(value, str):
            raise SceneError(f"{where} = {show(value)}: must be a string{spec.hint()}")
        if spec.choices and value not in spec.choices:
            raise SceneError(
                f"{where} = {show(value)}: must be one of {', '.join(spec.choices)}{spec.hint()}"
            )
        if len(value) > MAX_STR:
            raise SceneError(f"{where}: {len(value)} characters; at most {MAX_STR}")
        if "\0" in value:  # os.stat would raise ValueError on the path
            raise SceneError(f'{where} = {show(value)}: a NUL character; e.g. "measured.csv"')
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
        shown = v if isinstance(v, int) and abs(v) < 10**15 else f"{v:g}"
        works = spec.works()
        hint = f", e.g. {works}" if works is not None else ""
        raise SceneError(f"{where} = {shown}: allowed range is {key_range(spec)}{hint}")


def _check(where: str, v: float, low: float, high: float, **kw: bool) -> None:
    """A range that depends on the design, worded like the static ones."""
    if out_of_range(v, low, high, **kw):
        tries = (0.0, (low + high) / 2)
        works = next((w for w in tries if not out_of_range(w, low, high, **kw)), None)
        hint = f", e.g. {works:g}" if works is not None and math.isfinite(works) else ""
        raise SceneError(f"{where} = {v:g}: allowed range is {range_text(low, high, **kw)}{hint}")


@verified_examples
def parse_scene(data: dict, name: str = "scene", base_dir: Path | None = None) -> Scene:
    """Validate a scene given as a dictionary (as read from TOML)."""
    if not isinstance(data, dict):
        raise SceneError("a scene must be a table of sections")
    if not data:
        raise SceneError(
            f"the scene {show(name)} is empty; give at least one section ({', '.join(SCHEMA)}); "
            "'corr-cad new FILE' writes a template"
        )
    data = split_sizing_tables(
        lub.split_thermal_test(drv.split_drive_tables(split_design_table(data)))
    )
    unknown = [s for s in data if s not in SCHEMA]
    if unknown:
        raise SceneError(
            f"unknown section [{show(unknown[0])[1:-1]}]{did_you_mean(unknown[0], SCHEMA)}; "
            f"valid sections: {', '.join(SCHEMA)}"
        )
    values: dict[str, dict[str, Any]] = {}
    for section, keys in SCHEMA.items():
        given = data.get(section, {})
        if not isinstance(given, dict):
            raise SceneError(f"[{section}] must be a table, got {show(given)}")
        bad = [k for k in given if k not in keys]
        if bad:
            raise SceneError(
                f"unknown key {show(bad[0])} in [{section}]{did_you_mean(bad[0], keys)}; "
                f"valid keys: {', '.join(keys)}"
            )
        values[section] = {
            k: (_coerce(section, k, spec, given[k]) if k in given else spec.default)
            for k, spec in keys.items()
        }

    d = {k: v for k, v in values["design"].items() if k != "slot_clearance"}
    m = values["material"]
    try:
        material = Material(m["young_modulus"], m["poisson_ratio"])
        design = GearDesign(material=material, **d)
    except CorrCadError as exc:
        key = str(exc).split(" ", 1)[0]
        if key in SCHEMA["material"]:
            raise SceneError(f"[material] {exc}") from exc
        raise SceneError(design_refusal(str(exc), key, d, data.get("design", {}))) from exc
    try:  # an undercut design is refused here, before anything runs (closed form, ms)
        working_profile(design)
    except CorrCadError as exc:
        key = str(exc).split(" ", 1)[0]
        raise SceneError(design_refusal(str(exc), key, d, data.get("design", {}))) from exc

    ex = values["export"]
    formats = tuple(ex["formats"])
    if not ex["assembly_angles_deg"]:
        raise SceneError("[export] assembly_angles_deg is empty; give at least one crank angle")
    if not formats:
        raise SceneError(f"[export] formats is empty; choose from {', '.join(FORMATS)}")
    left_out: tuple[tuple[str, str], ...] = ()
    if ALL in formats:
        if len(formats) > 1:
            raise SceneError(f'[export] formats = {show(list(formats))}: "all" stands alone')
        formats, left_out = every_format(values, data)

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
    first_stage = parse_first_stage(values, data)
    load = first_stage_load(values, load, first_stage, LoadSpec)
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
        model=sv["model"],
        contact_law=sv["contact_law"],
        bodies=sv["bodies"],
    )
    drive = drv.parse_drive(values, data, design)
    crank = parse_crank(values, data, design, drive["bearing"], formats)

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
    drv.check_harmonic_sum(_where("errors", "profile_deviation_harmonics"), harmonics, half_r)
    errors = ErrorSpec(
        er["cam_radius_error"],
        er["eccentricity_error"],
        er["roller_radius_error"],
        tuple(per) if per is not None else None,
        tuple(math.radians(x) for x in slots) if slots is not None else None,
        math.radians(er["cam_phase_error_deg"]),
        harmonic_deviation(harmonics) if harmonics else None,
    )
    errors = drv.with_slot_fit(errors, values["design"]["slot_clearance"], solver.model)
    checks = Checks(**{k: v for k, v in values["checks"].items()})
    if checks.min_loaded_rollers is not None:
        _check(
            "[checks] min_loaded_rollers",
            checks.min_loaded_rollers,
            0,
            design.roller_count,
            low_open=False,
        )
    _check_datasheet(values["datasheet"], checks, formats, load, values["load"])
    sheet = "datasheet" in formats or bool(checks.datasheet_active()) or "datasheet" in data
    tolerances = {k: v for k, v in values["tolerances"].items() if v is not None}
    tol_high = {
        "cam_radius": (half_r, True),
        "eccentricity": (half_r, True),
        "roller_radius": (half_r, True),
        "slot_angle": (quarter_pitch, True),
        "cam_phase": (180.0, False),
        "slot_clearance": (1.0, False),
    }
    drv.check_drive_tolerances(tolerances, formats, solver, checks, data)
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
    check_binding_gate(checks, formats)
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
    if "allocation" in formats and not checks.montecarlo_active():
        raise SceneError(
            f"allocation needs a limit the Monte Carlo computes in [checks]; "
            f"{', '.join(checks.datasheet_active())} is judged on the nominal design only "
            "(e.g. add max_backlash_arcmin or max_contact_pressure)"
        )
    unique_angle_tags(ex["assembly_angles_deg"])
    ip = ex["interference_positions"]
    if ex["interference_method"] != "exact" and ip is not None and ip > MESH_POSITIONS_MAX:
        raise SceneError(
            f"[export] interference_positions = {ip}: allowed range with interference_method "
            f"= {ex['interference_method']!r} is (0, {MESH_POSITIONS_MAX}] (about 0.8 s of mesh "
            'booleans per position); use interference_method = "exact" for finer sweeps'
        )
    drv.check_inspection_row(
        values["inspection"]["row"], formats, er["measured_profile"], drive, solver.model
    )
    if "edm" in formats:  # the dialect against tolerance, design size and its M-codes
        check_edm_scene(values["edm"], ex["tolerance"], design)
    spacing = values["inspection"]["point_spacing"]
    if (
        "cmm" in formats
        and 2 * math.pi * (design.link_length + design.roller_radius) / spacing > 2e6
    ):
        raise SceneError(
            f"[inspection] point_spacing = {spacing:g}: more than 2,000,000 points; "
            "allowed range is at least 1e-6 of the circumference"
        )
    modification, assembly, search = parse_modification(
        values, data, design, base_dir, load, formats
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
        errors_b=drive["errors_b"],
        bearing=drive["bearing"],
        bearing_b=drive["bearing_b"],
        crank=crank,
        checks=checks,
        measured_profile=(
            (Path(base_dir or ".") / er["measured_profile"])
            if er["measured_profile"] is not None
            else None
        ),
        measured_profile_b=(
            (Path(base_dir or ".") / drive["measured_profile_b"])
            if drive["measured_profile_b"] is not None
            else None
        ),
        measured_exaggeration=er["measured_exaggeration"],
        tolerances=tolerances,
        montecarlo=values["montecarlo"],
        sweeps=values["sweeps"],
        edm=values["edm"],
        inspection=values["inspection"],
        datasheet=values["datasheet"],
        **friction_sections(values, data, checks),
        losses=lub.lubrication_sections(values, data),
        modification=modification,
        assembly=assembly,
        modification_design=search,
        first_stage=first_stage,
        sizing=parse_sizing(values, data, formats, first_stage, drive["bearing"]),
        budget=values["budget"],
        dask=values["dask"],
        source={
            s: {
                k: (v.__dict__ if isinstance(v, Distribution) else v)
                for k, v in vals.items()
                if v is not None and drv.recorded(s, k, data)
            }
            for s, vals in values.items()
            # [datasheet] is recorded where it is used or given, [modification] and
            # [assembly] where they act (the inputs of scenes without them stay as they were).
            if (s != "datasheet" or sheet)
            and acts(s, modification, assembly, search)
            and drv.recorded(s, "", data)
        },
        warnings=no_effect_warnings(data, formats, bool(checks.active()))
        + renamed_key_warnings(data),
        formats_left_out=left_out,
    )
    from corr_cad.run.scene.limits import check_structure

    # The structural limits here; the budget (memory, files, time) where the
    # run starts, with the command line's overrides and worker count
    # (corr_cad.run.budget.resources.check_scene).
    check_structure(scene)
    return scene


def _check_datasheet(ds: dict, checks: Checks, formats: tuple, load, ld: dict) -> None:
    """``[datasheet]`` against the rest of the scene, when the datasheet or its checks run."""
    if not ("datasheet" in formats or checks.datasheet_active()):
        return
    rng = ds["rigidity_range"]
    if len(rng) != 2 or not rng[0] < rng[1] or rng[1] - rng[0] < MIN_SHARE:
        raise SceneError(  # a narrower range divides by round-off: the rigidity would be inf
            f"[datasheet] rigidity_range = {rng!r}: must be [T_1, T_2] with "
            f"0 <= T_1 < T_2 <= 1 (shares of T_R), T_2 - T_1 >= {MIN_SHARE:g}, e.g. [0.5, 1.0]"
        )
    if ds["rated_torque_Nm"] is None and load is None:
        why = (
            "formats lists 'datasheet'"
            if "datasheet" in formats
            else (f"[checks] {next(iter(checks.datasheet_active()))} needs the datasheet")
        )
        raise SceneError(
            f"[datasheet] rated_torque_Nm is not set and [load] gives no torque ({why}); "
            "set rated_torque_Nm (N*m, e.g. 2860) or [load] input_torque (N*mm)"
        )
    if ds["rated_torque_Nm"] is None and load is not None and abs(load.input_torque) < 1.0:
        # (z + 1) * 1 N*mm is the smallest rated torque (MIN_RATED_TORQUE_NMM)
        raise SceneError(small_torque_refusal(ld, load.input_torque))


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
    depth = nesting_depth(text)
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
    except ValueError as exc:  # an integer beyond Python's 4300 digits
        raise SceneError(long_number(text, show(path.name, 120))) from exc
    return parse_scene(data, name=path.stem, base_dir=path.parent)
