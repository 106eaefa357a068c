"""Approximating an exact profile to a stated tolerance, and measuring it.

Three representations, as CAM and wire-EDM controllers want them:

``polyline``
    vertices on the exact curve, straight segments between them, placed at
    equal sagitta: a segment of chord ``c`` on a stretch of radius of
    curvature ``R`` deviates by ``c^2 / (8 R)``, so the nodes are spaced to
    make that equal to the tolerance everywhere;
``arcs``
    tangent-continuous biarcs (two circular arcs per span, tangent to the
    exact curve at both ends and to each other: G1), stored as LWPOLYLINE
    bulges. Nodes are placed greedily, each span as long as the tolerance
    allows, and the joint point of each biarc is free (the split of the two
    tangent legs is chosen per span);
``spline``
    one clamped cubic B-spline per tooth, interpolating the curve with the
    exact end tangents, joined into a single closed spline.

Tooth 0 is approximated; the other teeth are exact rotations. The reported
``max_deviation`` is then **measured**, in both directions (exact curve to
export, export to exact curve), with the converged projection of
:mod:`corr_cad.geometry.measure`, never inferred from a step size. A span whose
measured deviation exceeds the tolerance is split and the whole tooth
measured again; if the tolerance still cannot be reached (a node budget or
float resolution is hit), the approximation is returned with its true
measured deviation and ``within_tolerance`` false, and the run fails
(exit 1) naming the file and the figure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

from corr_cad.errors import ProfileError
from corr_cad.geometry import kinematics as kin
from corr_cad.geometry.biarcs import (
    biarc,
    biarc_with_ratio,
    bulge_arc_points,
    point_bulge_distance,
    points_on_bulges,
)
from corr_cad.geometry.measure import DenseSampling, max_on_spans, project_points
from corr_cad.geometry.profile import ProfileCurve, replicate_teeth

__all__ = [
    "REPRESENTATIONS",
    "ProfileApproximation",
    "approximate",
    "project_to_curve",
    "distance_to_curve",
    "bulge_arc_points",
    "point_bulge_distance",
    "biarc",
]

REPRESENTATIONS = ("polyline", "arcs", "spline")
_SAGITTA_TARGET = 0.95  # polyline: aim the equal sagitta at this share of tol
_ARC_TARGET = 0.9  # arcs: greedy span length at this share of tol
_SPAN_SAMPLES = 8  # samples per span while placing nodes (the measurement decides)
_MEASURE_SAMPLES = 16  # samples per span / primitive for the final measurement
_REFINE_ROUNDS = 12  # measured-and-split rounds before giving up
_MAX_VERTICES = 200_000  # whole-contour budget: beyond it the run fails honestly
_JOINT_RATIOS = np.array([0.55, 0.7, 0.85, 1.0, 1.2, 1.45, 1.8])


@dataclass(frozen=True)
class ProfileApproximation:
    """A closed approximation of a :class:`ProfileCurve`.

    Attributes
    ----------
    representation : str
    vertices : (n, 2) float, mm
        Polyline / arcs: the closed LWPOLYLINE vertices (no repeated end).
        Spline: the control points (first equals last).
    bulges : (n,) float
        Bulge of the segment leaving each vertex (zeros for ``polyline``).
    knots : (m,) float or None
        Spline knot vector (clamped, degree 3).
    max_deviation : float, mm
        Measured two-way maximum distance between approximation and exact
        curve (the larger of the two directions below).
    tolerance : float, mm
    spans_per_tooth : int
    exact_to_export : float, mm
        Max over the exact curve of the distance to the approximation.
    export_to_exact : float, mm
        Max over the approximation of the distance to the exact curve.
    """

    representation: str
    vertices: np.ndarray
    bulges: np.ndarray
    knots: np.ndarray | None
    max_deviation: float
    tolerance: float
    spans_per_tooth: int
    exact_to_export: float = math.nan
    export_to_exact: float = math.nan

    @property
    def entity_vertex_count(self) -> int:
        return int(len(self.vertices))

    @property
    def within_tolerance(self) -> bool:
        return bool(self.max_deviation <= self.tolerance)

    def as_dict(self) -> dict:
        return {
            "representation": self.representation,
            "tolerance_mm": self.tolerance,
            "max_deviation_mm": self.max_deviation,
            "exact_to_export_mm": self.exact_to_export,
            "export_to_exact_mm": self.export_to_exact,
            "within_tolerance": self.within_tolerance,
            "vertex_count": self.entity_vertex_count,
            "spans_per_tooth": self.spans_per_tooth,
        }


# --- projection onto the exact curve -----------------------------------------
def _measure_range(curve: ProfileCurve) -> tuple[float, float]:
    """Parameter range around tooth 0 where its nearest points can lie."""
    t_a, t_b = curve.piece_t_range
    # A smooth profile continues into the next tooth; only a trimmed one stops.
    pad = 0.0 if curve.has_corners else 0.5 * (t_b - t_a)
    return t_a - pad, t_b + pad


def _dense(curve: ProfileCurve, n: int = 4096) -> DenseSampling:
    lo, hi = _measure_range(curve)
    return DenseSampling.build(curve.points, curve.derivative, lo, hi, n)


def project_to_curve(
    curve: ProfileCurve, q: np.ndarray, dense: DenseSampling | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest points of tooth 0's piece (padded by half a pitch if smooth) to ``q`` (n, 2).

    Converged, bracketed projection (see :mod:`corr_cad.geometry.measure`).
    Returns ``(t, distance)``.
    """
    dense = dense if dense is not None else _dense(curve)
    pr = project_points(curve.points, curve.derivative, dense, q)
    return pr.t, pr.distance


def distance_to_curve(curve: ProfileCurve, q: np.ndarray, samples_per_tooth: int = 4096):
    """Distance from arbitrary points ``q`` (n, 2) to the closed exact ``curve``, mm.

    Each point is rotated back onto tooth 0 by its polar angle and projected
    with the converged method; a trimmed (undercut) profile is never measured
    against its discarded swallowtail. Returns ``(distance, t)``.
    """
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    z = curve.tooth_count
    pitch = 2.0 * math.pi / z
    # Polar angle measured from +y, growing clockwise (as the curve's parameter);
    # tooth m's piece spans the polar angles (m -+ 1/2) pitch.
    polar = np.arctan2(q[:, 0], q[:, 1])
    m = np.floor(polar / pitch + 0.5).astype(int) % z
    q0 = np.empty_like(q)
    for mm in np.unique(m):
        sel = m == mm
        q0[sel] = kin.rotate_by_polar_angle(q[sel], -mm * pitch)
    dense = _dense(curve, samples_per_tooth)
    t, dist = project_to_curve(curve, q0, dense)
    return dist, t + m * pitch


# --- node placement ----------------------------------------------------------
def _unit_tangents(curve: ProfileCurve, t: np.ndarray) -> np.ndarray:
    d = curve.derivative(t)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _equal_sagitta_nodes(curve: ProfileCurve, tol: float, budget: int) -> np.ndarray:
    """Polyline nodes: chord c with c^2 / (8 R) = tol for the local radius R."""
    t_a, t_b = curve.piece_t_range
    t = np.linspace(t_a, t_b, 8193)
    speed = np.linalg.norm(curve.derivative(t), axis=-1)
    k = np.abs(curve.curvature(t))
    dens = np.sqrt(k / (8.0 * _SAGITTA_TARGET * tol)) * speed
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(t))])
    n = min(max(4, int(math.ceil(cum[-1]))), budget)
    return np.interp(np.linspace(0.0, cum[-1], n + 1), cum, t)


def _biarc_spans(curve: ProfileCurve, t0: np.ndarray, t1: np.ndarray, ratio: np.ndarray):
    p0, p1 = curve.points(t0), curve.points(t1)
    u0, u1 = _unit_tangents(curve, t0), _unit_tangents(curve, t1)
    j, b1, b2 = biarc_with_ratio(p0, u0, p1, u1, ratio)
    return p0, j, p1, b1, b2


def _biarc_error(curve, t0, t1, ratio, m=_SPAN_SAMPLES) -> np.ndarray:
    """Exact-curve-to-biarc distance of spans [t0, t1] (n,), max over m samples."""
    p0, j, p1, b1, b2 = _biarc_spans(curve, t0, t1, ratio)
    u = (np.arange(m) + 0.5) / m
    ts = t0[:, None] + u[None, :] * (t1 - t0)[:, None]
    q = curve.points(ts.ravel()).reshape(len(t0), m, 2)
    d1 = point_bulge_distance(q, p0[:, None], j[:, None], b1[:, None])
    d2 = point_bulge_distance(q, j[:, None], p1[:, None], b2[:, None])
    err = np.minimum(d1, d2).max(axis=1)
    return np.where(np.isfinite(err), err, np.inf)


def _best_ratio(curve, t0, t1):
    """Per span, the joint-point ratio with the smallest error, and that error."""
    n = len(t0)
    r = np.repeat(_JOINT_RATIOS[None, :], n, axis=0).ravel()
    e = _biarc_error(curve, np.repeat(t0, len(_JOINT_RATIOS)), np.repeat(t1, len(_JOINT_RATIOS)), r)
    e = e.reshape(n, -1)
    k = np.argmin(e, axis=1)
    return _JOINT_RATIOS[k], e[np.arange(n), k]


def _greedy_biarc_nodes(curve: ProfileCurve, tol: float, budget: int) -> np.ndarray:
    """Arcs nodes: from one end, each span as long as the tolerance allows.

    Past ``budget`` spans the rest of the piece is split evenly in parameter
    (the measurement then shows, and the run reports, what that reaches).
    """
    t_a, t_b = curve.piece_t_range
    target = _ARC_TARGET * tol
    nodes = [t_a]
    h = (t_b - t_a) / 16.0
    growth = 2.0 ** np.linspace(-6.0, 3.0, 37)
    while nodes[-1] < t_b:
        t0 = nodes[-1]
        if len(nodes) > budget:
            nodes.extend(np.linspace(t0, t_b, 3)[1:])
            break
        cand = np.minimum(t0 + h * growth, t_b)
        cand = np.unique(cand[cand > t0])
        _, err = _best_ratio(curve, np.full(cand.size, t0), cand)
        ok = err <= target
        if ok[-1] and cand[-1] >= t_b:
            nodes.append(t_b)
            break
        bad = np.flatnonzero(~ok)
        first_bad = bad[0] if bad.size else cand.size
        if first_bad == 0:
            # Even the shortest candidate fails: shrink the search scale.
            h *= 2.0**-6
            if h < 1e-14 * max(1.0, abs(t0)):
                nodes.append(min(t0 + 1e-9 * (t_b - t_a), t_b))
            continue
        good = cand[first_bad - 1]
        if first_bad < cand.size:
            fine = np.linspace(good, cand[first_bad], 18)[1:-1]
            _, err_f = _best_ratio(curve, np.full(fine.size, t0), fine)
            okf = err_f <= target
            nb = np.flatnonzero(~okf)
            n_ok = nb[0] if nb.size else fine.size
            if n_ok:
                good = fine[n_ok - 1]
        nodes.append(float(good))
        h = good - t0
    return np.array(nodes)


def _spline_nodes(curve: ProfileCurve, tol: float, budget: int, start: int = 9) -> np.ndarray:
    """Spline nodes by bisection, from ``start`` evenly spaced ones, until the
    parametric error is within 0.7 tol."""
    t_a, t_b = curve.piece_t_range
    t_nodes = np.linspace(t_a, t_b, start)
    for _ in range(60):
        spl = _piece_spline(curve, t_nodes)
        u = (np.arange(_SPAN_SAMPLES) + 0.5) / _SPAN_SAMPLES
        ts = (t_nodes[:-1, None] + u[None, :] * np.diff(t_nodes)[:, None]).ravel()
        err = np.linalg.norm(spl(ts) - curve.points(ts), axis=-1)
        err = err.reshape(len(t_nodes) - 1, -1).max(axis=1)
        bad = err > 0.7 * tol
        if not np.any(bad):
            break
        candidate = _split(t_nodes, bad)
        if len(candidate) - 1 > budget or np.min(np.diff(candidate)) < 1e-13 * (t_b - t_a):
            break
        t_nodes = candidate
    return t_nodes


def _split(t_nodes: np.ndarray, bad: np.ndarray) -> np.ndarray:
    mids = 0.5 * (t_nodes[:-1] + t_nodes[1:])[bad]
    return np.sort(np.concatenate([t_nodes, mids]))


def _piece_spline(curve: ProfileCurve, t_nodes: np.ndarray) -> BSpline:
    d = curve.derivative(np.array([t_nodes[0], t_nodes[-1]]))
    return make_interp_spline(
        t_nodes, curve.points(t_nodes), k=3, bc_type=([(1, d[0])], [(1, d[1])])
    )


# --- primitives and their measurement ----------------------------------------
def _bulge_primitives(curve: ProfileCurve, t_nodes: np.ndarray, representation: str, ratio):
    """Vertices and bulges of tooth 0 (the last node's point is the next tooth's first)."""
    p = curve.points(t_nodes)
    if representation == "polyline":
        return p[:-1], np.zeros(len(t_nodes) - 1)
    _, j, _, b1, b2 = _biarc_spans(curve, t_nodes[:-1], t_nodes[1:], ratio)
    verts = np.empty((2 * (len(t_nodes) - 1), 2))
    verts[0::2] = p[:-1]
    verts[1::2] = j
    bulges = np.empty(2 * (len(t_nodes) - 1))
    bulges[0::2] = b1
    bulges[1::2] = b2
    return verts, bulges


def _measure_bulge(curve, dense, t_nodes, verts, bulges):
    """Per node span: (exact -> export, export -> exact) maxima, mm."""
    n_span = len(t_nodes) - 1
    per_span = len(verts) // n_span
    closed = np.vstack([verts, curve.points(t_nodes[-1:])])
    dt = np.diff(t_nodes)

    def fwd(span, u):
        q = curve.points(t_nodes[span] + u * dt[span])
        best = np.full(q.shape[0], np.inf)
        for j in range(per_span):
            k = span * per_span + j
            best = np.minimum(best, point_bulge_distance(q, closed[k], closed[k + 1], bulges[k]))
        return best

    def bwd(seg, u):
        q = points_on_bulges(closed[seg], closed[seg + 1], bulges[seg], u)
        return project_points(curve.points, curve.derivative, dense, q).distance

    f = max_on_spans(fwd, n_span, _MEASURE_SAMPLES)
    b = max_on_spans(bwd, len(verts), _MEASURE_SAMPLES).reshape(n_span, per_span).max(axis=1)
    return f, b


def _measure_spline(curve, dense, t_nodes, spl):
    """Per node span: (exact -> spline, spline -> exact) maxima, mm."""
    dt = np.diff(t_nodes)
    dspl = spl.derivative()
    sdense = DenseSampling.build(spl, dspl, t_nodes[0], t_nodes[-1], dense.t.size - 1)

    def fwd(span, u):
        q = curve.points(t_nodes[span] + u * dt[span])
        return project_points(spl, dspl, sdense, q).distance

    def bwd(span, u):
        q = spl(t_nodes[span] + u * dt[span])
        return project_points(curve.points, curve.derivative, dense, q).distance

    n_span = len(t_nodes) - 1
    return max_on_spans(fwd, n_span, _MEASURE_SAMPLES), max_on_spans(bwd, n_span, _MEASURE_SAMPLES)


def approximate(curve: ProfileCurve, representation: str, tolerance: float) -> ProfileApproximation:
    """Approximate the closed ``curve`` within ``tolerance`` (mm) and measure the result.

    Spans whose measured deviation exceeds ``tolerance`` are split and the
    tooth measured again. If the tolerance cannot be reached, the result
    carries its true measured deviation and ``within_tolerance`` is False.

    ``representation`` is ``"polyline"``, ``"arcs"`` (tangent biarcs) or
    ``"spline"`` (one clamped cubic B-spline); ``max_deviation`` is measured,
    not estimated.

    >>> from corr_cad import GearDesign, working_profile, approximate
    >>> a = approximate(working_profile(GearDesign()), "arcs", 0.001)
    >>> a.max_deviation < 0.001
    True
    """
    if representation not in REPRESENTATIONS:
        raise ProfileError(
            f"representation = {representation!r}: must be one of {', '.join(REPRESENTATIONS)}"
        )
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance > 0):
        raise ProfileError(f"tolerance = {tolerance!r}: allowed range is (0, inf) mm")
    tol = float(tolerance)
    z = curve.tooth_count
    dense = _dense(curve)
    per_node = 1 if representation != "arcs" else 2
    budget = max(4, _MAX_VERTICES // (z * per_node))
    if representation == "polyline":
        t_nodes = _equal_sagitta_nodes(curve, tol, budget)
    elif representation == "arcs":
        t_nodes = _greedy_biarc_nodes(curve, tol, budget)
    else:
        t_nodes = _spline_nodes(curve, tol, budget)
    t_a, t_b = curve.piece_t_range
    min_step = 1e-13 * max(1.0, abs(t_b - t_a))
    for round_ in range(_REFINE_ROUNDS + 1):
        if representation == "spline":
            spl = _piece_spline(curve, t_nodes)
            f, b = _measure_spline(curve, dense, t_nodes, spl)
        else:
            ratio = (
                _best_ratio(curve, t_nodes[:-1], t_nodes[1:])[0]
                if representation == "arcs"
                else None
            )
            verts, bulges = _bulge_primitives(curve, t_nodes, representation, ratio)
            f, b = _measure_bulge(curve, dense, t_nodes, verts, bulges)
        bad = np.maximum(f, b) > tol
        if not np.any(bad) or round_ == _REFINE_ROUNDS:
            break
        candidate = _split(t_nodes, bad)
        if len(candidate) - 1 > budget or np.min(np.diff(candidate)) < min_step:
            break
        t_nodes = candidate
    n_span = len(t_nodes) - 1
    fwd_max, bwd_max = float(f.max()), float(b.max())
    if representation == "spline":
        return _spline_result(curve, t_nodes, spl, tol, fwd_max, bwd_max)
    all_verts = replicate_teeth(verts, z)
    # Rotated copies: their vertices must lie on the exact curve of their tooth.
    pitch = 2.0 * math.pi / z
    node_t = np.concatenate([t_nodes[:-1] + m * pitch for m in range(z)])
    rot_err = float(np.linalg.norm(all_verts[::per_node] - curve.points(node_t), axis=-1).max())
    return ProfileApproximation(
        representation,
        all_verts,
        np.tile(bulges, z),
        None,
        max(fwd_max, bwd_max) + rot_err,  # rotated copies: their own float error on top
        tol,
        n_span,
        fwd_max + rot_err,
        bwd_max + rot_err,
    )


def _spline_result(curve, t_nodes, spl, tol, fwd_max, bwd_max) -> ProfileApproximation:
    z = curve.tooth_count
    pitch = 2.0 * math.pi / z
    n_span = len(t_nodes) - 1
    knots, ctrl = _join_spline_pieces(spl, z, pitch)
    # The other teeth are rotations: their parametric distance from the
    # exact curve must equal tooth 0's up to float error.
    joined = BSpline(knots, ctrl, 3)
    span_len = t_nodes[-1] - t_nodes[0]
    ts = t_nodes[0] + np.linspace(0.0, 1.0, 8 * n_span + 1) * span_len
    ref = np.linalg.norm(spl(ts) - curve.points(ts), axis=-1)
    rot_err = 0.0
    for m in range(z):
        d = np.linalg.norm(joined(ts + m * span_len) - curve.points(ts + m * pitch), axis=-1)
        rot_err = max(rot_err, float(np.max(np.abs(d - ref))))
    return ProfileApproximation(
        "spline",
        ctrl,
        np.zeros(len(ctrl)),
        knots,
        max(fwd_max, bwd_max) + rot_err,
        tol,
        n_span,
        fwd_max + rot_err,
        bwd_max + rot_err,
    )


def _join_spline_pieces(spl: BSpline, z: int, pitch: float) -> tuple[np.ndarray, np.ndarray]:
    """Join z rotated copies of a clamped cubic piece into one closed clamped spline."""
    k = 3
    knots = spl.t
    ctrl = spl.c
    t_a, t_b = knots[0], knots[-1]
    span = t_b - t_a
    interior = knots[k + 1 : -(k + 1)]
    all_knots = [np.full(k + 1, t_a)]
    all_ctrl = [ctrl]
    for m in range(z):
        all_knots.append(interior + m * span)
        if m < z - 1:
            all_knots.append(np.full(k, t_b + m * span))
        if m > 0:
            all_ctrl.append(kin.rotate_by_polar_angle(ctrl[1:], m * pitch))
    all_knots.append(np.full(k + 1, t_a + z * span))
    c = np.vstack(all_ctrl)
    c[-1] = c[0]
    return np.concatenate(all_knots), c


# --- per-tooth and per-span pieces of a joined spline (CAD export) -----------
def spline_tooth_pieces(approx: ProfileApproximation) -> list[tuple[np.ndarray, np.ndarray]]:
    """Split a ``spline`` approximation at its tooth boundaries.

    The joined curve's knots of full multiplicity (the degree, 3) are where
    the curve passes through a control point: the joins between teeth.
    Returns one clamped cubic ``(knots (m,), control points (m - 4, 2))`` per
    tooth, in order; consecutive pieces share their end control point
    exactly (the same float values), so the chain is closed and C1 wherever
    the exact profile is smooth.
    """
    if approx.representation != "spline" or approx.knots is None:
        raise ProfileError(f"representation = {approx.representation!r}: not a spline")
    k = 3
    knots = np.asarray(approx.knots, dtype=float)
    ctrl = np.asarray(approx.vertices, dtype=float)
    values, first, counts = np.unique(knots, return_index=True, return_counts=True)
    joins = [i for i in range(len(values)) if counts[i] >= k]
    pieces = []
    for a, b in zip(joins[:-1], joins[1:], strict=True):
        start = 0 if a == 0 else first[a] - 1
        stop = len(ctrl) - 1 if b == len(values) - 1 else first[b] - 1
        inner = knots[first[a] + counts[a] : first[b]]
        piece_knots = np.concatenate([np.full(k + 1, values[a]), inner, np.full(k + 1, values[b])])
        pieces.append((piece_knots, ctrl[start : stop + 1]))
    return pieces


def spline_bezier_spans(approx: ProfileApproximation) -> tuple[np.ndarray, np.ndarray]:
    """The ``spline`` approximation as cubic Bezier spans, one per knot interval.

    Each span of a cubic B-spline is a cubic polynomial, so its Bezier form
    (``P0 = C(a)``, ``P1 = P0 + h C'(a) / 3``, ``P2 = P3 - h C'(b) / 3``,
    ``P3 = C(b)``, ``h = b - a``) is the same curve, not an approximation.
    Returns ``(control points (n, 4, 2), parameter intervals (n, 2))``;
    span ``i``'s ``P3`` is span ``i + 1``'s ``P0`` (the same floats), and the
    last span ends on the first one's start.
    """
    ctrl_out, params = [], []
    for knots, ctrl in spline_tooth_pieces(approx):
        spl = BSpline(knots, ctrl, 3)
        u = np.unique(knots)
        p = spl(u)
        p[0], p[-1] = ctrl[0], ctrl[-1]  # a clamped end is its control point, exactly
        d = spl.derivative()(u)
        h = np.diff(u)[:, None]
        seg = np.empty((len(u) - 1, 4, 2))
        seg[:, 0] = p[:-1]
        seg[:, 1] = p[:-1] + h * d[:-1] / 3.0
        seg[:, 2] = p[1:] - h * d[1:] / 3.0
        seg[:, 3] = p[1:]
        ctrl_out.append(seg)
        params.append(np.stack([u[:-1], u[1:]], axis=1))
    return np.concatenate(ctrl_out), np.concatenate(params)
