"""The working profile as STEP edges: cubic B-spline edges of a few knot spans each.

The ``spline`` approximation's spans (:func:`~corr_cad.geometry.sampling.spline_bezier_spans`)
are grouped, :data:`SPANS_PER_EDGE` at a time within a tooth, into edges that
share their end vertices; why so few per edge is in :mod:`corr_cad.export.step`.
"""

from __future__ import annotations

import numpy as np

from corr_cad.errors import ExportError
from corr_cad.geometry.sampling import (
    ProfileApproximation,
    spline_bezier_spans,
    spline_tooth_pieces,
)

__all__ = ["SPANS_PER_EDGE", "profile_edge_spans", "profile_edges"]

#: Knot spans of the profile's cubic B-spline per STEP edge (see the module's docstring).
SPANS_PER_EDGE = 3


def profile_edge_spans(approx: ProfileApproximation) -> list[tuple[int, int]]:
    """The profile's STEP edges as ranges ``[a, b)`` of its Bezier spans
    (:func:`~corr_cad.geometry.sampling.spline_bezier_spans`): :data:`SPANS_PER_EDGE`
    consecutive spans of one tooth each (a tooth's last edge shorter where its
    span count is not a multiple of it); every tooth a whole number of edges."""
    out, start = [], 0
    for knots, _ in spline_tooth_pieces(approx):
        count = len(np.unique(knots)) - 1
        out += [
            (start + a, start + min(a + SPANS_PER_EDGE, count))
            for a in range(0, count, SPANS_PER_EDGE)
        ]
        start += count
    return out


def profile_edges(approx: ProfileApproximation) -> list:
    """The closed profile's edges in order: cubic B-spline edges of
    :data:`SPANS_PER_EDGE` knot spans each, sharing vertices.

    Each edge is its tooth's B-spline cut at two of its knots (Open CASCADE's
    ``Segment``: knot insertion, the same cubic pieces), so its inner knots stay
    simple (C2, ``SPANS_PER_EDGE + 3`` poles).
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeVertex
    from OCP.Geom import Geom_BSplineCurve

    # OCP 8 moved the TColgp / TColStd arrays to OCP.OCP.collections.
    from OCP.OCP.collections import Array1_double, Array1_gp_Pnt, Array1_int

    spans, _ = spline_bezier_spans(approx)
    groups = profile_edge_spans(approx)
    if groups[-1][1] != len(spans):
        raise ExportError("STEP: the profile's teeth do not cover its spline's spans")
    n = len(groups)
    # Edge i ends where edge i + 1 starts: one vertex each, at the span's
    # start point (a tooth's first one its end control point, exactly).
    verts = [BRepBuilderAPI_MakeVertex(_pnt(spans[a, 0])).Vertex() for a, _ in groups]
    edges = []
    for knots, ctrl in spline_tooth_pieces(approx):
        values, mults = np.unique(knots, return_counts=True)
        poles = Array1_gp_Pnt(1, len(ctrl))
        for j, q in enumerate(ctrl):
            poles.SetValue(j + 1, _pnt(q))
        kk, mm = Array1_double(1, len(values)), Array1_int(1, len(values))
        for j, (k, m) in enumerate(zip(values, mults, strict=True)):
            kk.SetValue(j + 1, float(k))
            mm.SetValue(j + 1, int(m))
        tooth = Geom_BSplineCurve(poles, kk, mm, 3, False)
        count = len(values) - 1
        for a in range(0, count, SPANS_PER_EDGE):
            b = min(a + SPANS_PER_EDGE, count)
            curve = tooth.Copy()
            curve.Segment(float(values[a]), float(values[b]))
            i = len(edges)
            mk = BRepBuilderAPI_MakeEdge(curve, verts[i], verts[(i + 1) % n])
            if not mk.IsDone():
                raise ExportError(f"STEP: profile edge {i} could not be made")
            edges.append(mk.Edge())
    return edges


def _pnt(xy):
    from OCP.gp import gp_Pnt

    return gp_Pnt(float(xy[0]), float(xy[1]), 0.0)
