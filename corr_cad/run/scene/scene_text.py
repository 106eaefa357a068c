"""Scene text: the no-effect warnings, the README's bounds table and the template.

All three are generated from :data:`corr_cad.run.scene.scene_schema.SCHEMA`.
"""

from __future__ import annotations

import tomllib
from typing import Any

from corr_cad.run.scene.scene_schema import MAX_LIST, MAX_STR, SCHEMA, key_range
from corr_cad.run.scene.scene_schema_drive import SECTIONS as DRIVE_SECTIONS

#: Which formats make each section, or key, have an effect. ``None`` for a
#: section means "see the keys"; a key not listed follows its section.
_SOLVER_FORMATS = {"forces", "datasheet", "montecarlo", "allocation", "sweeps", "modification"}
#: ``[checks]`` keys judged on the datasheet's windup (they run the datasheet).
_DATASHEET_CHECKS = (
    "max_lost_motion_arcmin",
    "min_torsional_rigidity_Nm_per_arcmin",
    "max_transmission_error_arcsec",
    "min_efficiency",
    "min_life_h",
)
_MESH = {"stl", "3mf", "glb", "ply"}


def no_effect_warnings(data: dict, formats: tuple[str, ...], checks: bool) -> tuple[str, ...]:
    """One line for each given section or key that does nothing in this scene."""
    f = set(formats)
    if "sizing" in f:  # each candidate is a datasheet and forces run of a scene like this
        f |= {"datasheet", "forces"}
    forces = "forces" in f or checks  # the checks run the force solver
    sheet = "datasheet" in f or bool(set(_DATASHEET_CHECKS) & set(data.get("checks", {})))
    mc = bool({"montecarlo", "allocation"} & f)
    # inspection solves the forces, nominal and measured, when [load] gives a torque
    inspected = "inspection" in f and "load" in data
    solver = forces or bool(_SOLVER_FORMATS & f) or inspected
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
    if "tolerances" in data and not mc and "modification" not in f:  # the design searches it
        warn("[tolerances]", 'formats lists neither "montecarlo" nor "allocation"')
    if "sweeps" in data and "sweeps" not in f:
        warn("[sweeps]", 'formats does not list "sweeps"')
    sz = data.get("sizing") if isinstance(data.get("sizing"), dict) else {}
    for sec in ("sizing", "sizing.requirements", "sizing.variables"):
        given = sec in data or sec.removeprefix("sizing.") in sz
        if given and "sizing" not in f:
            warn(f"[{sec}]", 'formats does not list "sizing"')
    if "load" in data and not solver and "first_stage" not in data:  # its loads use it
        warn(
            "[load]",
            "no format needs the mesh forces (forces, montecarlo, allocation, sweeps, inspection)",
        )
    if "material" in data and not solver and "first_stage" not in data:  # Hertz of the gears
        warn("[material]", "only the force solver uses it and no format needs it")
    sv = data.get("solver", {})
    # model = "drive" describes the hardware, as the drive's sections do: it lets them and
    # [design] slot_clearance load whatever the formats (so does its contact law).
    described = sv.get("model") == "drive" and set(sv) <= {"model", "contact_law", "bodies"}
    if "solver" in data and not solver and not described:
        warn(
            "[solver]",
            "no format runs the force solver (forces, montecarlo, allocation, sweeps, inspection)",
        )
    elif not forces:
        # inspection solves with positions and crank_angles_deg; the datasheet with the
        # variants (its positions are its own)
        for k in ("positions", "crank_angles_deg", "variants"):
            used = (k == "variants" and sheet) or (k != "variants" and inspected)
            if k in sv and not used:
                who = (
                    'only "forces", "datasheet" and [checks] use it'
                    if k == "variants"
                    else 'only "forces", "inspection" and [checks] use it (the datasheet '
                    "takes [datasheet] positions_per_mesh)"
                )
                warn(f"[solver] {k}", who)
    # A Monte Carlo takes its figures from it, the inspection its predicted play.
    if "datasheet" in data and not sheet and not mc and "inspection" not in f:
        warn(
            "[datasheet]",
            'formats lists none of "datasheet", "montecarlo", "allocation", "inspection" '
            "and no [checks] limit needs it",
        )
    if "friction" in data and not sheet:
        warn("[friction]", 'formats does not list "datasheet" and no [checks] limit needs it')
    th = data.get("thermal")
    for section, given in (
        ("lubrication", "lubrication" in data),
        ("thermal", "thermal" in data),
        ("thermal.test", isinstance(th, dict) and "test" in th),
    ):
        if given and "datasheet" not in f:
            warn(f"[{section}]", 'formats does not list "datasheet"')
    if "life" in data and not sheet and "montecarlo" not in f:  # the Monte Carlo's life_h
        warn(
            "[life]",
            'formats lists neither "datasheet" nor "montecarlo" and no [checks] limit needs it',
        )
    ex = data.get("export", {})
    if "representation" in ex and "dxf" not in f:
        warn("[export] representation", 'formats does not list "dxf"')
    geometry = bool((_MESH | {"step", "interference"}) & f)
    # edm: the wire path and its decimals take the tolerance too
    if "tolerance" in ex and not {"dxf", "edm"} & f and ("chord_tolerance" in ex or not geometry):
        warn(
            "[export] tolerance", 'formats lists no "dxf" or "edm" (and no mesh/STEP takes it over)'
        )
    if "chord_tolerance" in ex and not geometry:
        warn("[export] chord_tolerance", "formats lists no mesh, step or interference")
    if "assembly_angles_deg" in ex and not (_MESH | {"step"}) & f:  # STEP writes assemblies too
        warn("[export] assembly_angles_deg", "formats lists no mesh (stl, 3mf, glb, ply) or step")
    if "interference_positions" in ex and "interference" not in f:
        warn("[export] interference_positions", 'formats does not list "interference"')
    if "interference_method" in ex and "interference" not in f:
        warn("[export] interference_method", 'formats does not list "interference"')
    edm = data.get("edm", {})
    if "edm" in data and "edm" not in f:
        warn("[edm]", 'formats does not list "edm"')
    else:
        if "d_register" in edm and edm.get("compensation", "path") == "path":
            warn("[edm] d_register", 'compensation = "path" puts the offset in the path')
        if "program_number" in edm and edm.get("dialect", "iso") != "fanuc":
            warn("[edm] program_number", 'only dialect = "fanuc" writes an O number')
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
            or (sheet and not measured)  # the measured ring's datasheet: other parts nominal
            or mc
            or exact
            or inspected
            or "modification" in f  # the design searches from the scene's errors
            or (roller_only and k in ("roller_radius_error", "roller_radius_errors"))
        ):
            warn(
                f"[errors] {k}",
                "only forces, datasheet (without measured_profile), checks, montecarlo, "
                "allocation, modification, interference, inspection with [load]",
            )
    out.extend(f"{what} has no effect in this scene: {why}" for what, why in _modification(data, f))
    return tuple(out)


def _modification(data: dict, f: set[str]) -> list[tuple[str, str]]:
    """``[modification]``, ``[modification.design]`` and ``[assembly]`` keys without effect."""
    found = []
    mod = data.get("modification", {})
    mod = mod if isinstance(mod, dict) else {}
    # split by the loader, or still nested as TOML reads it (the template's own check)
    design = "modification.design" in data or isinstance(mod.get("design"), dict)
    if design and "modification" not in f:
        found.append(("[modification.design]", 'formats does not list "modification"'))
    if "inspect_against" in mod and "inspection" not in f:
        found.append(("[modification] inspect_against", 'formats does not list "inspection"'))
    asm = data.get("assembly", {})
    asm = asm if isinstance(asm, dict) else {}
    for k in asm:
        if k != "roller_classes_um" and "roller_classes_um" not in asm:
            found.append((f"[assembly] {k}", "[assembly] roller_classes_um is not set"))
    return found


def renamed_key_warnings(data: dict) -> tuple[str, ...]:
    """One line for a key whose meaning changed, naming the key that took the old one.

    ``[checks] max_lost_motion_arcmin`` meant the free play at zero torque
    before the datasheet; it now limits the catalogue lost motion (at
    +-``lost_motion_band`` of the rated torque, elastic windup included),
    which is never smaller. It keeps working, with the new meaning; a scene
    that configures ``[datasheet]`` was written for the new meaning and is
    not warned.
    """
    if "max_lost_motion_arcmin" in data.get("checks", {}) and "datasheet" not in data:
        return (
            "[checks] max_lost_motion_arcmin now limits the lost motion at +-3 % of the rated "
            "torque (elastic windup included); the free play at zero torque it limited before "
            "is max_backlash_arcmin",
        )
    return ()


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


def _derived_defaults() -> dict[str, tuple[float, str]]:
    """The template design's derived radii: each default's value and its formula, evaluated."""
    import math

    from corr_cad.geometry.design import SLOT_END_CLEARANCE, GearDesign

    d = GearDesign(**{k: s.default for k, s in SCHEMA["design"].items() if s.default is not None})
    e, Rj, r, c = d.eccentricity, d.cam_radius, d.roller_radius, SLOT_END_CLEARANCE
    m = max(5.0, r)
    ring = e + Rj + 2 * r + max(10.0, 3 * r)
    bore = min(0.35 * Rj, 0.5 * (Rj - e))
    inner = Rj - e - c
    return {
        "ring_outer_radius": (
            d.ring_outer_radius,
            f"{e:g} + {Rj:g} + 2 x {r:g} + max(10, 3 x {r:g}) = {ring:g}, "
            f"up to {5 * math.ceil(ring / 5):g}",
        ),
        "face_width": (d.face_width, f"roller_length = {d.roller_length:g}"),
        "cam_bore_radius": (
            d.cam_bore_radius,
            f"min(0.35 x {Rj:g}, ({Rj:g} - {e:g})/2) = {bore:g}, rounded to {d.cam_bore_radius:g}",
        ),
        "frame_inner_radius": (
            d.frame_inner_radius,
            f"max({inner:g} - {m:g}, {inner:g}/2) = {d.frame_inner_radius:g}",
        ),
        "frame_outer_radius": (
            d.frame_outer_radius,
            f"{Rj:g} + {e:g} + 2 x {r:g} + {c:g} + {m:g} = {d.frame_outer_radius:g}",
        ),
        "frame_thickness": (d.frame_thickness, f"max(5, {r:g}) = {d.frame_thickness:g}"),
    }


#: What ``corr-cad new`` says about the two force models, above ``[solver]``.
MODEL_COMMENT = (
    '# Two force models. model = "paper" is the paper\'s: one row of rollers carrying',
    "# load_share of the crank moment M0 on a fixed cam; use it to reproduce and compare",
    '# with the paper. model = "drive" solves both rows and both cams together: the row',
    "# share is a result, [errors.row_b] gives row B its own errors and the cams float on",
    "# [bearings.eccentric]; use it for the datasheet of a reducer you mean to build,",
    '# with contact_law = "palmgren" (bearing practice\'s steel line contact). Under',
    '# "drive" leave load_share out. The drive\'s sections follow [errors], commented out.',
)


def template_text() -> str:
    """A commented scene with every section and key (optional ones commented out).

    Sections and keys that would have no effect with the template's own
    formats are written commented out too, so that a fresh scene runs without
    a single "has no effect" warning; uncomment them with the format they need.
    """
    derived = _derived_defaults()
    quiet: set[str] = set()
    for _ in range(2):  # pass 1 finds what would warn, pass 2 writes it commented
        lines = [
            "# corr_cad scene. Units: mm, N, N*mm, MPa; angles in degrees.",
            "# Run it with:  corr-cad run THIS_FILE --out outputs/NAME",
            "# Commented sections and keys take effect with the formats they name.",
            "",
        ]
        for section, keys in SCHEMA.items():
            # [first_stage] describes hardware the drive may not have: written commented
            off = f"[{section}]" in quiet or section in DRIVE_SECTIONS or section == "first_stage"
            if section == "solver":
                lines.extend(MODEL_COMMENT)
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
                line = f"{'# ' if commented else ''}{k} = {_toml_value(value)}"
                if section == "design" and k in derived:
                    value, how = derived[k]
                    line = f"# {k} = {_toml_value(value)}   # the default here: {how}"
                lines.append(line)
            lines.append("")
        data = tomllib.loads("\n".join(lines))
        formats = tuple(data.get("export", {}).get("formats", SCHEMA["export"]["formats"].default))
        found = {w.split(" has no effect")[0] for w in no_effect_warnings(data, formats, False)}
        if not found - quiet:
            break
        quiet |= found
    return "\n".join(lines)
