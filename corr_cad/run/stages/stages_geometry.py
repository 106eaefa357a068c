"""Pipeline stages for the solids: meshes, STEP, the mesh interference sweep
and the exact clearance (registered in :data:`corr_cad.run.stages.stages.STAGES`).
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.errors import ExportError
from corr_cad.export.files import angle_tag
from corr_cad.geometry.sampling import approximate
from corr_cad.run.stages.context import RunContext, expected_seconds, modified_curve, raw_errors

#: Part names of the files, the same for DXF, meshes and STEP.
PART_NAMES = {"ring": "inner_gear", "cam": "disk_cam", "roller": "roller", "frame": "teeth_frame"}
MESH_FORMATS = ("stl", "3mf", "glb", "ply")


def _solids(ctx: RunContext) -> None:
    from corr_cad.export import mesh
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    s = ctx.scene
    tol = s.chord_tolerance
    rows = needle_rows_of(ctx)
    # Made by the drive's stage at this tolerance where it ran, else here.
    outlines = ctx.results.outlines or part_outlines(
        s.design, ctx.results.working, tol, floating=rows is not None
    )
    solids, meshes, report = {}, {}, {}
    for name, outline in outlines.items():
        solid = mesh.solid(outline)
        tm = mesh.to_trimesh(solid)
        facts = mesh.check_mesh(tm, PART_NAMES[name])
        exact = outline.exact_volume
        facts.update(
            {
                "exact_volume_mm3": exact,
                "volume_error_mm3": facts["volume_mm3"] - exact,
                "volume_error_bound_mm3": tol * outline.boundary_length * outline.thickness,
                "chord_tolerance_mm": tol,
            }
        )
        solids[name], meshes[name], report[PART_NAMES[name]] = solid, tm, facts
    if s.first_stage is not None:
        from corr_cad.run.stages import stages_first_stage

        ctx.results.first_stage_solids = stages_first_stage.solids(ctx, report)
    if rows is not None:
        from corr_cad.run.stages import stages_bearing_parts

        more = stages_bearing_parts.solids(ctx, rows, report)
        ctx.results.first_stage_solids = {**(ctx.results.first_stage_solids or {}), **more}
    ctx.results.outlines = outlines
    ctx.results.solids = solids
    ctx.results.meshes = meshes
    ctx.manifest["solids"] = report


def _mesh_files(ctx: RunContext) -> None:
    from corr_cad.export import mesh

    s = ctx.scene
    fmts = [f for f in MESH_FORMATS if f in s.formats]
    solids = ctx.results.solids
    stack = mesh.frame_stack(s.design, solids["frame"])
    for name, tm in ctx.results.meshes.items():
        for fmt in fmts:
            fname = f"{PART_NAMES[name]}.{fmt}"
            mesh.write_mesh(tm, ctx.out / fname, fmt)
            ctx.files.append(fname)
    first = ctx.results.first_stage_solids or {}
    for name, man in first.items():
        tm = mesh.to_trimesh(man)
        for fmt in fmts:
            mesh.write_mesh(tm, ctx.out / f"{name}.{fmt}", fmt)
            ctx.files.append(f"{name}.{fmt}")
    for angle in s.assembly_angles_deg:
        placed, _ = _placed_solids(ctx, solids, angle, stack=stack)
        parts = {k: mesh.to_trimesh(v) for k, v in placed.items()}
        # Closed and consistently wound depend on the triangles alone (vertex
        # indices), which a placement (a rotation and a move) keeps: a copy of
        # a mesh checked here (the rollers, the rings, the plates, the wheels) is
        # checked once, with the first of its instances.
        checked = set()
        for name, tm in parts.items():
            key = (len(tm.vertices), tm.faces.tobytes())
            if key not in checked:
                mesh.check_mesh(tm, name)
                checked.add(key)
        for fmt in fmts:
            fname = f"assembly_{angle_tag(angle)}.{fmt}"
            mesh.write_mesh(parts, ctx.out / fname, fmt)
            ctx.files.append(fname)


def _placed_solids(ctx: RunContext, solids: dict, angle: float, **kw) -> dict:
    """Every solid of the assembly at ``angle`` (deg): the second stage's, the first
    stage's and the bearings' (with ``[first_stage]`` and the eccentric bearings)."""
    from corr_cad.export import mesh
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    rows = needle_rows_of(ctx)
    asm = mesh.assembly(
        ctx.scene.design, solids, math.radians(angle), floating=rows is not None, **kw
    )
    placed = asm.all_solids()
    extra = ctx.results.first_stage_solids or {}
    where = []
    if ctx.scene.first_stage is not None:
        from corr_cad.run.stages.stages_first_stage import placements

        where += placements(ctx, angle)
    if rows is not None:
        from corr_cad.run.stages import stages_bearing_parts

        where += stages_bearing_parts.placements(ctx, rows, angle)
    placed.update({p.name: mesh.place(extra[p.part], p) for p in where})
    return placed, asm


def _step_files(ctx: RunContext) -> None:
    from corr_cad.export import step
    from corr_cad.geometry.parts import part_outlines
    from corr_cad.geometry.placement import assembly_placements
    from corr_cad.run.stages.stages_bearing_parts import needle_rows_of

    step.require_ocp()
    s = ctx.scene
    tol = s.chord_tolerance
    rows = needle_rows_of(ctx)
    floating = rows is not None
    spline = approximate(ctx.results.working, "spline", tol)
    shapes = step.part_shapes(s.design, spline, floating)
    outlines = ctx.results.outlines or part_outlines(
        s.design, ctx.results.working, tol, floating=floating
    )
    report = {}
    volumes = {}
    quick_boxes = {}  # each part file's quick box, as read back
    for name, shape in shapes.items():
        fname = f"{PART_NAMES[name]}.step"
        path = step.write_step(shape, ctx.out / fname, PART_NAMES[name])
        product, parts = step.read_step(path, heal=False)
        o = outlines[name]
        exact = o.exact_volume
        # Only the ring's profile is approximated (by the spline, within its
        # measured deviation); circles, lines and arcs are exact in STEP.
        bound = (
            spline.max_deviation * o.boundary_length * o.thickness
            if name == "ring"
            else 1e-9 * exact
        )
        ring = name == "ring"
        facts = step.readback_facts(
            fname,
            product,
            PART_NAMES[name],
            parts[0].shape,
            exact,
            bound,
            profile_spline_deviation_mm=spline.max_deviation if ring else None,
            profile_edges=_profile_edge_count(spline) if ring else None,
        )
        volume = facts["readback_volume_mm3"]
        report[fname] = facts
        volumes[name] = volume
        quick_boxes[PART_NAMES[name]] = step.bounding_box(parts[0].shape, optimal=False)
        ctx.files.append(fname)
    names = PART_NAMES
    if s.first_stage is not None:
        from corr_cad.run.stages import stages_first_stage

        shapes = {**shapes, **stages_first_stage.step_parts(ctx, report, quick_boxes)}
    if rows is not None:
        from corr_cad.run.stages import stages_bearing_parts

        shapes = {**shapes, **stages_bearing_parts.step_parts(ctx, rows, report, quick_boxes)}
    if len(shapes) > len(PART_NAMES):
        names = {**PART_NAMES, **{k: k for k in shapes if k not in PART_NAMES}}
    for angle in s.assembly_angles_deg:
        tag = angle_tag(angle)
        fname = f"assembly_{tag}.step"
        placements = assembly_placements(s.design, math.radians(angle), floating)
        if s.first_stage is not None:
            placements += stages_first_stage.placements(ctx, angle)
        if rows is not None:
            placements += stages_bearing_parts.placements(ctx, rows, angle)
        path = step.write_assembly_step(
            shapes, names, placements, ctx.out / fname, f"assembly_{tag}"
        )
        product, parts = step.read_step(path, heal=False)
        got = [(p.name, p.product) for p in parts]
        want = [(p.name, names[p.part]) for p in placements]
        if product != f"assembly_{tag}" or got != want:
            raise ExportError(f"{fname}: read-back names differ from the placements written")
        # Each product's box once, from its shape in this file; it must be the
        # box of its own part file (the quick box: equal geometry, equal box).
        # Then the corners of that box moved by each instance's location as
        # read, against the placement applied here.
        boxes: dict[str, np.ndarray] = {}
        offset = 0.0
        for p, want in zip(parts, placements, strict=True):
            if p.product not in boxes:
                box = step.bounding_box(step.unplaced(p.shape), optimal=False)
                if not np.abs(box - quick_boxes[p.product]).max() <= 1e-9:
                    raise ExportError(f"{fname}: product {p.product} is not {p.product}.step")
                boxes[p.product] = box
            corners = _box_corners(boxes[p.product])
            moved = step.transform_points(p.shape, corners)
            offset = max(offset, float(np.abs(moved - _placed_points(want, corners)).max()))
        if offset > 1e-6:
            raise ExportError(f"{fname}: a part is {offset:.3g} mm from where it was placed")
        report[fname] = {
            "product_name": product,
            "instances": len(parts),
            "instance_counts": {names[k]: sum(p.part == k for p in placements) for k in names},
            "max_placement_error_mm": offset,
        }
        ctx.files.append(fname)
        _freecad_step_file(ctx, shapes, placements, parts, tag, report)
    ctx.manifest["step"] = report


def _freecad_step_file(ctx: RunContext, shapes, placements, parts, tag: str, report) -> None:
    """The assembly as one compound of its placed solids (FreeCAD 0.20's default
    importer opens it): read back, as many solids as instances, of the
    assembly's total volume (each instance its product's part file's volume as read
    back: the assembly's product is that file's geometry, its box checked)."""
    from corr_cad.export import step

    fname = f"assembly_{tag}_freecad.step"
    path = step.write_compound_step(shapes, placements, ctx.out / fname, f"assembly_{tag}")
    product_volume: dict[str, float] = {}
    for p in parts:
        if p.product not in product_volume:
            read = report.get(f"{p.product}.step", {}).get("readback_volume_mm3")
            product_volume[p.product] = read if read is not None else step.volume(p.shape)
    want = sum(product_volume[p.product] for p in parts)
    solids = step.read_solids(path, heal=False)
    volume = sum(step.volume(s) for s in solids)
    facts = {
        "solids": len(solids),
        "readback_volume_mm3": volume,
        "assembly_volume_mm3": want,
        "volume_relative_error": (volume - want) / want,
    }
    if len(solids) != len(placements) or not abs(volume - want) <= 1e-9 * want:
        raise ExportError(f"{fname}: read-back check failed ({facts})")
    report[fname] = facts
    ctx.files.append(fname)


def _profile_edge_count(spline) -> int:
    from corr_cad.export.step_profile import profile_edge_spans

    return len(profile_edge_spans(spline))


def _box_corners(box: np.ndarray) -> np.ndarray:
    """The 8 corners (8, 3) of a box given as (2, 3) min / max corners."""
    idx = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    return box[idx, [0, 1, 2]]


def _placed_points(p, points: np.ndarray) -> np.ndarray:
    """``points`` (n, 3) of a part moved by placement ``p``: ``T(offset) . R(angle) . T(pre)``."""
    from corr_cad.geometry.kinematics import rotate_by_polar_angle

    xy = rotate_by_polar_angle(points[:, :2] + np.asarray(p.pre_offset, dtype=float), p.angle_rad)
    return np.column_stack([xy, points[:, 2]]) + np.asarray(p.offset, dtype=float)


def _interference(ctx: RunContext) -> None:
    from corr_cad.export import mesh, plots
    from corr_cad.export.files import write_csv
    from corr_cad.geometry.parts import roller_outline

    s = ctx.scene
    d = s.design
    tol = s.chord_tolerance
    solids = ctx.results.solids
    stack = mesh.frame_stack(d, solids["frame"])
    pieces = mesh.frame_pieces(d, stack)
    errs = s.errors.roller_errors(d.roller_count)
    cache: dict[float, object] = {}
    rollers = []
    for de in errs:
        if de not in cache:
            cache[de] = mesh.solid(roller_outline(d, float(de), tol)) if de else solids["roller"]
        rollers.append(cache[de])
    allowance = interference_allowance(d, tol)
    from corr_cad.run.stages.stages_bearing_parts import contact_allowances, needle_rows_of

    rows_b = needle_rows_of(ctx)
    contacts = None if rows_b is None else contact_allowances(d, rows_b, tol)
    n = s.positions_for("mesh")
    angles = np.arange(n) * 360.0 / n
    rows = []
    pairs_checked, overlaps = 0, []
    # A cam's bore on its shaft: a sliver at most chord_tolerance deep (mesh._FITS).
    fit = tol * 2 * math.pi * d.cam_bore_radius * d.face_width if rows_b is None else 0.0
    from corr_cad.run.progress import Progress

    bar = Progress(
        n, "      interference", "positions", expected=expected_seconds(ctx, "interference")
    )
    for k, ang in enumerate(angles):
        if rows_b is None:
            asm = mesh.assembly(
                d, solids, math.radians(ang), roller_solids=rollers, stack=stack, pieces=pieces
            )
            every = asm.all_solids()
        else:  # the needles, the crankshaft and (with [first_stage]) the first stage too
            every, asm = _placed_solids(
                ctx, solids, float(ang), roller_solids=rollers, stack=stack, pieces=pieces
            )
        for rec in mesh.interference_at(asm, search_length=max(0.1, 50 * tol)):
            rows.append({"crank_angle_deg": float(ang), **rec})
        checked, found = mesh.solid_overlaps(every, fit_allowance_mm3=fit, contacts=contacts)
        pairs_checked += checked
        overlaps += [{"crank_angle_deg": float(ang), **o} for o in found]
        bar.update(1)
    bar.close()
    parts = ("ring", "cam", "frame")
    header = ["crank_angle_deg", "row", "roller"] + [
        f"{p}_{q}" for p in parts for q in ("volume", "gap")
    ]
    write_csv(
        ctx.out / "interference.csv",
        header,
        (
            [f"{r['crank_angle_deg']:.6f}", r["row"], r["roller"]]
            + [f"{r[h]:.9g}" for h in header[3:]]
            for r in rows
        ),
    )
    bad = [
        {"crank_angle_deg": r["crank_angle_deg"], "row": r["row"], "roller": r["roller"], "part": p}
        for r in rows
        for p in parts
        if r[f"{p}_volume"] > allowance[p]["volume_mm3"] or r[f"{p}_gap"] > allowance[p]["gap_mm"]
    ]
    summary = {
        "positions": n,
        "ok": not bad and not overlaps,
        "allowance": allowance,
        # Every other pair of solids (the two rows' rollers in one slot, rings,
        # cams, plates): intersection volume above mesh.OVERLAP_VOLUME_TOL.
        "other_pairs": {
            "pairs_checked": pairs_checked,
            **(
                {}
                if contacts is None
                else {
                    "needle_contact_allowance_mm3": {
                        f"{a}*/{b}": v for (a, b), v in contacts.items()
                    }
                }
            ),
            "volume_tol_mm3": mesh.OVERLAP_VOLUME_TOL,
            "overlaps": len(overlaps),
            "first_overlaps": overlaps[:20],
        },
        "max_volume_mm3": {p: max(r[f"{p}_volume"] for r in rows) for p in parts},
        "max_gap_mm": {p: max(r[f"{p}_gap"] for r in rows) for p in parts},
        "violations": len(bad),
        "first_violations": bad[:20],
    }
    if s.interference_method == "both":
        summary["agreement_with_exact"] = _agreement(ctx, angles, rows, allowance, tol)
    plots.interference_png(
        angles, rows, parts, allowance, ctx.out / "interference.png", d, summary["ok"]
    )
    ctx.files.extend(["interference.csv", "interference.png"])
    ctx.manifest["interference"] = summary
    ctx.results.interference = summary


#: Crank positions x rollers of the exact clearance computed (and written) at a
#: time: about 400 bytes a cell while it is computed, so 40 MB whatever the
#: scene; only the per-position envelope (32 bytes a position and contact) is kept.
CLEARANCE_CHUNK_CELLS = 100_000


def _clearance(ctx: RunContext) -> None:
    from corr_cad.export import plots
    from corr_cad.export.files import atomic_writer, format_columns
    from corr_cad.geometry.clearance import COLUMNS, Clearance, clearance, merge_summaries
    from corr_cad.run.progress import Progress

    s = ctx.scene
    info = ctx.results.undercut
    psi_end = math.radians(info.trimmed_psi_deg) if info.undercut and info.trimmed_psi_deg else None
    n = s.positions_for("exact")
    angles = 2.0 * np.pi * np.arange(n) / n
    # The designed clearance is the exact distance to the modified profile,
    # so the errors here are the scene's own (no modification gap added).
    profile = modified_curve(ctx)
    rows = clearance_rows(ctx)
    chunk = max(1, CLEARANCE_CHUNK_CELLS // s.design.roller_count)
    R = s.design.roller_count
    drive = len(rows) > 1
    columns = (COLUMNS[0], "row", *COLUMNS[1:]) if drive else COLUMNS
    fmts = ("%.6f", "%s", "%d") + ("%.9g",) * 4 if drive else ("%.6f", "%d") + ("%.9g",) * 4
    summaries: dict[str, list] = {row: [] for row in rows}
    envelopes: dict[str, list] = {row: [] for row in rows}
    bar = Progress(
        n * len(rows), "      clearance", "positions", expected=expected_seconds(ctx, "clearance")
    )
    with atomic_writer(ctx.out / "clearance.csv") as f:
        f.write(",".join(columns) + "\n")
        for row, (errors, turn) in rows.items():
            for a in range(0, n, chunk):
                clr = clearance(s.design, angles[a : a + chunk] + turn, errors, psi_end, profile)
                clr.crank_angles = angles[a : a + chunk]  # the drive's crank angle (row A's)
                cols = clr.columns()
                if drive:
                    cols["row"] = np.full(len(clr.crank_angles) * R, row)
                f.write(format_columns([cols[c] for c in columns], fmts))
                summaries[row].append(clr.summary())
                envelopes[row].append(clr.envelope())
                bar.update(len(clr.crank_angles))
    bar.close()
    env = {row: Clearance.concatenate(e) for row, e in envelopes.items()}
    every = [p for parts in summaries.values() for p in parts]
    summary = {"method": "exact", **merge_summaries(every), "positions": n}
    note = ""
    if drive:
        summary["rows"] = {row: merge_summaries(parts) for row, parts in summaries.items()}
        summary.update(_free_play(ctx))
        note = summary.get("free_play_note", "")
    plots.clearance_png(
        env["A"] if drive else env[""],
        ctx.out / "clearance.png",
        s.design,
        env if drive else None,
        summary,
        note,
    )
    ctx.files.extend(["clearance.csv", "clearance.png"])
    if s.first_stage is not None:
        from corr_cad.geometry.first_stage_parts import mesh_clearance
        from corr_cad.run.stages.stages_first_stage import gear_outlines

        verts = {k: o.vertices for k, o in gear_outlines(ctx, s.tolerance).items()}
        summary["first_stage"] = mesh_clearance(s.design, s.first_stage, verts)
    ctx.manifest["clearance"] = summary
    ctx.results.clearance = env["A"] if drive else env[""]


def clearance_rows(ctx: RunContext) -> dict:
    """``{row: (errors, crank turn)}`` of the exact clearance: the paper's one row (``""``),
    or the drive's rows A and B (row B's geometry is the one-row geometry half a turn on,
    with ``[errors.row_b]`` and the cam phase error; ``mechanics.drive.drive.row_errors``)."""
    s = ctx.scene
    if not s.solver.drive:
        return {"": (raw_errors(ctx), 0.0)}
    from dataclasses import replace

    from corr_cad.mechanics.drive.drive import row_errors

    eb = getattr(s, "errors_b", None)
    if eb is not None and ctx.results.registration_b is not None:
        eb = replace(eb, profile_deviation=ctx.results.registration_b.deviation)
    a, b = row_errors(raw_errors(ctx), eb)
    return {"A": (a, 0.0), "B": (b, math.pi)}


def _free_play(ctx: RunContext) -> dict:
    """The drive's eccentric bearings' free play (half each diametral clearance: how far a
    cam moves on its needles) and the drive's free rotation at the output where this run
    solved it (the datasheet's backlash, or the force solve's), which includes that play."""
    from corr_cad.figure_text import figure
    from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD

    s = ctx.scene
    out: dict = {}
    bearings = {"A": s.bearing, "B": s.bearing_b if s.bearing_b is not None else s.bearing}
    play = {
        row: 0.5 * b.diametral_clearance if b is not None else None for row, b in bearings.items()
    }
    out["bearing_free_play_mm"] = play
    ds, drive = ctx.results.datasheet, ctx.results.drive
    if ds is not None:
        bl = float(ds.backlash().max() * ARCMIN_PER_RAD)
        out["drive_backlash_arcmin"] = {"value": bl, "source": "datasheet (backlash_arcmin.max)"}
    elif drive is not None:
        bl = float(drive.backlash.max() * ARCMIN_PER_RAD)
        out["drive_backlash_arcmin"] = {"value": bl, "source": "forces (the drive's free turn)"}
    if all(v is None for v in play.values()):
        text = "cams fixed on the crank (no bearing play)"
    else:
        got = {row: v for row, v in play.items() if v is not None}
        moves = (
            f"each cam moves {figure(1e3 * got['A'])} um"
            if len(set(got.values())) == 1 and len(got) == 2
            else ", ".join(f"cam {row} moves {figure(1e3 * v)} um" for row, v in got.items())
        )
        text = f"eccentric bearings (not in the panels): {moves} on its needles (Pd / 2)"
    if "drive_backlash_arcmin" in out:
        text += (
            f"; the drive's free rotation, bearings included: "
            f"{figure(out['drive_backlash_arcmin']['value'])} arcmin at the output"
        )
    out["free_play_note"] = text
    return out


def _agreement(ctx: RunContext, angles_deg, rows, allowance, tol: float) -> dict:
    """Do the mesh booleans and the exact clearances agree, within the tessellation allowance?

    Compared for row A at the mesh positions, with the errors the mesh models
    (the roller radii). A contact agrees when: an exact clearance beyond the
    gap allowance shows no mesh overlap beyond the volume allowance; a mesh
    overlap beyond the volume allowance has a negative exact clearance; an
    exact interference beyond the gap allowance shows a mesh overlap; and a
    positive exact clearance within the search length matches the mesh gap
    to the gap allowance.
    """
    from corr_cad.geometry.clearance import clearance
    from corr_cad.geometry.deviations import ManufacturingErrors

    d = ctx.scene.design
    err = ctx.scene.errors
    mesh_errors = ManufacturingErrors(
        roller_radius_error=err.roller_radius_error, roller_radius_errors=err.roller_radius_errors
    )
    clr = clearance(
        d, np.radians(np.asarray(angles_deg, dtype=float)), mesh_errors, profile=modified_curve(ctx)
    )
    index = {float(a): k for k, a in enumerate(angles_deg)}
    search = max(0.1, 50 * tol)
    exact_of = {"ring": clr.ring, "cam": clr.cam, "frame": clr.slot}
    bad, compared = [], 0
    for r in rows:
        if r["row"] != "a":
            continue
        k, i = index[r["crank_angle_deg"]], r["roller"] - 1
        for part, ex in exact_of.items():
            c = float(ex[k, i])
            vol, gap = r[f"{part}_volume"], r[f"{part}_gap"]
            g_allow, v_allow = allowance[part]["gap_mm"], allowance[part]["volume_mm3"]
            ok = not (c > g_allow and vol > v_allow)
            ok &= not (vol > v_allow and c >= 0)
            ok &= not (c < -g_allow and vol <= 0)
            if 0 <= c < search and vol <= 0:
                ok &= abs(gap - c) <= g_allow
            compared += 1
            if not ok:
                bad.append(
                    {
                        "crank_angle_deg": r["crank_angle_deg"],
                        "roller": r["roller"],
                        "part": part,
                        "exact_clearance_mm": c,
                        "mesh_volume_mm3": vol,
                        "mesh_gap_mm": gap,
                    }
                )
    return {"agree": not bad, "contacts_compared": compared, "disagreements": bad[:20]}


def interference_allowance(design, chord_tol: float) -> dict:
    """What tessellation alone can produce at a tangent contact, per part.

    Both meshes may miss the exact surface by up to ``chord_tol``, so a
    nominal tangent contact can show a penetration ``d = 2 chord_tol`` (a lens
    of area ``4/3 d sqrt(2 R* d)`` over the contact length) or a gap of
    ``d``. ``R*`` is the largest effective radius of the contact (the most
    conformal point of the gear flank).
    """
    from corr_cad.geometry import kinematics as kin
    from corr_cad.geometry.parts import roller_solid_length

    r = design.roller_radius
    dpen = 2.0 * chord_tol
    gap = dpen + 1e-7  # plus manifold3d's own arithmetic precision
    psi = np.linspace(0, 2 * np.pi, 4001)
    k_l = kin.locus_curvature(psi, design.tooth_count, design.eccentricity, design.link_length)
    k_gear = -k_l / (1 + r * k_l)
    r_ring = 1.0 / np.min(1.0 / r + k_gear)
    r_cam = 1.0 / (1.0 / r + 1.0 / design.cam_radius)

    def lens(R, length):
        return 4.0 / 3.0 * dpen * math.sqrt(2.0 * R * dpen) * length

    return {
        "ring": {"volume_mm3": lens(r_ring, design.face_width), "gap_mm": gap},
        "cam": {"volume_mm3": lens(r_cam, design.face_width), "gap_mm": gap},
        # Through the outer plate and half the middle one (parts.roller_solid_length).
        "frame": {
            "volume_mm3": lens(r, roller_solid_length(design) - design.face_width),
            "gap_mm": gap,
        },
    }
