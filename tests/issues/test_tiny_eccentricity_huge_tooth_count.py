"""A tiny eccentricity (1e-6 mm) and a huge tooth count.

What could go wrong: moment arms of order e (1e-6 mm) make the forces for a
given torque enormous and the locus almost a circle (curvature 1/L plus
z^2 e terms); with z = 1000 the profile has 1000 lobes of micrometre height
and the per-tooth sampling must still close the contour within tolerance.
"""

import numpy as np

from corr_cad import GearDesign, approximate, working_profile
from corr_cad.mechanics.row.solver import solve_forces


def test_tiny_eccentricity():
    d = GearDesign(eccentricity=1e-6)
    res = solve_forces(d, 1e-3, positions=52)
    assert res.success and np.all(np.isfinite(res.F_j))
    np.testing.assert_allclose(np.sum(res.geometry.arm * res.F_j, axis=1), 0.55e-3, rtol=1e-9)
    a = approximate(working_profile(d), "arcs", 1e-3)
    assert a.max_deviation <= 1e-3


def test_huge_tooth_count():
    d = GearDesign(tooth_count=1000, cam_radius=300.0, roller_radius=0.8, eccentricity=0.05)
    res = solve_forces(d, 1e5, positions=1001)
    assert res.success and np.all(np.isfinite(res.F_j))
    assert res.positions_solved == 1
    for rep in ("polyline", "arcs", "spline"):
        a = approximate(working_profile(d), rep, 1e-3)
        assert a.max_deviation <= 1e-3 and np.all(np.isfinite(a.vertices))
