"""Working profile: envelope identities, independent checks, undercut."""

import dataclasses
import math

import numpy as np
import pytest
import shapely
from hypothesis import given
from shapely.geometry import LinearRing, LineString, Polygon

from corr_cad import (
    GearDesign,
    UndercutError,
    admissible_roller_radius,
    theoretical_profile,
    undercut_analysis,
    working_profile,
)
from corr_cad.geometry.kinematics import centre_distance_derivatives, locus_points
from corr_cad.geometry.sampling import distance_to_curve

from .strategies import designs


@given(designs())
def test_envelope_identity(design):
    # Every working point is exactly r from the locus along the locus normal, and
    # no locus point is closer than r: the roller disc touches, never cuts.
    w = working_profile(design)
    th = theoretical_profile(design)
    t = np.linspace(0, 2 * np.pi, 3001)
    q = w.points(t)
    p = th.points(t)
    np.testing.assert_allclose(np.linalg.norm(q - p, axis=1), design.roller_radius, rtol=1e-12)
    d, _ = distance_to_curve(th, q, samples_per_tooth=2000)
    np.testing.assert_allclose(d, design.roller_radius, rtol=1e-9)


@given(designs(max_teeth=40))
def test_theoretical_area_is_pi_L_squared(design):
    # Mean of s^2 over psi is L^2 exactly, so the locus encloses pi L^2.
    area = theoretical_profile(design).area()
    assert area == pytest.approx(math.pi * design.link_length**2, rel=1e-12)


def _buffer_exterior(design, n_per_tooth=800):
    th = theoretical_profile(design)
    ring = LinearRing(th.sample(n_per_tooth))
    return Polygon(shapely.buffer(ring, design.roller_radius, quad_segs=64).exterior)


@pytest.mark.parametrize(
    "kw",
    [{}, {"tooth_count": 11, "eccentricity": 2.0, "cam_radius": 60.0, "roller_radius": 5.0}],
)
def test_shapely_buffer_agrees_with_exact_offset(kw):
    design = GearDesign(**kw)
    w = working_profile(design)
    outer = _buffer_exterior(design)
    ring = np.asarray(outer.exterior.coords)[:-1]
    d, _ = distance_to_curve(w, ring)
    assert d.max() < 2e-4  # shapely's own chord/arc approximation
    assert outer.area == pytest.approx(w.area(), rel=2e-7)


def test_area_against_dense_polygon(prototype):
    w = working_profile(prototype)
    poly = Polygon(w.sample(20000))
    assert poly.is_valid
    assert poly.area == pytest.approx(w.area(), rel=1e-9)


def test_prototype_is_sharp_but_valid(prototype):
    info = undercut_analysis(prototype)
    assert not info.undercut
    # Tip radius of the working profile: |rho_locus| - r = 9.757 - 8.
    assert info.min_working_radius == pytest.approx(1.757, abs=1e-3)
    assert info.admissible_roller_radius == pytest.approx(10.053, abs=1e-3)


def _tip_residual(design_r, z, e, Rj):
    # Closed form at the tooth tip psi = pi: s^2 + r s - r s'' = 0.
    L = Rj + design_r
    s, _, d2s, _ = centre_distance_derivatives(np.pi, e, L)
    return s * s + design_r * s - design_r * z * z * d2s


@pytest.mark.parametrize("z,e,Rj", [(25, 3.5, 135.0), (11, 4.0, 60.0), (40, 1.5, 200.0)])
def test_admissible_radius_matches_tip_closed_form(z, e, Rj):
    r_adm = admissible_roller_radius(z, e, Rj)
    assert abs(_tip_residual(r_adm, z, e, Rj)) < 1e-9 * Rj**2


def _self_intersects(design) -> bool:
    # Two teeth of the raw (untrimmed) offset, densely sampled around a tip.
    w = dataclasses.replace(working_profile(dataclasses.replace(design, allow_undercut=True)))
    from corr_cad.geometry.profile import ProfileCurve

    raw = ProfileCurve(w.tooth_count, w.eccentricity, w.link_length, w.offset)
    t = np.linspace(0.0, 2 * 2 * np.pi / design.tooth_count, 200001)
    return not LineString(raw.points(t)).is_simple


@pytest.mark.parametrize("z,e,Rj", [(25, 3.5, 135.0), (11, 4.0, 60.0)])
def test_undercut_threshold_is_the_onset_of_self_intersection(z, e, Rj):
    r_adm = admissible_roller_radius(z, e, Rj)
    below = GearDesign(tooth_count=z, eccentricity=e, cam_radius=Rj, roller_radius=r_adm * 0.99)
    above = GearDesign(tooth_count=z, eccentricity=e, cam_radius=Rj, roller_radius=r_adm * 1.01)
    assert not _self_intersects(below)
    assert _self_intersects(above)
    working_profile(below)  # accepted
    with pytest.raises(UndercutError, match=r"undercut.*admissible roller radius") as exc:
        working_profile(above)
    assert f"{r_adm:.6g}" in str(exc.value)


def test_allowed_undercut_is_the_union_of_roller_discs():
    design = GearDesign(roller_radius=11.0, allow_undercut=True)
    info = undercut_analysis(design)
    assert info.undercut and info.trimmed_psi_deg is not None
    lo, hi = info.psi_range_deg
    assert lo < 180 < hi
    w = working_profile(design, info)
    assert w.has_corners
    outer = _buffer_exterior(design, n_per_tooth=1600)
    ring = np.asarray(outer.exterior.coords)[:-1]
    d, _ = distance_to_curve(w, ring)
    assert d.max() < 5e-4
    assert outer.area == pytest.approx(w.area(), rel=1e-6)
    # The trimmed curve is a simple closed contour.
    assert Polygon(w.sample(4000)).is_valid


def test_locus_points_radius(prototype):
    p = locus_points(np.array([0.0]), 25, 3.5, prototype.link_length)
    assert p[0, 1] == pytest.approx(146.5)


def test_no_undercut_radius_limit_when_tip_curvature_grows_with_r():
    # z = 11, e = 2, Rj = 60: the tip's radius of curvature grows faster than r,
    # so no roller radius undercuts (adjacent rollers collide first).
    assert admissible_roller_radius(11, 2.0, 60.0) == math.inf
    info = undercut_analysis(
        GearDesign(tooth_count=11, eccentricity=2.0, cam_radius=60.0, roller_radius=12.0)
    )
    assert not info.undercut
