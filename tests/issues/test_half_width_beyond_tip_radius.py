"""Contact half-width larger than the tooth-tip radius.

What went wrong with the textbook form: delta = R - sqrt(R^2 - b^2) is NaN
for b > R. At huge loads b passes the tip radius (1.76 mm for the
prototype) and the roller radius; the approach continues along its tangent
(finite, increasing) and the contact is flagged instead.
"""

import numpy as np

from corr_cad import GearDesign
from corr_cad.mechanics.row.solver import solve_forces


def test_flagged_not_nan():
    res = solve_forces(GearDesign(), 1e12, positions=52)
    assert res.success
    for arr in (res.F_j, res.F_n, res.F_s, res.p_cam, res.p_gear, res.p_slot):
        assert np.all(np.isfinite(arr))
    assert not np.all(res.valid[res.F_j > 0])
    nominal = solve_forces(GearDesign(), 1.1e5, positions=52)
    assert np.all(nominal.valid)
