"""Conformal contact: the gear's concave radius close to the roller radius.

What could go wrong: with 1/R* = 1/r - 1/rho_w the effective radius grows
without bound as rho_w -> r, the Hertz half-width follows, and the overlap
formula's square roots go negative (NaN) once b passes a radius. Here the
tooth space is made sharp (large z e / L, small locus radius there) so that
the flank is nearly conformal; the contact must stay finite and be flagged
when it leaves the model's validity.
"""

import numpy as np

from corr_cad import GearDesign
from corr_cad.mechanics.row.solver import solve_forces


def test_nearly_conformal_tooth_space():
    d = GearDesign(tooth_count=40, cam_radius=60.0, roller_radius=2.0, eccentricity=1.5)
    res = solve_forces(d, 1e5, positions=410)
    k_gear = res.geometry.k_gear  # negative: concave, as seen from the roller
    ratio = -k_gear / res.geometry.k_roller  # roller radius / concave gear radius
    assert ratio.max() > 0.5  # the gear's concave radius within 2x the roller radius
    assert res.success and np.all(np.isfinite(res.p_gear)) and np.all(np.isfinite(res.F_n))
    big = solve_forces(d, 1e9, positions=410)
    assert big.success and np.all(np.isfinite(big.F_n))
    assert not np.all(big.valid_gear[big.F_j > 0])
