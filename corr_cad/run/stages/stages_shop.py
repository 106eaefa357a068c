"""Pipeline stages for the shop floor and the inspection lab (issue 12).

``edm_files`` (format ``edm``), ``cmm_points`` (``cmm``) and ``inspection``
(``inspection``, needs ``[errors] measured_profile``, or ``[errors.row_b]``'s with
``[inspection] row = "b"``). Registered in
``corr_cad.run.stages.stages.STAGES``; kept here so that the stage graph stays readable.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.run.stages.context import (
    RunContext,
    drive_kwargs,
    modified_curve,
    psi_contact_limit,
    scene_errors,
)

__all__ = ["edm_files", "cmm_points", "inspection", "predicted_line"]

_PLAY = ("backlash_arcmin", "lost_motion_arcmin", "transmission_error_arcsec")


def edm_files(ctx: RunContext) -> None:
    from corr_cad.export.edm_io import write_edm_dxf
    from corr_cad.export.gcode import DIALECTS, GcodeOptions, write_gcode
    from corr_cad.geometry.modification import describe_profile, profile_record
    from corr_cad.shop.edm import EdmSpec, plan_cut

    s = ctx.scene
    e = s.edm
    dialect = DIALECTS[e["dialect"]]
    slug = e["slug_stop_mm"] if e["slug_stop_mm"] is not None else dialect.slug_stop_mm
    spec = EdmSpec(
        wire_diameter=e["wire_diameter"],
        spark_gap=e["spark_gap"],
        start_hole_diameter=e["start_hole_diameter"],
        lead_in_length=e["lead_in_length"],
        feed_mm_per_min=e["feed_mm_per_min"],
        compensation=e["compensation"],
        slug_stop_mm=slug,
    )
    options = GcodeOptions(
        dialect=dialect.name,
        d_register=e["d_register"],
        program_number=e["program_number"],
        wire_thread_mcode=e["wire_thread_mcode"],
        wire_cut_mcode=e["wire_cut_mcode"],
    )
    # I and J words beyond the control's range: nearly straight arcs, written as lines.
    reach = dialect.max_abs - 10.0 ** (1 - dialect.max_decimals)
    # The lead-in reuses the forces this run solved (format "forces"); without them it
    # goes to the tooth tip by geometry: the EDM stage never solves forces itself.
    profile = describe_profile(s.design, s.modification)
    prog, _ = plan_cut(
        ctx.results.working, spec, s.tolerance, ctx.results.forces, reach, profile=profile
    )
    write_edm_dxf(s.design, prog, ctx.out / "inner_gear_edm.dxf")
    write_gcode(s.design, prog, s.name, ctx.out / "inner_gear_edm.nc", options)
    ctx.files.extend(["inner_gear_edm.dxf", "inner_gear_edm.nc"])
    ctx.manifest["edm"] = prog.as_dict()
    ctx.manifest["edm"]["profile"] = profile_record(s.design, s.modification)
    ctx.manifest["edm"]["gcode"] = {
        "dialect": dialect.name,
        "coordinate_decimals": prog.decimals,
        **({"d_register": options.d_register} if spec.compensation != "path" else {}),
        **({"program_number": options.program_number} if dialect.program_number else {}),
        "wire_thread_mcode": options.wire_thread_mcode,
        "wire_cut_mcode": options.wire_cut_mcode,
    }
    where = "into the opening" if spec.compensation == "path" else f"by {spec.compensation}"
    ctx.progress(
        f"      wire path ({dialect.name}): offset {spec.offset:g} mm {where}, "
        f"{len(prog.contour)} moves, measured deviation {prog.written_deviation:.3g} mm; "
        f"lead-in at the {prog.lead_in_point['where']}"
    )


def cmm_points(ctx: RunContext) -> None:
    from corr_cad.export.inspection_io import write_nominal_csv
    from corr_cad.geometry.modification import describe_profile, profile_record
    from corr_cad.geometry.projection import arc_length_parameters

    s = ctx.scene
    w = ctx.results.working
    z = w.tooth_count
    pitch = 2 * math.pi / z
    t0, step, length = arc_length_parameters(
        w, -0.5 * pitch, 0.5 * pitch, s.inspection["point_spacing"]
    )
    t = np.concatenate([t0 + k * pitch for k in range(z)])
    tooth = np.repeat(np.arange(1, z + 1), len(t0))
    pts = w.points(t)
    normals = -w.normals(t)
    profile = describe_profile(s.design, s.modification)
    write_nominal_csv(tooth, t, pts, normals, ctx.out / "inner_gear_nominal.csv", profile)
    ctx.files.append("inner_gear_nominal.csv")
    ctx.manifest["cmm"] = {
        "profile": profile_record(s.design, s.modification),
        "points": int(len(t)),
        "points_per_tooth": int(len(t0)),
        "point_spacing_mm": step,
        "requested_spacing_mm": s.inspection["point_spacing"],
        "tooth_length_mm": length,
        "normal": "unit, from the ring material into the opening",
        "tooth": "tooth space k centred at polar angle (k - 1) 360/z deg, from tip to tip",
    }


def inspected_row(ctx: RunContext) -> str:
    """``[inspection] row``: ``"a"`` (the default) or ``"b"``."""
    return ctx.scene.inspection.get("row") or "a"


def _drive_prediction(ctx: RunContext, row: str):
    """Row A's errors and the drive's settings with the inspected ring measured in its row,
    the other ring and every other part nominal (with a ``[modification]``'s designed
    clearance in both rings)."""
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.run.stages.stages_datasheet import datasheet_errors, datasheet_errors_b

    s = ctx.scene
    other = ManufacturingErrors()
    if modified_curve(ctx) is not None:
        from corr_cad.geometry.modification import with_modification

        scene_errors(ctx)  # makes the designed clearance once
        other = with_modification(other, ctx.results.modification_gap)
    measured = datasheet_errors(ctx) if row == "a" else datasheet_errors_b(ctx)
    a, b = (measured, other) if row == "a" else (other, measured)
    return a, _with_crank(s, {"errors_b": b, "bearing": s.bearing, "bearing_b": s.bearing_b})


def _with_crank(scene, drive: dict) -> dict:
    """The drive's settings with ``[crankshaft]`` / ``[bearings.crank]`` where given."""
    if getattr(scene, "crank", None) is not None:
        drive["crank"] = scene.crank
    return drive


def _drive_ring(ctx: RunContext, row: str) -> dict:
    """Which ring the drive's prediction puts where: ``predicted["ring"]`` under the drive."""
    key = "measured_profile" if row == "a" else "measured_profile_b"
    reg = ctx.results.registration if row == "a" else ctx.results.registration_b
    m = ctx.manifest.get(key, {})
    return {
        "profile": "measured",
        "row": row,
        "file": m.get("source"),
        "sha256": m.get("sha256"),
        "registration": reg.as_dict(),
        "other_ring": "nominal",
        "other_parts": "nominal",
    }


def _predicted(ctx: RunContext) -> dict:
    """The measured ring's predicted backlash, lost motion and transmission error.

    The measured ring with nominal other parts (as the datasheet describes
    it), beside the nominal design, in catalogue units. From the datasheet
    when this run made it, else from five windup solves per ring
    (:func:`corr_cad.mechanics.datasheet.play_figures`). Lost motion and
    transmission error need the rated torque; backlash does not. Under
    ``model = "drive"`` the drive's figures, the measured ring in the row of
    ``[inspection] row``, the other ring nominal (never the datasheet's, which
    follows the scene's rows).
    """
    from corr_cad.mechanics.datasheet import DatasheetSpec, play_figures, span_errors
    from corr_cad.mechanics.row.windup import ARCMIN_PER_RAD, Windup, revolution_classes
    from corr_cad.run.stages.stages_datasheet import (
        datasheet_errors,
        datasheet_spec,
        ring_description,
    )

    s = ctx.scene
    row = inspected_row(ctx)
    drive = nominal_drive = None
    if s.solver.drive:
        errors, drive = _drive_prediction(ctx, row)
        nominal_drive = _with_crank(
            s, {"errors_b": None, "bearing": s.bearing, "bearing_b": s.bearing_b}
        )
    else:
        errors = datasheet_errors(ctx)
    common = {
        "load_share": s.solver.load_share,
        "variants": s.solver.variants,
        "psi_contact_limit": psi_contact_limit(ctx),
        "contact_model": s.solver.contact_model,
    }
    out: dict = {
        "ring": _drive_ring(ctx, row) if drive else ring_description(ctx),
        "convention": "output windup, input locked, ring fixed (see datasheet.json)",
    }
    if drive:
        out.update(model="drive", row=row, contact_law=s.solver.contact_law)
    if s.datasheet.get("rated_torque_Nm") is None and s.load is None:
        per_turn = s.datasheet.get("transmission_error_positions_per_turn", 360)
        for name, err, dk in (("measured", errors, drive), ("nominal", None, nominal_drive)):
            span = span_errors(s.design, err, dk, s.solver.variants) if dk else err
            x, _ = revolution_classes(s.design, per_turn, span, s.solver.variants)
            if dk is None:
                w = Windup(s.design, x, errors=err, **common)
            else:
                from corr_cad.mechanics.drive.drive_windup import DriveWindup

                kw = {k: v for k, v in common.items() if k != "load_share"}
                w = DriveWindup(s.design, x, errors=err, **kw, **dk)
            b = w.backlash() * ARCMIN_PER_RAD
            out[name] = {
                "backlash_arcmin": {
                    "min": float(b.min()),
                    "mean": float(b.mean()),
                    "max": float(b.max()),
                    "definition": "theta(0+) - theta(0-)",
                }
            }
        out["not_computed"] = (
            "lost motion and transmission error need the rated torque: set [load] "
            "input_torque (N*mm) or [datasheet] rated_torque_Nm"
        )
        return out
    spec: DatasheetSpec = datasheet_spec(s)
    ds = ctx.results.datasheet
    if ds is not None and drive is None:
        fig = ds.figures()
        out["measured"] = {k: fig[k] for k in _PLAY}
        out["measured_source"] = "datasheet.json (same figures)"
    else:
        out["measured"] = play_figures(s.design, spec, errors=errors, drive=drive, **common)
        out["measured_source"] = "windup at the transmission-error positions"
    out["nominal"] = play_figures(s.design, spec, errors=None, drive=nominal_drive, **common)
    out["rated_torque_Nm"] = spec.rated_torque / 1000.0
    return out


def predicted_line(p: dict) -> str:
    """The predicted figures in one console line.

    >>> predicted_line({"measured": {"backlash_arcmin": {"max": 0.5}}})
    'measured ring, other parts nominal: backlash 0.5 arcmin'
    """
    m = p["measured"]
    who = f"measured ring {p['row'].upper()} in the drive" if "row" in p else "measured ring"
    parts = [f"backlash {m['backlash_arcmin']['max']:.4g} arcmin"]
    if "lost_motion_arcmin" in m:
        parts.append(f"lost motion {m['lost_motion_arcmin']['max']:.4g} arcmin")
        te = m["transmission_error_arcsec"]
        parts.append(
            f"transmission error {te['forward_peak_to_peak']:.4g} / "
            f"{te['reverse_peak_to_peak']:.4g} arcsec (forward / reverse)"
        )
    return f"{who}, other parts nominal: " + ", ".join(parts)


def _force_comparison(ctx: RunContext) -> dict:
    from corr_cad.geometry.deviations import ManufacturingErrors
    from corr_cad.mechanics.row.solver import solve_forces

    s = ctx.scene
    if s.load is None:
        return {"computed": False, "reason": "no [load] input_torque"}
    angles = (
        np.radians(np.asarray(s.solver.crank_angles_deg, dtype=float))
        if s.solver.crank_angles_deg is not None
        else None
    )
    kw = {"positions": s.solver.positions, "load_share": s.solver.load_share}
    if s.solver.contact_model != "nonlinear":
        kw["contact_model"] = s.solver.contact_model
    nominal_errors = ManufacturingErrors()
    if s.modification is not None:  # the nominal is the modified design
        from corr_cad.geometry.modification import with_modification

        scene_errors(ctx)
        nominal_errors = with_modification(nominal_errors, ctx.results.modification_gap)
    includes = "the measured profile as a gear-contact gap, with the scene's other [errors]"
    if s.solver.drive:
        # The drive's forces; the inspected ring's row compared (the measured drive has the
        # scene's errors in both rows, as the forces stage solves it).
        from corr_cad.mechanics.drive.drive import solve_drive

        row = inspected_row(ctx)
        c = 0 if row == "a" else 1
        dk = drive_kwargs(ctx)
        dk.pop("errors"), dk.pop("errors_b")
        T, n = s.load.input_torque, s.solver.positions
        nom = solve_drive(
            s.design, T, angles, positions=n, errors=nominal_errors, errors_b=nominal_errors, **dk
        ).rows[c]
        both = ctx.results.drive or solve_drive(
            s.design, T, angles, positions=n, **drive_kwargs(ctx)
        )
        mea = both.rows[c]
        includes = f"the drive's row {row.upper()}, its ring measured; " + includes
    else:
        nom = solve_forces(s.design, s.load.input_torque, angles, errors=nominal_errors, **kw)
        mea = ctx.results.forces or solve_forces(
            s.design, s.load.input_torque, angles, errors=scene_errors(ctx), **kw
        )
    a, b = nom.summary(), mea.summary()
    rows = {}
    for key in ("F_j_mean", "F_j_peak", "F_n_peak", "p_max", "loaded_rollers_min"):
        rows[key] = {
            "nominal": a[key],
            "measured": b[key],
            "change_percent": 100.0 * (b[key] - a[key]) / a[key] if a[key] else None,
        }
    rows["F_n_peak_any_roller"] = {
        "nominal": float(nom.F_n.max()),
        "measured": float(mea.F_n.max()),
        "change_percent": 100.0 * (float(mea.F_n.max()) / float(nom.F_n.max()) - 1.0),
    }
    return {
        "computed": True,
        "input_torque_Nmm": s.load.input_torque,
        "positions": int(nom.F_j.shape[0]),
        "measured_includes": includes,
        "roller_1_and_all": rows,
    }


def inspection(ctx: RunContext) -> None:
    from corr_cad.export.inspection_io import inspection_png, verdict_line, write_inspection
    from corr_cad.geometry import kinematics as kin
    from corr_cad.geometry.modification import describe_profile
    from corr_cad.tolerance.inspection import (
        LIMITS,
        evaluate_limits,
        fit_design_family,
        inspect_teeth,
    )

    s = ctx.scene
    w = ctx.results.working
    row = inspected_row(ctx)
    reg = ctx.results.registration if row == "a" else ctx.results.registration_b
    raw = ctx.results.measured_points if row == "a" else ctx.results.measured_points_b
    against = None
    if s.modification is not None:
        against = s.source["modification"].get("inspect_against", "modified")
        if against == "conjugate":  # the conjugate profile as the nominal, registered to it
            from corr_cad.tolerance.measured import register

            w = ctx.results.conjugate
            reg = register(w, raw)
    datum = kin.rotate_by_polar_angle(raw, -math.radians(reg.rotation_deg))
    res = inspect_teeth(w, reg.placed, datum, s.inspection["evaluation_psi_deg"])
    limits = {k: s.inspection[k] for k in LIMITS}
    verdicts = evaluate_limits(res, limits)
    ctx.progress("      fitting e, L, phase and centre to the measured profile")
    fit = fit_design_family(w, raw)
    summary = {
        "nominal_profile": describe_profile(
            s.design, None if against == "conjugate" else s.modification
        ),
        "teeth": len(res.teeth),
        "registration": reg.as_dict(),
        "evaluation_psi_deg": s.inspection["evaluation_psi_deg"],
        "profile_deviation_max_mm": float(res.column("profile_deviation_mm").max()),
        "form_deviation_max_mm": float(res.column("form_deviation_mm").max()),
        "position_max_abs_arcsec": float(np.abs(res.column("position_arcsec")).max()),
        "single_pitch_max_abs_arcsec": float(np.abs(res.column("single_pitch_arcsec")).max()),
        "cumulative_pitch_total_arcsec": res.cumulative_pitch_total_arcsec,
        "cumulative_pitch_span_teeth": list(res.cumulative_pitch_span),
        "runout_mm": res.runout_mm,
        "limits": verdicts,
        "passed": all(v["passed"] for v in verdicts.values()),
        "design_fit": fit,
        "forces": _force_comparison(ctx),
        "predicted": _predicted(ctx),
        "definitions": "see README 'Inspection report' (ISO 1328-1 adapted)",
    }
    if against is not None:
        summary["nominal"] = f"{against} profile ([modification] inspect_against)"
    if s.solver.drive:  # which ring of the drive was measured (the paper's row has one)
        summary["model"], summary["row"] = "drive", row
    files = write_inspection(res, summary, ctx.out)
    inspection_png(res, limits, verdicts, ctx.out / "inspection.png", s.design)
    ctx.files.extend(files + ["inspection.png"])
    ctx.manifest["inspection"] = {
        k: summary[k]
        for k in ("nominal_profile", "passed", "limits", "profile_deviation_max_mm", "runout_mm")
        + ("cumulative_pitch_total_arcsec", "predicted")
    }
    ctx.manifest["inspection"]["failed"] = [
        f"{k} tooth {v['tooth']} value {v['value']:.6g} {v['unit']} > {v['limit']:g} "
        f"(failing teeth {', '.join(str(j) for j in v['failing_teeth'])})"
        for k, v in verdicts.items()
        if not v["passed"]
    ]
    for k, v in verdicts.items():
        ctx.progress(f"      inspection {verdict_line(k, v)}")
    ctx.progress(f"      {predicted_line(summary['predicted'])}")
