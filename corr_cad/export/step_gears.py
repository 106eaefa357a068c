"""STEP solids of the first gear stage's parts (Open CASCADE via OCP, an optional extra).

A part is a stack of extrusions, fused; a contour is a circle, a polyline or
a gear's outline (:class:`~corr_cad.geometry.gear_outline.GearSplines`),
whose fillets and involutes go in as B-spline edges and whose roots and tips
as exact circle edges. Written and read back by :mod:`corr_cad.export.step`.
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.errors import ExportError
from corr_cad.export.step import _circle_edge, _extrude, _pnt, _wire, require_ocp

__all__ = ["stacked_shape"]


def _polygon_wire(points: np.ndarray):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakePolygon

    mk = BRepBuilderAPI_MakePolygon()
    for x, y in np.asarray(points, dtype=float):
        mk.Add(_pnt(x, y))
    mk.Close()
    if not mk.IsDone():
        raise ExportError("STEP: could not close a polygon wire")
    return mk.Wire()


def _gear_spline_wire(gs):
    """A gear outline (:class:`~corr_cad.geometry.gear_outline.GearSplines`), tooth by tooth.

    Fillets and involutes are B-spline edges; the root and tip arcs are exact
    circle edges about the centre, each whole (the two half-arcs of a root or
    a tip, one at each end of a tooth's segments, joined). Neighbours share
    their end vertices.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeVertex
    from OCP.Geom import Geom_BSplineCurve, Geom_Circle
    from OCP.gp import gp_Ax2, gp_Dir
    from OCP.OCP.collections import Array1_double, Array1_gp_Pnt, Array1_int

    pitch = 2.0 * math.pi / gs.teeth
    curves = []  # (kind, poles or None for an arc) in outline order
    for k in range(gs.teeth):
        c, s = math.cos(k * pitch), math.sin(k * pitch)
        for kind, spl in zip(gs.kinds, gs.splines, strict=True):
            if spl is None:
                curves.append((kind, None, None))
                continue
            p = np.asarray(spl.c, dtype=float)
            # polar angles grow by k pitches: (x, y) -> (x c + y s, -x s + y c)
            poles = np.stack([p[:, 0] * c + p[:, 1] * s, -p[:, 0] * s + p[:, 1] * c], 1)
            curves.append((kind, poles, spl))
    # start on a B-spline; an arc (its two halves joined) runs from the end of
    # the spline before it to the start of the spline after it
    first = next(i for i, cv in enumerate(curves) if cv[1] is not None)
    curves = curves[first:] + curves[:first]
    pieces = []  # (kind, start point, poles of a B-spline or None for an arc, spline)
    for kind, poles, spl in curves:
        if poles is not None:
            pieces.append((kind, poles[0], poles, spl))
        elif pieces[-1][2] is not None:  # an arc's first half starts where a spline ends
            pieces.append((kind, pieces[-1][2][-1], None, None))
    starts = [BRepBuilderAPI_MakeVertex(_pnt(*p0)).Vertex() for _, p0, _, _ in pieces]
    edges = []
    for i, (kind, p0, poles, spl) in enumerate(pieces):
        v0, v1 = starts[i], starts[(i + 1) % len(pieces)]
        if poles is None:
            p1 = pieces[(i + 1) % len(pieces)][1]
            radius = 0.5 * (math.hypot(*p0) + math.hypot(*p1))
            # the short way from p0 to p1: anticlockwise about +z when their cross product is
            up = float(p0[0] * p1[1] - p0[1] * p1[0]) > 0.0
            circle = Geom_Circle(gp_Ax2(_pnt(0, 0), gp_Dir(0, 0, 1 if up else -1)), radius)
            mk = BRepBuilderAPI_MakeEdge(circle, v0, v1)
        else:
            knots, mults = np.unique(np.asarray(spl.t, dtype=float), return_counts=True)
            P, K, M = (
                Array1_gp_Pnt(1, len(poles)),
                Array1_double(1, len(knots)),
                Array1_int(1, len(knots)),
            )
            for j, q in enumerate(poles):
                P.SetValue(j + 1, _pnt(*q))
            for j, (kn, mu) in enumerate(zip(knots, mults, strict=True)):
                K.SetValue(j + 1, float(kn))
                M.SetValue(j + 1, int(mu))
            curve = Geom_BSplineCurve(P, K, M, int(spl.k), False)
            mk = BRepBuilderAPI_MakeEdge(curve, v0, v1)
        if not mk.IsDone():
            raise ExportError(f"STEP: gear outline {kind} edge {i} could not be made")
        edges.append(mk.Edge())
    return _wire(edges)


def stacked_shape(pieces: list):
    """A B-rep solid from ``[(outer, holes, height, z0), ...]`` extrusions (fused).

    A contour is a circle (its radius: an exact circle edge; an ``OffsetCircle``: the
    same about its centre), a polyline
    ((n, 2) array of vertices, straight edges) or a gear's
    :class:`~corr_cad.geometry.gear_outline.GearSplines` (B-spline edges).
    """
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf, gp_Vec

    require_ocp()

    def wire(c):
        if hasattr(c, "centre"):  # an eccentric circle (geometry.bearing_parts.OffsetCircle)
            return _wire([_circle_edge(c.radius, c.centre)])
        if isinstance(c, float):
            return _wire([_circle_edge(c)])
        if hasattr(c, "splines"):
            return _gear_spline_wire(c)
        return _polygon_wire(c)

    shape = None
    for outer, holes, height, z0 in pieces:
        prism = _extrude(wire(outer), [wire(h) for h in holes], height)
        if z0:
            tr = gp_Trsf()
            tr.SetTranslation(gp_Vec(0.0, 0.0, float(z0)))
            prism = BRepBuilderAPI_Transform(prism, tr, True).Shape()
        shape = prism if shape is None else BRepAlgoAPI_Fuse(shape, prism).Shape()
    return shape
