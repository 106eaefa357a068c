"""Sampling to a tolerance: stated tolerance met, measured deviation honest."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from corr_cad import ProfileError, approximate, theoretical_profile, working_profile
from corr_cad.geometry.sampling import biarc, bulge_arc_points, distance_to_curve

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


def test_projection_converges_at_a_sharp_tip():
    """z = 39, r = 5.35 (undercut limit 5.371, tip radius 0.02 mm): the curve speed
    at the tip is 0.4 % of its mean. Points on chords and on both sides of the curve
    project to the true distance (brute force on 2 million parameters)."""
    from corr_cad import GearDesign
    from corr_cad.geometry.sampling import project_to_curve

    d = GearDesign(tooth_count=39, cam_radius=150.0, eccentricity=3.0, roller_radius=5.35)
    w = working_profile(d)
    t_a, t_b = w.piece_t_range
    # Chords of the coarse uniform polyline (0.95 mm long near the tip) and
    # points pushed off the curve along its normal, tip included.
    tn = np.linspace(t_a, t_b, 40)
    p = w.points(tn)
    u = np.linspace(0, 1, 11)[1:-1]
    chords = (p[:-1, None] + u[None, :, None] * (p[1:] - p[:-1])[:, None]).reshape(-1, 2)
    ts = np.concatenate([np.linspace(t_a, t_b, 61), t_b - np.geomspace(1e-7, 1e-3, 20)])
    off = np.concatenate([w.points(ts) + s * w.normals(ts) for s in (-1e-3, 2e-4, 1e-3)])
    q = np.vstack([chords, off])
    t, dist = project_to_curve(w, q)
    fine = np.linspace(t_a - 0.5 * (t_b - t_a), t_b + 0.5 * (t_b - t_a), 2_000_001)
    dense = w.points(fine)
    from scipy.spatial import cKDTree

    _, j = cKDTree(dense).query(q)
    brute = np.full(len(q), np.inf)
    for s in (j - 1, j):
        a, b = dense[s], dense[s + 1]
        ab = b - a
        u = np.clip(np.sum((q - a) * ab, 1) / np.sum(ab * ab, 1), 0, 1)
        brute = np.minimum(brute, np.linalg.norm(q - a - u[:, None] * ab, axis=1))
    # Equal to brute force up to the fine polyline's sagitta (2e-9 mm at the tip).
    assert np.all(np.abs(brute - dist) <= 1e-8)
    # A point pushed along the normal by less than the radius of curvature
    # (0.02 mm at the tip) is exactly that far from the curve.
    n_off = len(ts)
    expect = np.repeat([1e-3, 2e-4, 1e-3], n_off)
    np.testing.assert_allclose(dist[len(chords) :], expect, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(w.points(t) - q, axis=1), dist, atol=1e-12)


def test_approximate_reports_failure_instead_of_raising(prototype, monkeypatch):
    """A tolerance the node budget cannot reach: the true measured value, flagged."""
    from corr_cad.geometry import sampling

    monkeypatch.setattr(sampling, "_MAX_VERTICES", 500)
    for rep in ("polyline", "arcs", "spline"):
        a = approximate(working_profile(prototype), rep, 1e-4)
        assert not a.within_tolerance and a.max_deviation > 1e-4
        assert a.as_dict()["within_tolerance"] is False
        assert len(a.vertices) <= 600
