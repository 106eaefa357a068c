"""Rated life under tolerances: L10 percentiles over the Monte Carlo's samples.

Each sample is the Monte Carlo's own (same seed, same draws:
:func:`corr_cad.tolerance.montecarlo.draw_samples`), solved by the windup's
force solver at the rated torque over one tooth pitch (every roller meets
every tooth) at ``positions_per_mesh``. Friction enters as on the nominal
design: the floating cam's spin (so the bearing's relative speed and the
cam raceway's) is the nominal design's at each position, and the
bearing's load is the sample's frictionless resultant ``|sum F_k n_k|``
times the nominal design's ratio of its friction-loaded to frictionless
bearing load at that position (about 1.03 with 0.05 everywhere). The
nominal design's draws (all zero) reproduce its life exactly.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from corr_cad.mechanics.efficiency import drive_friction, drive_life, row_loads_from_forces
from corr_cad.mechanics.friction import Friction, row_contacts
from corr_cad.mechanics.life import LifeSpec
from corr_cad.mechanics.windup import Windup, mesh_period_rad, result_period_rad
from corr_cad.tolerance.montecarlo import _errors_for, draw_samples

__all__ = ["life_samples", "life_percentiles"]


def _frictionless_bearing_load(design, res) -> np.ndarray:
    c = row_contacts(
        design.tooth_count,
        design.eccentricity,
        design.cam_radius,
        design.roller_radius,
        res.crank_angles,
        res.F_s,
    )
    return np.linalg.norm(np.einsum("pr,prx->px", res.F_j, -c.d[:, :, 0]), axis=1)


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
) -> dict[str, np.ndarray]:
    """L10 in hours of every component and the system for the first ``samples`` samples.

    ``draws``: the Monte Carlo's sample count (the draws are made for all
    of them, as the Monte Carlo makes them, and the first ``samples``
    used). Returns arrays (samples,) keyed like
    :func:`~corr_cad.mechanics.efficiency.drive_life`.
    """
    R = design.roller_count
    units = draw_samples(tolerances, draws or samples, seed, R)
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
    # The nominal design's friction: its cam spin and its bearing-load ratio at each position.
    nom = Windup(design, x, errors=base_errors, **common).forces(-rated_torque)
    fr_nom = drive_friction(design, [row_loads_from_forces(design, nom)], friction)[0]
    free = _frictionless_bearing_load(design, nom)
    ratio = np.where(free > 0.0, fr_nom.bearing_load / np.where(free > 0.0, free, 1.0), 1.0)
    out: dict[str, list[float]] = {}
    for k in range(samples):
        err = _errors_for(base_errors, tolerances, units, k)
        res = Windup(design, x, errors=err, **common).forces(-rated_torque)
        row = row_loads_from_forces(design, res)
        fr = replace(fr_nom, bearing_load=_frictionless_bearing_load(design, res) * ratio)
        lives = drive_life(
            design, [row] * rows, [fr] * rows, spec, friction.mounting, spec.rated_speed_rpm
        )
        for name, v in lives.items():
            out.setdefault(name, []).append(v)
    return {name: np.asarray(v) for name, v in out.items()}


def life_percentiles(lives: dict[str, np.ndarray], percentiles=(5, 50, 95)) -> dict:
    """Percentiles of each component's and the system's L10 (``None`` for an infinite one)."""

    def cell(v: float):
        return float(v) if math.isfinite(v) else None

    n = len(next(iter(lives.values())))
    return {
        "samples": n,
        "percentiles": list(percentiles),
        **{
            name: {f"p{q:g}": cell(np.percentile(v, q)) for q in percentiles}
            for name, v in lives.items()
        },
        "definition": "L10 at the rated torque and [life] rated_speed_rpm, hours, over the "
        "first samples of the Monte Carlo (same draws)",
    }
