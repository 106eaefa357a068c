"""A single loaded roller.

What could go wrong: with every roller but one in clearance the moment
balance has a single active term; the bracket must be found across a gap
much larger than the elastic approach, and Newton must not wander into the
clearance of the others.
"""

import numpy as np

from corr_cad import GearDesign
from corr_cad.geometry.deviations import ManufacturingErrors
from corr_cad.mechanics.row.solver import solve_forces


def test_all_but_one_roller_in_clearance():
    per = [-0.2] * 26  # 0.2 mm clearance: far beyond the elastic approach
    per[5] = 0.0
    res = solve_forces(
        GearDesign(),
        1.1e5,
        np.radians([330.0, 340.0]),  # roller 6 near its largest arm (psi ~ -90 deg)
        errors=ManufacturingErrors(roller_radius_errors=tuple(per)),
    )
    assert res.success
    assert np.all(res.loaded_count == 1)
    assert np.all(res.F_j[:, 5] > 0)
    np.testing.assert_allclose(res.geometry.arm[:, 5] * res.F_j[:, 5], 0.55 * 1.1e5, rtol=1e-10)
