"""The first gear stage inside the solid stages: its outlines, solids, meshes and STEP.

Called by the bodies in :mod:`corr_cad.run.stages.stages_geometry` when the scene has
``[first_stage]``; a scene without it never reaches this module.
"""

from __future__ import annotations

import math

from corr_cad.geometry.first_stage_parts import (
    exact_volume,
    first_stage_outlines,
    first_stage_placements,
    first_stage_profiles,
)
from corr_cad.geometry.gear_outline import approximate_gear
from corr_cad.run.stages.context import RunContext

__all__ = ["gear_outlines", "part_pieces", "solids", "placements", "step_parts", "drive"]

GEARS = ("pinion", "wheel", "crank_gear")


def gear_outlines(ctx: RunContext, tol: float) -> dict:
    """Each gear's measured outline at ``tol`` (reused when the DXF stage made it)."""
    have = ctx.results.gear_outlines
    if have is not None and all(o.tolerance == tol for o in have.values()):
        return have
    fs = ctx.scene.first_stage
    made = {part: approximate_gear(getattr(fs, part), tol) for part in GEARS}
    if tol == ctx.scene.tolerance:
        ctx.results.gear_outlines = made
    return made


def drive(ctx: RunContext) -> None:
    """The whole drive: ratio, masses, inertia at the input; the first stage's loads."""
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.mechanics.gears.first_stage_loads import drive_mass_inertia, first_stage_loads
    from corr_cad.run.scene.scene_first_stage import FIRST_STAGE_CHECKS
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    s = ctx.scene
    fs, tol = s.first_stage, s.tolerance
    rows = needle_rows_of(ctx)
    verts = {k: o.vertices for k, o in gear_outlines(ctx, tol).items()}
    profiles = first_stage_profiles(s.design, fs, verts, rows)
    outlines = ctx.results.outlines or part_outlines(
        s.design, ctx.results.working, tol, floating=rows is not None
    )
    if tol == s.chord_tolerance:  # the solids stage's outlines: made once
        ctx.results.outlines = outlines
    report = drive_mass_inertia(s.design, fs, profiles, outlines, rows)
    if s.load is not None:
        t_in = s.load.input_torque * fs.stage.pinion_teeth / fs.stage.crank_gear_teeth
        loads = first_stage_loads(
            fs, t_in, s.design.material.young_modulus, s.design.material.poisson_ratio
        )
        report["first_stage_loads"] = loads.as_dict()
        values = {
            "max_first_stage_bending_MPa": max(loads.bending.values()),
            "max_first_stage_contact_MPa": max(loads.contact),
        }
        for key in FIRST_STAGE_CHECKS:
            limit = getattr(s.checks, key)
            if limit is not None:
                v = values[key]
                ctx.manifest.setdefault("checks", {})[key] = {
                    "value": v,
                    "limit": limit,
                    "margin": limit - v,
                    "passed": bool(v <= limit),
                }
    ctx.manifest["drive"] = report


def part_pieces(ctx: RunContext, tol: float) -> dict:
    """``{part: [(PartOutline, z0), ...]}`` of every first-stage part at ``tol``."""
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    outlines = gear_outlines(ctx, tol)
    verts = {k: o.vertices for k, o in outlines.items()}
    rows = needle_rows_of(ctx)
    return first_stage_outlines(ctx.scene.design, ctx.scene.first_stage, verts, tol, rows)


def solids(ctx: RunContext, report: dict) -> dict:
    """Manifold solids of the first-stage parts; their mesh facts go into ``report``."""
    from corr_cad.export import mesh

    tol = ctx.scene.chord_tolerance
    gears = gear_outlines(ctx, tol)
    out = {}
    for part, pieces in part_pieces(ctx, tol).items():
        solid = mesh.stacked_solid(pieces)
        facts = mesh.check_mesh(mesh.to_trimesh(solid), part)
        exact = sum(o.exact_volume for o, _ in pieces)
        dev = gears[part].max_deviation if part in gears else 0.0
        length = sum(o.boundary_length * o.thickness for o, _ in pieces)
        facts.update(
            {
                "exact_volume_mm3": exact,
                "volume_error_mm3": facts["volume_mm3"] - exact,
                "volume_error_bound_mm3": (tol + dev) * length,
                "chord_tolerance_mm": tol,
            }
        )
        report[part] = facts
        out[part] = solid
    return out


def placements(ctx: RunContext, angle_deg: float) -> list:
    """The first stage's instances at ``angle_deg``, laid out along the drawn crankshaft."""
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    s = ctx.scene
    return first_stage_placements(
        s.design, s.first_stage, math.radians(angle_deg), needle_rows_of(ctx)
    )


def step_parts(ctx: RunContext, report: dict, quick_boxes: dict) -> dict:
    """Write ``<part>.step`` of each first-stage part, read it back; returns the shapes.

    Each file's facts go into ``report``, its quick box as read back
    (:func:`~corr_cad.export.step.bounding_box`) into ``quick_boxes``.
    """
    from corr_cad.export import step, step_gears
    from corr_cad.geometry.gear_outline import spline_gear

    tol = ctx.scene.chord_tolerance
    fs = ctx.scene.first_stage
    splines = {k: spline_gear(getattr(fs, k), tol) for k in GEARS}
    verts = {k: o.vertices for k, o in gear_outlines(ctx, tol).items()}
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    rows = needle_rows_of(ctx)
    exact_profiles = first_stage_profiles(ctx.scene.design, fs, verts, rows)
    profiles = first_stage_profiles(ctx.scene.design, fs, splines, rows)
    lengths = {
        part: sum(o.boundary_length * o.thickness for o, _ in pcs)
        for part, pcs in part_pieces(ctx, tol).items()
    }
    shapes = {}
    for part, pieces in profiles.items():
        shape = step_gears.stacked_shape(pieces)
        fname = f"{part}.step"
        path = step.write_step(shape, ctx.out / fname, part)
        product, parts = step.read_step(path, heal=False)
        # the exact volume: circles exact, the gear outline by its polyline, whose
        # measured deviation (and the splines') bound the difference
        exact = exact_volume(exact_profiles[part])
        bound = 1e-9 * exact
        extra = {}
        if part in splines:
            dev = splines[part].max_deviation + gear_outlines(ctx, tol)[part].max_deviation
            bound += dev * lengths[part]
            extra["profile_spline_deviation_mm"] = splines[part].max_deviation
        facts = step.readback_facts(fname, product, part, parts[0].shape, exact, bound, **extra)
        report[fname] = facts
        quick_boxes[part] = step.bounding_box(parts[0].shape, optimal=False)
        ctx.files.append(fname)
        shapes[part] = shape
    return shapes


#: The whole drive's checks: metric -> how the first stage's share combines with the
#: second stage's ("add": backlash and lost motion; "series": rigidity; "product":
#: efficiency), and the figure the check reads.
WHOLE_DRIVE_METRICS = {
    "backlash_arcmin": (
        "add",
        "whole drive at the output: the second stage's free play (largest over the "
        "positions) plus the first stage's backlash (pinion held) / (z + 1)",
    ),
    "lost_motion_arcmin": (
        "add",
        "whole drive at the output: the second stage's lost motion (datasheet, largest) "
        "plus the first stage's backlash / (z + 1) and its meshes' windup at +-band T_R",
    ),
    "torsional_rigidity_Nm_per_arcmin": (
        "series",
        "whole drive: 1 / (1/K2 + 1/K1), the second stage's catalogue rigidity (smallest) "
        "in series with the first stage's mesh stiffness (ISO 6336-1) times (z + 1)^2",
    ),
    "efficiency": (
        "product",
        "whole drive, forward: the second stage's smallest efficiency over the map times "
        "the first stage's eta1 (ISO/TR 14179-2 sliding loss)",
    ),
}


def first_stage_mesh_of(ctx: RunContext):
    """The first stage's :class:`~corr_cad.mechanics.gears.first_stage_mesh.FirstStageMesh`
    (``[friction] mu_mesh``; 0 without ``[friction]``: no loss figure is read then)."""
    from corr_cad.mechanics.gears.first_stage_mesh import first_stage_mesh

    s = ctx.scene
    mu = s.friction.get("mu_mesh", 0.0) if s.friction else 0.0
    return first_stage_mesh(s.first_stage, s.design.roller_count, mu)


def first_stage_shares(ctx: RunContext, spec=None) -> dict[str, float]:
    """The first stage's part of each whole-drive check metric that this run has
    (``spec``: the datasheet's :class:`DatasheetSpec`, default the run's datasheet's)."""
    from corr_cad.tolerance.checks import ARCMIN_PER_RAD

    m = first_stage_mesh_of(ctx)
    out = {"backlash_arcmin": m.output_backlash * ARCMIN_PER_RAD}
    ds = ctx.results.datasheet
    if spec is None and ds is not None:
        spec = ds.spec
    if spec is not None:
        sp = spec
        out["lost_motion_arcmin"] = (
            m.lost_motion(sp.rated_torque, sp.lost_motion_band) * ARCMIN_PER_RAD
        )
        out["torsional_rigidity_Nm_per_arcmin"] = m.output_stiffness / ARCMIN_PER_RAD / 1000.0
    if ctx.results.friction is not None:
        out["efficiency"] = m.efficiency
    return out


def whole_drive_values(values: dict[str, float], shares: dict[str, float]) -> dict[str, dict]:
    """Each whole-drive metric with its parts: ``{metric: {value, second_stage,
    first_stage, combined}}``, for the metrics both ``values`` and ``shares`` have."""
    out = {}
    for k, first in shares.items():
        if k not in values:
            continue
        second = float(values[k])
        how, figure = WHOLE_DRIVE_METRICS[k]
        if how == "add":
            total = second + first
        elif how == "series":
            total = 1.0 / (1.0 / second + 1.0 / first)
        else:
            total = second * first
        out[k] = {"value": total, "second_stage": second, "first_stage": first, "figure": figure}
    return out


def second_stage_limits(ctx: RunContext, checks, spec=None):
    """The limits the second stage's Monte Carlo samples must meet for the whole drive
    to meet ``checks``: ``(Checks, {check: {limit, second_stage_limit, first_stage}})``.

    The first stage's share is the nominal gears' (no tolerance of its own):
    a sum's limit less it; a rigidity in series ``1 / (1/L - 1/K1)`` (infinite
    where ``K1`` alone is below ``L``).
    """
    from dataclasses import replace

    from corr_cad.tolerance.checks import CHECK_METRICS

    shares = first_stage_shares(ctx, spec)
    new, record = {}, {}
    for name, limit in checks.active().items():
        metric = CHECK_METRICS[name][0]
        if metric not in shares or metric == "efficiency":
            continue
        first = shares[metric]
        if WHOLE_DRIVE_METRICS[metric][0] == "add":
            second = limit - first
        else:
            rest = 1.0 / limit - 1.0 / first if limit > 0.0 else float("inf")
            second = 1.0 / rest if rest > 0.0 else float("inf")
        new[name] = second
        record[name] = {"limit": limit, "second_stage_limit": second, "first_stage": first}
    return replace(checks, **new), record
