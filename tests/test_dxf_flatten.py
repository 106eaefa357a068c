"""Flattening a DXF contour: within the sagitta, and counted before a point is made."""

from __future__ import annotations

import math

import numpy as np
import pytest
from ezdxf.math import BSpline

from corr_cad.export.dxf_flatten import (
    FlatteningTooLarge,
    bulge_chord_counts,
    flatten_bulge_polygon,
    flatten_spline,
)


def _square_of_arcs(r: float, bulge: float) -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[r, 0.0], [0.0, r], [-r, 0.0], [0.0, -r]])
    return v, np.full(4, bulge)


@pytest.mark.parametrize("sagitta", [1e-2, 1e-4])
def test_a_circle_of_bulges_flattens_within_the_sagitta_with_the_counted_points(sagitta):
    v, b = _square_of_arcs(50.0, math.tan(math.pi / 8))  # four quarter arcs: a circle
    pts = flatten_bulge_polygon(v, b, sagitta, max_points=10**6)
    # hand count: a chord of angle step h has sagitta R (1 - cos(h / 2)) <= s
    step = 2 * math.acos(1 - sagitta / 50.0)
    assert len(pts) == 4 * math.ceil((math.pi / 2) / step)
    assert len(pts) == bulge_chord_counts(v, b, sagitta).sum()
    r = np.hypot(*pts.T)
    assert np.allclose(r, 50.0, atol=1e-9)  # the points lie on the arc
    mid = 0.5 * (pts + np.roll(pts, -1, axis=0))
    assert 50.0 - np.hypot(*mid.T).min() <= sagitta * (1 + 1e-9)  # the chords within s


def test_a_straight_polygon_of_many_vertices_is_read_as_it_is():
    v = np.random.default_rng(1).normal(size=(5000, 2))
    assert len(flatten_bulge_polygon(v, np.zeros(5000), 1e-4, max_points=100)) == 5000


def test_an_arc_of_1e9_mm_is_refused_by_its_count_before_a_point_is_made():
    v, b = _square_of_arcs(1e9, math.tan(math.pi / 8))
    with pytest.raises(FlatteningTooLarge) as err:
        flatten_bulge_polygon(v, b, 1e-4, max_points=4_000_000)
    # 4 quarter arcs at a step of 4 asin(sqrt(s / 2R)) ~ 8.9e-7 rad: 3.5 million points
    assert err.value.points == pytest.approx(2 * math.pi / (4 * math.sqrt(0.5e-4 / 1e9)), 1e-3)
    assert err.value.points > 4_000_000 or pytest.fail("should have fitted")


def _circle_spline(radius: float) -> BSpline:
    t = np.linspace(0.0, 2 * np.pi, 41)
    ctrl = [(radius * math.cos(a), radius * math.sin(a), 0.0) for a in t]
    ctrl[-1] = ctrl[0]
    return BSpline(ctrl, order=4)


@pytest.mark.parametrize("sagitta", [1e-2, 1e-4])
def test_a_spline_flattens_within_the_sagitta(sagitta):
    spline = _circle_spline(50.0)
    pts = flatten_spline(spline, sagitta, max_points=10**6)
    # the curve between neighbouring points, evaluated by ezdxf itself: within s of the chord
    dense = np.array([(p.x, p.y) for p in spline.flattening(sagitta / 100)])
    assert np.allclose(pts[0], dense[0]) and np.allclose(pts[-1], dense[-1])
    a, b = pts[:-1], pts[1:]
    d = b - a
    worst = 0.0
    for q in dense[:: max(1, len(dense) // 2000)]:  # its distance to the nearest chord
        u = np.clip(np.einsum("ij,ij->i", q - a, d) / np.einsum("ij,ij->i", d, d), 0, 1)
        worst = max(worst, float(np.hypot(*(a + u[:, None] * d - q).T).min()))
    assert worst <= sagitta


def test_a_spline_of_coordinates_1e15_is_refused_by_its_count():
    with pytest.raises(FlatteningTooLarge) as err:
        flatten_spline(_circle_spline(1e15), 1e-4, max_points=4_000_000)
    assert err.value.points > 1e9 and err.value.allowed == 4_000_000
