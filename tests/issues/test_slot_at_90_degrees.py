"""A slot at exactly 90 degrees.

What went wrong in the paper: Eq. (14) projects the slot deflection with
tan(theta_i), which is infinite for the slot at 90 deg (and at 270 deg).
The vector form has no angle of the slot in it at all; with z = 3 there are
four slots, at 0, 90, 180 and 270 deg exactly.
"""

import math

import numpy as np

from corr_cad import GearDesign
from corr_cad.mechanics.row.solver import solve_forces


def test_four_slots_at_right_angles():
    d = GearDesign(tooth_count=3, cam_radius=40.0, roller_radius=3.0, eccentricity=0.4)
    assert d.slot_pitch_rad == math.pi / 2
    res = solve_forces(d, 1e4, np.radians([0.0, 30.0, 90.0, 200.0]))
    assert res.success
    assert np.all(np.isfinite(res.F_j)) and np.all(np.isfinite(res.F_s))
    np.testing.assert_allclose(np.sum(res.geometry.arm * res.F_j, axis=1), 0.55e4, rtol=1e-10)
