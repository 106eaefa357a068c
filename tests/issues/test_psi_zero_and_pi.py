"""psi exactly 0 (tooth space) and pi (tooth tip).

What could go wrong: the moment arm, the slot force and the normal angle all
vanish there (sin psi = 0); a sine-rule form (paper Eq. 4) or an arctan
normal (Eq. 3) divides by them, and the tooth tip is where the working
profile is sharpest (largest curvature, 1/1.76 mm for the prototype).
"""

import math

import numpy as np

from corr_cad import GearDesign
from corr_cad.mechanics.row.solver import solve_forces


def test_rollers_exactly_at_tooth_space_and_tip():
    res = solve_forces(GearDesign(), 1.1e5, np.array([0.0, math.pi]))
    assert res.success and np.all(np.isfinite(res.F_j)) and np.all(np.isfinite(res.p_gear))
    # Roller 1 sits at psi = 0, then at psi = pi: no arm, so no load.
    assert res.F_j[0, 0] == 0.0 and res.F_j[1, 0] == 0.0
    assert res.F_s[0, 0] == 0.0
    np.testing.assert_allclose(res.geometry.rho_n[:, 0], 1.0, rtol=1e-15)
