"""The force stage under ``[solver] model = "drive"``: both rows' solve and its files.

Called from :mod:`corr_cad.run.stages.stages_forces` when the scene's model is the drive.
"""

from __future__ import annotations

import numpy as np

from corr_cad.errors import SolverError
from corr_cad.mechanics.drive.drive import DriveResult, solve_drive
from corr_cad.run.stages.context import RunContext, drive_kwargs

__all__ = [
    "drive_forces",
    "drive_force_files",
    "drive_check_values",
    "model_description",
    "samples_chain",
]

ROWS = ("A", "B")


def model_description(scene, tables=None) -> dict:
    """The model, the contact law and the bearings as the files state them."""
    sv = scene.solver
    out = {
        "model": sv.model,
        "contact_law": sv.contact_law,
        "bearing": scene.bearing.as_dict() if scene.bearing is not None else "none (cams fixed)",
    }
    if scene.bearing_b is not None and scene.bearing_b != scene.bearing:
        out["bearing_b"] = scene.bearing_b.as_dict()
    crank = getattr(scene, "crank", None)
    if crank is not None:  # [crankshaft] / [bearings.crank]: the keys appear with them only
        out["crank"] = crank.as_dict()
        out["compliances"] = compliances(scene)
    if sv.bodies == "elastic":  # absent under rigid bodies: those files keep their bytes
        from corr_cad.run.stages.stages_bodies import bodies_description

        out["bodies"] = bodies_description(tables, with_crank=crank is not None)
    return out


def samples_chain(s) -> str | None:
    """What the samples solve beyond the contacts and bearings, as the files state it
    (``samples_chain``; None where the chain is the contacts and bearings alone)."""
    crank = getattr(s, "crank", None) is not None
    bodies = s.solver.bodies == "elastic"
    if not (crank or bodies):
        return None
    parts = []
    if crank:
        parts.append(
            "the crankshaft on its support bearings as [crankshaft] and [bearings.crank] give "
            "it (one shaft for every sample)"
        )
    if bodies:
        parts.append(
            "the elastic ring, frame and cams by the nominal design's influence tables "
            "(reduced once per design, never per sample), applied to each sample's perturbed "
            "drive: its errors move the gaps by micrometres, not the bodies' shape (a "
            "small-perturbation choice; its size measured in the manual's physics)"
        )
    return "every sample solved on the nominal drive's chain: " + "; ".join(parts)


def compliances(scene) -> dict:
    """Which compliances of the load path the drive's figures hold, and which not."""
    crank = scene.crank
    inside = ["contacts: cam, ring and slot of every roller (both rows)"]
    inside.append(
        "needle bearings of the cams" if scene.bearing is not None else "none: cams fixed"
    )
    inside.append("crankshaft: bending, shear and torsion (Timoshenko beam)")
    if crank.bearing is not None:
        inside.append(f"support bearings of the crankshaft ({crank.bearing.type})")
    outside = ["first stage", "output bearings and housing"]
    if scene.solver.bodies == "elastic":
        inside.append("gear ring body, frame body and cam body (plane-stress FE)")
    else:
        outside[:0] = ["ring body (rigid)", "frame (rigid)"]
    if crank.bearing is None:
        outside.insert(0, "support bearings (rigid)")
    return {"in_figure": inside, "not_in_figure": outside}


def solve_scene_drive(ctx: RunContext, design, input_torque: float, psi_limit: float):
    """One drive solve with the scene's settings (both rows)."""
    s = ctx.scene
    kw = drive_kwargs(ctx)
    kw["psi_contact_limit"] = psi_limit
    angles = (
        np.radians(np.asarray(s.solver.crank_angles_deg, dtype=float))
        if s.solver.crank_angles_deg is not None
        else None
    )
    return solve_drive(design, input_torque, angles, positions=s.solver.positions, **kw)


def drive_forces(ctx: RunContext, psi_limit: float) -> None:
    s = ctx.scene
    res = solve_scene_drive(ctx, s.design, s.load.input_torque, psi_limit)
    if not res.success:
        raise SolverError(f"drive solver: {res.message}")
    ctx.results.drive = res
    ctx.results.forces = res.rows[0]


def _stats(v: np.ndarray) -> dict:
    v = np.asarray(v, dtype=float).reshape(-1)
    return {"min": float(v.min()), "mean": float(v.mean()), "max": float(v.max())}


def drive_check_values(res: DriveResult, check_values) -> dict[str, float]:
    """The check metrics over both rows (names of ``CHECK_METRICS``), ``check_values`` of
    each row's :class:`~corr_cad.mechanics.row.solver.ForceResult` combined."""
    from corr_cad.tolerance.checks import ARCMIN_PER_RAD

    per_row = [check_values(r) for r in res.rows]
    return {
        "peak_gear_force": max(v["peak_gear_force"] for v in per_row),
        "peak_pressure": max(v["peak_pressure"] for v in per_row),
        "min_loaded_rollers": min(v["min_loaded_rollers"] for v in per_row),
        # The drive's own free rotation: both rows' intersection, with the bearings.
        "backlash_arcmin": float(res.backlash.max() * ARCMIN_PER_RAD),
    }


def heavier_row(res: DriveResult) -> int:
    """Index of the row with the larger peak gear force ``F_n`` (the drive's governing load);
    on a tie (to 1e-9 relative) the row carrying the larger mean share of the crank moment,
    then row A."""
    peaks = [float(r.F_n.max()) for r in res.rows]
    shares = [float(np.mean(res.row_a_share)), float(np.mean(1.0 - res.row_a_share))]
    for a, b in (peaks, shares):
        if abs(b - a) > 1e-9 * max(abs(a), abs(b)):
            return int(b > a)
    return 0


def drive_force_files(ctx: RunContext) -> None:
    """``forces.csv`` (a row per position, row and roller), ``forces_summary.json`` per row."""
    from corr_cad.export import plots
    from corr_cad.export.files import write_columns, write_json
    from corr_cad.run.console import force_peaks

    res: DriveResult = ctx.results.drive
    s = ctx.scene
    _, P, R = res.F_j.shape
    ang = np.degrees(res.crank_angles)
    cols: list = [[] for _ in range(13)]
    for i, row in enumerate(res.rows):
        share = res.row_a_share if i == 0 else 1.0 - res.row_a_share
        parts = [
            np.repeat(ang, R),
            np.full(P * R, ROWS[i]),
            *roller_columns(row),
            np.repeat(share, R),
            np.repeat(res.bearing_load[i], R),
            np.repeat(res.needle_load_max[i], R),
        ]
        for c, p in zip(cols, parts, strict=True):
            c.append(p)
    cols = [np.concatenate(c) for c in cols]
    header = [
        "crank_angle_deg",
        "row",
        *ROLLER_COLUMNS,
        "row_share",
        "bearing_load",
        "needle_load_max",
    ]
    fmts = ("%.6f", "%s", "%d", "%.6f") + ("%.9g",) * 9
    write_columns(ctx.out / "forces.csv", header, cols, fmts)
    rows = {}
    for i, row in enumerate(res.rows):
        summary = row.summary()
        summary["roller"] = 1
        summary["peak"] = force_peaks(row, s.design)
        share = res.row_a_share if i == 0 else 1.0 - res.row_a_share
        summary["share"] = _stats(share)
        summary["bearing_load_N"] = _stats(res.bearing_load[i])
        if res.bearings[i] is not None:
            summary["needle_load_max_N"] = _stats(res.needle_load_max[i])
            summary["bearing"] = res.bearings[i].as_dict()
        rows[ROWS[i]] = summary
    h = heavier_row(res)
    summary = {
        **model_description(s, ctx.results.bodies),
        "row_a_share": _stats(res.row_a_share),
        "heavier_row": ROWS[h],
        "rows": rows,
        "solver": {
            "success": res.success,
            "message": res.message,
            "iterations": res.iterations,
            "moment_residual": res.moment_residual,
            "positions": P,
            "full_cycle": s.solver.crank_angles_deg is None,
            "input_torque_Nmm": s.load.input_torque,
            "variants": list(s.solver.variants),
            "conventions": {
                "row A": "cam at the crank angle, its rollers in slots k",
                "row B": "cam at crank angle + 180 deg + cam_phase_error_deg, its rollers in "
                "the same slots; psi_deg is row B's own",
                "row_share": "share of the crank moment M0 carried by the row",
                "heavier_row": "the row with the larger peak gear force F_n (the console, "
                "manifest.json forces, forces.png and load_distribution.png show it)",
                "bearing_load": "radial load of the row's cam bearing, N (|sum F_j n_k|)",
                "needle_load_max": "largest needle load of the row's cam bearing, N "
                "(nan: no bearing, the cam is fixed)",
            },
        },
    }
    write_json(ctx.out / "forces_summary.json", summary)
    row = res.rows[h]
    other = f"row {ROWS[1 - h]}: peak $F_n$ {float(res.rows[1 - h].F_n.max()):.0f} N"
    plots.forces_png(
        row,
        ctx.out / "forces.png",
        s.design,
        s.load.input_torque,
        f"row {ROWS[h]}, the heavier ({other})",
    )
    at = int(np.unravel_index(np.argmax(row.F_n), row.F_n.shape)[0])
    plots.load_distribution_png(
        s.design,
        float(np.degrees(row.crank_angles[at])),  # the row's own cam angle (B: half a turn on)
        row.F_j[at],
        row.F_n[at],
        row.F_s[at],
        ctx.out / "load_distribution.png",
        s.load.input_torque,
        f" (row {ROWS[h]}, the heavier: peak $F_n$)",
    )
    ctx.files.extend(["forces.csv", "forces_summary.json", "forces.png", "load_distribution.png"])
    # The heavier row's figures where the one-row model has them (console, report), and the
    # drive's (both rows under "rows").
    ctx.manifest["forces"] = {
        **rows[ROWS[h]],
        **{k: v for k, v in summary.items() if k != "solver"},
    }


#: forces.csv's per-roller columns (:func:`roller_columns`), after the crank angle (and row).
ROLLER_COLUMNS = ("roller", "psi_deg", "F_j", "F_s", "F_n", "p_cam", "p_slot", "p_gear")


def roller_columns(res) -> list[np.ndarray]:
    """forces.csv's per-roller columns of one row, position-major: ``roller, psi_deg, F_j,
    F_s, F_n, p_cam, p_slot, p_gear``."""
    P, R = res.F_j.shape
    psi = np.degrees(np.mod(res.psi, 2 * np.pi))
    forces = (res.F_j, res.F_s, res.F_n, res.p_cam, res.p_slot, res.p_gear)
    return [np.tile(np.arange(1, R + 1), P), psi.ravel(), *(f.ravel() for f in forces)]
