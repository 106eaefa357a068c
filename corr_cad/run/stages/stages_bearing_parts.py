"""The cams' needle bearings and the crankshaft inside the file stages.

Only under ``[solver] model = "drive"`` with ``[bearings.eccentric]``
(:func:`needle_rows_of` is None otherwise, and no other scene reaches the rest of
this module): the needles (``needle``, and ``needle_b`` where row B's differ) and,
without ``[first_stage]`` (whose crankshaft carries the eccentrics then), the
crankshaft (:mod:`corr_cad.geometry.bearing_parts`).
"""

from __future__ import annotations

import math

from corr_cad.run.stages.context import RunContext

__all__ = [
    "needle_rows_of",
    "crank_drawing",
    "profiles",
    "solids",
    "placements",
    "step_parts",
    "dxf_files",
    "contact_allowances",
]


def needle_rows_of(ctx_or_scene):
    """The drawn rows (:func:`~corr_cad.geometry.bearing_parts.needle_rows`, as
    :class:`~corr_cad.geometry.bearing_parts.BearingRows` carrying the crankshaft drawn:
    the scene's crank model, or without ``[crankshaft]`` / ``[bearings.crank]`` the shaft
    :func:`~corr_cad.run.scene.scene_crank.default_layout` derives), or None."""
    s = getattr(ctx_or_scene, "scene", ctx_or_scene)
    solver = getattr(s, "solver", None)
    if solver is None or not solver.drive or getattr(s, "bearing", None) is None:
        return None
    from corr_cad.geometry.bearing_parts import BearingRows, needle_rows

    rows = BearingRows(needle_rows(s.design, s.bearing, s.bearing_b))
    rows.crank = crank_drawing(s)
    return rows


def crank_drawing(scene):
    """The crankshaft the files draw (:class:`~corr_cad.geometry.bearing_parts.CrankDrawing`):
    the one the crank model bends (``[crankshaft]`` / ``[bearings.crank]``, their derived
    defaults filled in), or, without either section (the model keeps the crank rigid),
    the same derived default shaft: one crankshaft, with or without ``[first_stage]``."""
    from corr_cad.geometry.bearing_parts import CrankDrawing
    from corr_cad.run.scene.scene_crank import default_layout

    s = scene
    needle = s.bearing.needle_diameter
    crank = getattr(s, "crank", None)
    if crank is None:
        d = default_layout(s.design, needle)
        return CrankDrawing(
            d["shaft_diameter"],
            d["eccentric_diameter"],
            d["eccentric_length"],
            tuple(d["eccentric_positions"]),
            tuple(d["support_positions"]),
            float(d["width"]),
            float(d["gear_position"]),
            0.0,
            d["pitch_diameter"] + 2.0 * d["roller_diameter"],
        )
    sh = crank.shaft
    brg = next((b for b in crank.supports if b is not None), None)
    dflt = default_layout(s.design, needle, sh.shaft_diameter)
    if brg is None:  # rigid supports: the bearing a designer would draw
        width, outer = dflt["width"], dflt["pitch_diameter"] + 2.0 * dflt["roller_diameter"]
    else:
        width, outer = brg.width or dflt["width"], brg.pitch_diameter + 2.0 * brg.roller_diameter
    return CrankDrawing(
        sh.shaft_diameter,
        sh.eccentric_diameter,
        sh.eccentric_length,
        tuple(sh.eccentric_positions),
        tuple(sh.support_positions),
        float(width),
        float(sh.gear_position),
        float(sh.bore_diameter),
        float(outer),
    )


def profiles(ctx: RunContext, rows) -> dict:
    """``{part: [(outer, holes, height, z0), ...]}`` of the parts drawn here."""
    from corr_cad.geometry.bearing_parts import (
        crankshaft_pieces,
        needle_part_names,
        needle_pieces,
    )

    s = ctx.scene
    out = {part: needle_pieces(row) for part, row in needle_part_names(rows).items()}
    if s.first_stage is None:
        out["crankshaft"] = crankshaft_pieces(s.design, rows, s.design.face_width)
    return out


def solids(ctx: RunContext, rows, report: dict) -> dict:
    """Manifold solids of :func:`profiles`; their mesh facts go into ``report``."""
    from corr_cad.export import mesh
    from corr_cad.geometry.first_stage_parts import piece_outlines

    tol = ctx.scene.chord_tolerance
    out = {}
    for part, pieces in piece_outlines(profiles(ctx, rows), tol).items():
        solid = mesh.stacked_solid(pieces)
        facts = mesh.check_mesh(mesh.to_trimesh(solid), part)
        exact = sum(o.exact_volume for o, _ in pieces)
        length = sum(o.boundary_length * o.thickness for o, _ in pieces)
        facts.update(
            {
                "exact_volume_mm3": exact,
                "volume_error_mm3": facts["volume_mm3"] - exact,
                "volume_error_bound_mm3": tol * length,
                "chord_tolerance_mm": tol,
            }
        )
        report[part] = facts
        out[part] = solid
    return out


def placements(ctx: RunContext, rows, angle_deg: float) -> list:
    """The needles (and the crankshaft without ``[first_stage]``) at ``angle_deg``."""
    from corr_cad.geometry.bearing_parts import bearing_placements

    s = ctx.scene
    return bearing_placements(
        s.design, rows, math.radians(angle_deg), crankshaft=s.first_stage is None
    )


def step_parts(ctx: RunContext, rows, report: dict, quick_boxes: dict) -> dict:
    """Write ``<part>.step`` of :func:`profiles`, read each back; returns the shapes.

    Circles are exact in STEP: the read-back volume equals the exact one to 1e-9.
    """
    from corr_cad.export import step, step_gears
    from corr_cad.geometry.first_stage_parts import exact_volume

    shapes = {}
    for part, pieces in profiles(ctx, rows).items():
        shape = step_gears.stacked_shape(pieces)
        fname = f"{part}.step"
        path = step.write_step(shape, ctx.out / fname, part)
        product, parts = step.read_step(path, heal=False)
        exact = exact_volume(pieces)
        facts = step.readback_facts(fname, product, part, parts[0].shape, exact, 1e-9 * exact)
        report[fname] = facts
        quick_boxes[part] = step.bounding_box(parts[0].shape, optimal=False)
        ctx.files.append(fname)
        shapes[part] = shape
    return shapes


def dxf_files(ctx: RunContext, rows) -> None:
    """``needle.dxf`` (and ``needle_b.dxf``), ``crankshaft.dxf`` without ``[first_stage]``."""
    from corr_cad.export.gear_dxf import write_round_part

    for part, pieces in profiles(ctx, rows).items():
        path = write_round_part(ctx.scene.design, part, pieces, ctx.out / f"{part}.dxf")
        ctx.files.append(path.name)


def contact_allowances(design, rows, chord_tol: float) -> dict:
    """What tessellation alone can overlap where a needle touches its races by design.

    Both polygons are inscribed within ``chord_tol``: a nominal tangent contact can
    show a penetration ``d = 2 chord_tol``, a lens of area ``4/3 d sqrt(2 R* d)``
    over the needle's length, ``1/R* = 2/D - 1/R_b`` on the cam's bore (concave) and
    ``2/D + 1/r_j`` on the journal (as :func:`~corr_cad.run.stages.stages_geometry.
    interference_allowance` for the rollers). Keys: instance-name prefixes for
    :func:`corr_cad.export.mesh.solid_overlaps`.
    """
    d = 2.0 * chord_tol
    out = {}
    for row in rows:
        rn = 0.5 * row.needle_diameter
        bore = 1.0 / (1.0 / rn - 1.0 / design.cam_bore_radius)
        journal = 1.0 / (1.0 / rn + 1.0 / row.journal_radius)
        lens = 4.0 / 3.0 * d * row.needle_length
        tag = row.row
        out[(f"needle_{tag}_", f"cam_{tag}")] = lens * math.sqrt(2.0 * bore * d)
        out[(f"needle_{tag}_", "crankshaft")] = lens * math.sqrt(2.0 * journal * d)
    return out
