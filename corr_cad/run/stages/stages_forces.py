"""Pipeline stages for the mesh forces: the solve, its files and the design checks.

Registered in :data:`corr_cad.run.stages.stages.STAGES`.
"""

from __future__ import annotations

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics.row.solver import solve_forces
from corr_cad.run.stages.context import RunContext, psi_contact_limit, scene_errors


def _solve(ctx: RunContext, design, input_torque: float, psi_limit: float):
    """One force solve with the scene's solver settings and errors."""
    s = ctx.scene
    angles = (
        np.radians(np.asarray(s.solver.crank_angles_deg, dtype=float))
        if s.solver.crank_angles_deg is not None
        else None
    )
    return solve_forces(
        design,
        input_torque,
        angles,
        positions=s.solver.positions,
        load_share=s.solver.load_share,
        errors=scene_errors(ctx),
        variants=s.solver.variants,
        contact_model=s.solver.contact_model,
        psi_contact_limit=psi_limit,
    )


def _forces(ctx: RunContext) -> None:
    s = ctx.scene
    if s.solver.drive:
        from corr_cad.run.stages.stages_drive import drive_forces

        drive_forces(ctx, psi_contact_limit(ctx))
        return
    res = _solve(ctx, s.design, s.load.input_torque, psi_contact_limit(ctx))
    if not res.success:
        raise SolverError(f"force solver: {res.message}")
    ctx.results.forces = res


def _force_files(ctx: RunContext) -> None:
    from corr_cad.export import plots
    from corr_cad.export.files import write_columns, write_json
    from corr_cad.run.console import force_peaks

    if ctx.results.drive is not None:
        from corr_cad.run.stages.stages_drive import drive_force_files

        drive_force_files(ctx)
        return
    res = ctx.results.forces
    s = ctx.scene
    from corr_cad.run.stages.stages_drive import ROLLER_COLUMNS, roller_columns

    P, R = res.F_j.shape
    ang = np.degrees(res.crank_angles)
    cols = [np.repeat(ang, R), *roller_columns(res)]
    header = ["crank_angle_deg", *ROLLER_COLUMNS]
    write_columns(ctx.out / "forces.csv", header, cols, ("%.6f", "%d", "%.6f") + ("%.9g",) * 6)
    summary = res.summary()
    summary["roller"] = 1  # the means and peaks above are roller 1's; "peak" is the drive's
    summary["peak"] = force_peaks(res, s.design)
    summary["solver"] = {
        "success": res.success,
        "message": res.message,
        "iterations": res.iterations,
        "moment_residual": res.moment_residual,
        "positions": P,
        "positions_solved": res.positions_solved,
        "full_cycle": res.full_cycle,
        "input_torque_Nmm": s.load.input_torque,
        "cam_moment_Nmm": res.cam_moment,
        "load_share": s.solver.load_share,
        "variants": list(s.solver.variants),
        "contacts_outside_validity": int(np.count_nonzero(~res.valid & res.loaded)),
        "output_torque_Nmm_mean": float(res.output_torque.mean()),
    }
    write_json(ctx.out / "forces_summary.json", summary)
    plots.forces_png(res, ctx.out / "forces.png", s.design, s.load.input_torque)
    # The load distribution where the gear force peaks.
    at = int(np.unravel_index(np.argmax(res.F_n), res.F_n.shape)[0])
    plots.load_distribution_png(
        s.design,
        float(ang[at]),
        res.F_j[at],
        res.F_n[at],
        res.F_s[at],
        ctx.out / "load_distribution.png",
        s.load.input_torque,
        " (peak $F_n$)",
    )
    ctx.files.extend(["forces.csv", "forces_summary.json", "forces.png", "load_distribution.png"])
    ctx.manifest["forces"] = {k: v for k, v in summary.items() if k != "solver"}


def check_values(res) -> dict[str, float]:
    """The check metrics of one force solution (the names of ``CHECK_METRICS``)."""
    from corr_cad.tolerance.checks import ARCMIN_PER_RAD

    return {
        "peak_gear_force": float(res.F_n.max()),
        "peak_pressure": float(np.maximum(np.maximum(res.p_cam, res.p_slot), res.p_gear).max()),
        "min_loaded_rollers": float(res.loaded_count.min()),
        "backlash_arcmin": float(res.backlash.max() * ARCMIN_PER_RAD),
    }


def _checks(ctx: RunContext) -> None:
    from corr_cad.figure_text import figure
    from corr_cad.tolerance.checks import CHECK_METRICS, evaluate_checks

    if ctx.results.drive is not None:
        from corr_cad.run.stages.stages_drive import drive_check_values

        values = drive_check_values(ctx.results.drive, check_values)
    else:
        values = check_values(ctx.results.forces)
    if ctx.results.datasheet is not None:
        values.update(ctx.results.datasheet.check_values())
    if ctx.results.friction is not None:
        values.update(ctx.results.friction.check_values())
    whole = {}
    if ctx.scene.first_stage is not None:
        from corr_cad.run.stages.stages_first_stage import first_stage_shares, whole_drive_values

        whole = whole_drive_values(values, first_stage_shares(ctx))
        values.update({k: v["value"] for k, v in whole.items()})
    report = evaluate_checks(values, ctx.scene.checks)
    for name, r in report.items():
        part = whole.get(CHECK_METRICS[name][0])
        if part is not None:
            r["figure"] = part["figure"]
            r["second_stage"], r["first_stage"] = part["second_stage"], part["first_stage"]
    ctx.manifest.setdefault("checks", {}).update(report)
    for name, r in report.items():
        state = "pass" if r["passed"] else "FAIL"
        nums = (
            f"value {figure(r['value'])}, limit {figure(r['limit'])}, margin {figure(r['margin'])}"
        )
        if "first_stage" in r:
            nums += (
                f"; whole drive: second stage {figure(r['second_stage'])}, first stage "
                f"{figure(r['first_stage'])}"
            )
        ctx.progress(f"      check {name}: {state} ({nums})")
        if name == "min_torsional_rigidity_Nm_per_arcmin" and not ctx.scene.solver.drive:
            from corr_cad.run.console import PAPER_RIGIDITY_NOTE

            ctx.progress(f"      {PAPER_RIGIDITY_NOTE}")
    # The remedy search re-solves the forces only: datasheet figures get none, nor the
    # whole drive's (the second stage's alone would be judged).
    sheet = ctx.scene.checks.datasheet_active()
    failed = [
        name
        for name, r in report.items()
        if not r["passed"] and name not in sheet and "first_stage" not in r
    ]
    if failed:
        _what_passes(ctx, failed)


#: The design inputs a scene built without a source (the API) is rebuilt from.
_DESIGN_INPUTS = (
    "tooth_count",
    "cam_radius",
    "roller_radius",
    "roller_length",
    "eccentricity",
    "allow_undercut",
)


def _what_passes(ctx: RunContext, failed: list[str]) -> None:
    """Record and show, per failed check, the nearest single-parameter change that passes."""
    import math

    from corr_cad.geometry.profile import undercut_analysis
    from corr_cad.tolerance.remedy import check_remedies

    s = ctx.scene

    def metrics(design, input_torque: float) -> dict[str, float]:
        info = undercut_analysis(design)
        trimmed = info.undercut and info.trimmed_psi_deg
        limit = math.radians(info.trimmed_psi_deg) if trimmed else math.pi
        if s.solver.drive:
            from corr_cad.run.stages.stages_drive import drive_check_values, solve_scene_drive

            dres = solve_scene_drive(ctx, design, input_torque, limit)
            if dres.success:
                return drive_check_values(dres, check_values)
            res = dres.rows[0]
        else:
            res = _solve(ctx, design, input_torque, limit)
        if not res.success:
            return {k: math.nan for k in ("peak_gear_force", "peak_pressure")} | {
                "min_loaded_rollers": -1.0,
                "backlash_arcmin": math.inf,
            }
        return check_values(res)

    remedies = check_remedies(
        s.design,
        dict(s.source.get("design") or {k: getattr(s.design, k) for k in _DESIGN_INPUTS}),
        s.load.input_torque,
        s.checks,
        failed,
        metrics,
        progress=ctx.progress,
    )
    for name, found in remedies.items():
        ctx.manifest["checks"][name]["passes_with"] = [r.as_dict() for r in found]
        text = " or ".join(r.text() for r in found) if found else "no single change found"
        ctx.progress(f"      {name} passes with {text}")
