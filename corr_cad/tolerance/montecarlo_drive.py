"""Monte Carlo of the two-row drive (``[solver] model = "drive"``): each row drawn on its own.

The draws of :func:`~corr_cad.tolerance.montecarlo.draw_samples` stay row
A's (and the frame's: slot angles, slot clearance; and cam B's phase against
cam A): seeded as before, so the same seed gives row A the same errors
whatever row B draws. Row B's own tolerances (cam radius, eccentricity,
roller radii) are drawn from a second generator seeded with ``[seed, 1]``.
Each sample is then solved by :class:`~corr_cad.mechanics.drive.DriveSolver`
at the Monte Carlo's crank positions, and keeps the four force metrics over
both rows (the drive's free rotation for the backlash).
"""

from __future__ import annotations

import numpy as np

from corr_cad.mechanics.drive import DriveSolver
from corr_cad.mechanics.solver import loaded_mask
from corr_cad.tolerance.checks import ARCMIN_PER_RAD

__all__ = ["ROW_B_KINDS", "ROW_B_STREAM", "row_b_tolerances", "drive_chunk", "drive_metrics"]

#: Tolerance kinds each row has of its own (drawn again for row B).
ROW_B_KINDS = ("cam_radius", "eccentricity", "roller_radius")
#: Row B's generator: ``numpy.random.default_rng([seed, ROW_B_STREAM])``.
ROW_B_STREAM = 1


def row_b_tolerances(tolerances: dict) -> dict:
    """The tolerances row B draws on its own."""
    return {k: v for k, v in tolerances.items() if k in ROW_B_KINDS}


def drive_metrics(res, interval: tuple[np.ndarray, np.ndarray], ratio: float) -> dict:
    """The four force metrics of one drive solution, over both rows (floats)."""
    p = [np.maximum(np.maximum(r.p_cam, r.p_slot), r.p_gear) for r in res.rows]
    loaded = [loaded_mask(r.F_j).sum(axis=1) for r in res.rows]
    rev, fwd = interval
    return {
        "peak_gear_force": float(res.F_n.max()),
        "peak_pressure": float(max(x.max() for x in p)),
        "min_loaded_rollers": float(min(x.min() for x in loaded)),
        "backlash_arcmin": float(np.max(fwd - rev) / ratio * ARCMIN_PER_RAD),
    }


def drive_chunk(
    design,
    input_torque,
    angles,
    base,
    base_b,
    tolerances,
    draws,
    draws_b,
    n,
    psi_limit,
    drive,
    errors_for,
):
    """Solve ``n`` samples of the drive (runs in a worker); returns ``(metrics, ok)``.

    ``errors_for(base, tolerances, draws, k)``: sample ``k``'s errors (the Monte
    Carlo's own mapping of draws to errors).
    """
    tol_b = row_b_tolerances(tolerances)
    names = ("peak_gear_force", "peak_pressure", "min_loaded_rollers", "backlash_arcmin")
    out = {k: np.empty(n) for k in names}
    ok = True
    ratio = float(design.roller_count)
    for k in range(n):
        ea = errors_for(base, tolerances, draws, k)
        eb = errors_for(base_b, tol_b, draws_b, k)
        solver = DriveSolver(
            design,
            angles,
            errors=ea,
            errors_b=eb,
            bearing=drive.get("bearing"),
            bearing_b=drive.get("bearing_b"),
            contact_model=drive.get("contact_model", "nonlinear"),
            psi_contact_limit=psi_limit,
        )
        res = solver.result(float(input_torque))
        ok &= bool(res.success)
        m = drive_metrics(res, solver.free_interval(), ratio)
        for name in names:
            out[name][k] = m[name]
    return out, ok
