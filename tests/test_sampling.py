"""Sampling to a tolerance: stated tolerance met, measured deviation honest."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from corr_cad import ProfileError, approximate, theoretical_profile, working_profile
from corr_cad.sampling import biarc, bulge_arc_points, distance_to_curve

from .strategies import designs


def _export_points(approx, per_span=24):
    """Dense points on the exported geometry, evaluated independently of the measurer."""
    if approx.representation == "spline":
        from scipy.interpolate import BSpline

        spl = BSpline(approx.knots, approx.vertices, 3)
        u = np.linspace(approx.knots[0], approx.knots[-1], 60 * len(approx.vertices))
        return spl(u)
    v = approx.vertices
    return bulge_arc_points(
        v, np.roll(v, -1, axis=0), approx.bulges, np.arange(per_span) / per_span
    ).reshape(-1, 2)


@pytest.mark.parametrize("representation", ["polyline", "arcs", "spline"])
@pytest.mark.parametrize("tol", [1e-2, 1e-3, 1e-4])
def test_tolerance_is_met_and_measurement_is_honest(prototype, representation, tol):
    curve = working_profile(prototype)
    a = approximate(curve, representation, tol)
    assert 0 < a.max_deviation <= tol
    # Independent check: distance of the export to the exact curve (k-d tree + Newton).
    d, _ = distance_to_curve(curve, _export_points(a))
    assert d.max() <= a.max_deviation * (1 + 1e-6) + 1e-12
    # The measurement is not a bound pulled from thin air: it is attained
    # (within the sampling of the independent check).
    assert d.max() >= 0.5 * a.max_deviation


@given(designs(max_teeth=30), st.sampled_from(["polyline", "arcs", "spline"]))
def test_tolerance_over_designs(design, representation):
    for curve in (working_profile(design), theoretical_profile(design)):
        a = approximate(curve, representation, 1e-3)
        assert a.max_deviation <= 1e-3
        assert np.all(np.isfinite(a.vertices))


def test_biarc_is_tangent_continuous():
    rng = np.random.default_rng(1)
    p0 = rng.normal(size=(50, 2))
    p1 = p0 + rng.normal(size=(50, 2))
    ang0 = np.arctan2(*(p1 - p0).T[::-1]) + rng.uniform(-0.6, 0.6, 50)
    ang1 = np.arctan2(*(p1 - p0).T[::-1]) + rng.uniform(-0.6, 0.6, 50)
    t0 = np.stack([np.cos(ang0), np.sin(ang0)], 1)
    t1 = np.stack([np.cos(ang1), np.sin(ang1)], 1)
    j, b1, b2 = biarc(p0, t0, p1, t1)
    eps = 1e-6
    a1 = bulge_arc_points(p0, j, b1, np.array([0.0, eps, 1 - eps, 1.0]))
    a2 = bulge_arc_points(j, p1, b2, np.array([0.0, eps, 1 - eps, 1.0]))

    def unit(v):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)

    np.testing.assert_allclose(unit(a1[:, 1] - a1[:, 0]), t0, atol=1e-5)
    np.testing.assert_allclose(unit(a2[:, 3] - a2[:, 2]), t1, atol=1e-5)
    np.testing.assert_allclose(unit(a1[:, 3] - a1[:, 2]), unit(a2[:, 1] - a2[:, 0]), atol=1e-5)
    np.testing.assert_allclose(a1[:, 3], a2[:, 0], atol=1e-12)


def test_bad_arguments(prototype):
    curve = working_profile(prototype)
    with pytest.raises(ProfileError, match="representation = 'nurbs'.*polyline, arcs, spline"):
        approximate(curve, "nurbs", 1e-3)
    for tol in (0.0, -1.0, float("nan")):
        with pytest.raises(ProfileError, match="tolerance"):
            approximate(curve, "polyline", tol)
