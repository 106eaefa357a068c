"""Rated life under tolerances: L10 percentiles over the Monte Carlo's samples.

Each sample is the Monte Carlo's own (same seed, same draws:
:func:`corr_cad.tolerance.montecarlo.draw_samples`), solved by the windup's
force solver at the rated torque over one tooth pitch (every roller meets
every tooth) at ``positions_per_mesh``, as the datasheet rates the nominal
design (:func:`~corr_cad.mechanics.losses.efficiency.drive_life`): loads without
friction (the bearing's the sample's resultant ``|sum F_k n_k|``), speeds
from the rolling kinematics. The nominal design's draws (all zero)
reproduce its life exactly.

Under the drive (``[solver] model = "drive"``, ``drive`` given as the Monte
Carlo's): each sample's two rows are drawn as the drive's Monte Carlo draws
them (row A and the frame from the seed's stream, row B's own tolerances
from :data:`~corr_cad.tolerance.montecarlo_drive.ROW_B_STREAM`) and solved
together by :class:`~corr_cad.mechanics.drive.drive_windup.DriveWindup` at the
rated torque; each row's raceways are rated on its own forces and each
cam's bearing on the drive's ``bearing_load`` of that cam, as the drive's
datasheet rates the design (``friction_figures`` with ``rows_at``).
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.life import LifeSpec
from corr_cad.mechanics.losses.efficiency import (
    drive_life,
    row_loads_from_forces,
    rows_from_drive,
)
from corr_cad.mechanics.losses.friction import Friction
from corr_cad.mechanics.row.windup import Windup, mesh_period_rad, result_period_rad
from corr_cad.tolerance.montecarlo import _errors_for, draw_samples

__all__ = ["DRIVE_LIFE_SOURCE", "life_samples", "life_percentiles"]


def life_samples(
    design,
    base_errors,
    tolerances: dict,
    samples: int,
    seed: int,
    spec: LifeSpec,
    friction: Friction,
    rated_torque: float,
    *,
    load_share: float = 0.55,
    variants: tuple[str, ...] = (),
    psi_contact_limit: float = math.pi,
    positions_per_mesh: int = 4,
    draws: int | None = None,
    rows: int = 2,
    drive: dict | None = None,
    life_b: LifeSpec | None = None,
) -> dict[str, np.ndarray]:
    """L10 in hours of every component and the system for the first ``samples`` samples.

    ``draws``: the Monte Carlo's sample count (the draws are made for all
    of them, as the Monte Carlo makes them, and the first ``samples``
    used). Returns arrays (samples,) keyed like
    :func:`~corr_cad.mechanics.losses.efficiency.drive_life`. ``drive``: the drive
    Monte Carlo's argument (``errors_b``, ``bearing``, ``bearing_b``,
    ``contact_model``): both rows solved together (``load_share`` and
    ``rows`` unused); ``life_b`` rates row B's bearing (default ``spec``).
    """
    R = design.roller_count
    units = draw_samples(tolerances, draws or samples, seed, R)
    if drive is not None:
        return _drive_life_samples(
            design,
            base_errors,
            tolerances,
            units,
            samples,
            seed,
            spec,
            friction,
            rated_torque,
            variants=variants,
            psi_contact_limit=psi_contact_limit,
            positions_per_mesh=positions_per_mesh,
            draws=draws or samples,
            drive=drive,
            life_b=life_b,
        )
    first = _errors_for(base_errors, tolerances, units, 0)
    period = max(
        result_period_rad(design, first, variants), result_period_rad(design, base_errors, variants)
    )
    n = int(round(period / mesh_period_rad(design))) * positions_per_mesh
    x = period * np.arange(n) / n
    common = {
        "load_share": load_share,
        "variants": variants,
        "psi_contact_limit": psi_contact_limit,
    }
    out: dict[str, list[float]] = {}
    for k in range(samples):
        err = _errors_for(base_errors, tolerances, units, k)
        res = Windup(design, x, errors=err, **common).forces(-rated_torque)
        row = row_loads_from_forces(design, res)
        lives = drive_life(design, [row] * rows, spec, friction.mounting, spec.rated_speed_rpm)
        for name, v in lives.items():
            out.setdefault(name, []).append(v)
    return {name: np.asarray(v) for name, v in out.items()}


def _drive_life_samples(
    design,
    base_errors,
    tolerances: dict,
    units: dict,
    samples: int,
    seed: int,
    spec: LifeSpec,
    friction: Friction,
    rated_torque: float,
    *,
    variants: tuple[str, ...],
    psi_contact_limit: float,
    positions_per_mesh: int,
    draws: int,
    drive: dict,
    life_b: LifeSpec | None,
) -> dict[str, np.ndarray]:
    """:func:`life_samples` under the drive: both rows of each sample, row B's own draws."""
    from corr_cad.mechanics.drive.drive_windup import DriveWindup
    from corr_cad.tolerance.montecarlo_drive import ROW_B_STREAM, row_b_tolerances

    tol_b = row_b_tolerances(tolerances)
    units_b = draw_samples(tol_b, draws, seed, design.roller_count, stream=ROW_B_STREAM)
    base_b = drive.get("errors_b") or base_errors
    # The span of the nominal design's datasheet and of the first sample, both rows.
    firsts = (
        base_errors,
        base_b,
        _errors_for(base_errors, tolerances, units, 0),
        _errors_for(base_b, tol_b, units_b, 0),
    )
    period = max(result_period_rad(design, e, variants) for e in firsts)
    n = int(round(period / mesh_period_rad(design))) * positions_per_mesh
    x = period * np.arange(n) / n
    out: dict[str, list[float]] = {}
    for k in range(samples):
        dw = DriveWindup(
            design,
            x,
            errors=_errors_for(base_errors, tolerances, units, k),
            errors_b=_errors_for(base_b, tol_b, units_b, k),
            bearing=drive.get("bearing"),
            bearing_b=drive.get("bearing_b"),
            contact_model=drive.get("contact_model", "nonlinear"),
            variants=variants,
            psi_contact_limit=psi_contact_limit,
            crank=drive.get("crank"),
            bodies=drive.get("bodies"),
        )
        rows = rows_from_drive(design, dw.forces(-rated_torque))
        lives = drive_life(
            design, rows, spec, friction.mounting, spec.rated_speed_rpm, spec_b=life_b
        )
        for name, v in lives.items():
            out.setdefault(name, []).append(v)
    return {name: np.asarray(v) for name, v in out.items()}


#: ``life_h["model"]`` and its definition's tail under ``model = "drive"``.
DRIVE_LIFE_SOURCE = (
    "drive: both rows solved together per sample, row B's own tolerances drawn from its "
    "own stream; each cam's bearing rated on the drive's bearing_load of that cam"
)


def life_percentiles(
    lives: dict[str, np.ndarray], percentiles=(5, 50, 95), model: str = "paper"
) -> dict:
    """Percentiles of each component's and the system's L10 (``None`` for an infinite one).

    ``model = "drive"`` adds ``model`` and names the drive in the definition.
    """

    def cell(v: float):
        return float(v) if math.isfinite(v) else None

    n = len(next(iter(lives.values())))
    out = {
        "samples": n,
        "percentiles": list(percentiles),
        **{
            name: {f"p{q:g}": cell(np.percentile(v, q)) for q in percentiles}
            for name, v in lives.items()
        },
        "definition": "L10 at the rated torque and [life] rated_speed_rpm, hours, over the "
        "first samples of the Monte Carlo (same draws)",
    }
    if model == "drive":
        out["model"] = "drive"
        out["definition"] += "; " + DRIVE_LIFE_SOURCE
    return out
