"""Pipeline stages for the mesh forces: the solve, its files and the design checks.

Registered in :data:`corr_cad.run.stages.STAGES`.
"""

from __future__ import annotations

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics.solver import solve_forces
from corr_cad.run.context import RunContext, psi_contact_limit, scene_errors


def _forces(ctx: RunContext) -> None:
    s = ctx.scene
    limit = psi_contact_limit(ctx)
    angles = (
        np.radians(np.asarray(s.solver.crank_angles_deg, dtype=float))
        if s.solver.crank_angles_deg is not None
        else None
    )
    res = solve_forces(
        s.design,
        s.load.input_torque,
        angles,
        positions=s.solver.positions,
        load_share=s.solver.load_share,
        errors=scene_errors(ctx),
        variants=s.solver.variants,
        psi_contact_limit=limit,
    )
    if not res.success:
        raise SolverError(f"force solver: {res.message}")
    ctx.results.forces = res


def _force_files(ctx: RunContext) -> None:
    from corr_cad.export import plots
    from corr_cad.export.files import write_columns, write_json
    from corr_cad.run.console import force_peaks

    res = ctx.results.forces
    s = ctx.scene
    P, R = res.F_j.shape
    ang = np.degrees(res.crank_angles)
    psi = np.degrees(np.mod(res.psi, 2 * np.pi))
    cols = [
        np.repeat(ang, R),
        np.tile(np.arange(1, R + 1), P),
        psi.ravel(),
        res.F_j.ravel(),
        res.F_s.ravel(),
        res.F_n.ravel(),
        res.p_cam.ravel(),
        res.p_slot.ravel(),
        res.p_gear.ravel(),
    ]
    header = [
        "crank_angle_deg",
        "roller",
        "psi_deg",
        "F_j",
        "F_s",
        "F_n",
        "p_cam",
        "p_slot",
        "p_gear",
    ]
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


def _checks(ctx: RunContext) -> None:
    from corr_cad.tolerance.checks import ARCMIN_PER_RAD, evaluate_checks

    res = ctx.results.forces
    values = {
        "peak_gear_force": float(res.F_n.max()),
        "peak_pressure": float(np.maximum(np.maximum(res.p_cam, res.p_slot), res.p_gear).max()),
        "min_loaded_rollers": float(res.loaded_count.min()),
        "lost_motion_arcmin": float(res.lost_motion.max() * ARCMIN_PER_RAD),
    }
    report = evaluate_checks(values, ctx.scene.checks)
    ctx.manifest.setdefault("checks", {}).update(report)
    for name, r in report.items():
        state = "pass" if r["passed"] else "FAIL"
        nums = f"value {r['value']:.4g}, limit {r['limit']:.4g}, margin {r['margin']:.4g}"
        ctx.progress(f"      check {name}: {state} ({nums})")
