"""Approximating an exact profile to a stated tolerance, and measuring it.

Three representations, as CAM and wire-EDM controllers want them:

``polyline``
    vertices on the exact curve, straight segments between them;
``arcs``
    tangent-continuous biarcs (two circular arcs per span, tangent to the
    exact curve at both ends), stored as LWPOLYLINE bulges;
``spline``
    one clamped cubic B-spline per tooth, interpolating the curve with the
    exact end tangents, joined into a single closed spline.

Nodes are refined adaptively on tooth 0 until every span is within the
tolerance; the other teeth are exact rotations. The reported
``max_deviation`` is *measured* afterwards, densely and in both directions
(exact curve to approximation, approximation to exact curve by projecting
onto the curve), never inferred from a step size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, make_interp_spline

from . import kinematics as kin
from .errors import ProfileError
from .profile import ProfileCurve, replicate_teeth

__all__ = [
    "REPRESENTATIONS",
    "ProfileApproximation",
    "approximate",
    "project_to_curve",
    "bulge_arc_points",
    "point_bulge_distance",
    "biarc",
]

REPRESENTATIONS = ("polyline", "arcs", "spline")
_REFINE_SAFETY = 0.7  # refine a span when its estimate exceeds this share of tol
_SPAN_SAMPLES = 12  # samples per span while refining
_MEASURE_SAMPLES = 40  # samples per span for the final measurement


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
        Measured maximum distance between approximation and exact curve.
    tolerance : float, mm
    spans_per_tooth : int
    """

    representation: str
    vertices: np.ndarray
    bulges: np.ndarray
    knots: np.ndarray | None
    max_deviation: float
    tolerance: float
    spans_per_tooth: int

    @property
    def entity_vertex_count(self) -> int:
        return int(len(self.vertices))

    def as_dict(self) -> dict:
        return {
            "representation": self.representation,
            "tolerance_mm": self.tolerance,
            "max_deviation_mm": self.max_deviation,
            "vertex_count": self.entity_vertex_count,
            "spans_per_tooth": self.spans_per_tooth,
        }


# --- geometry helpers --------------------------------------------------------
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def _point_segment_distance(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    den = np.maximum(_dot(ab, ab), 1e-300)
    u = np.clip(_dot(q - a, ab) / den, 0.0, 1.0)
    return np.linalg.norm(q - (a + u[..., None] * ab), axis=-1)


def _arc_geometry(a: np.ndarray, b: np.ndarray, bulge: np.ndarray):
    """Centre, signed radius and included angle of bulge arcs (arrays broadcast)."""
    theta = 4.0 * np.arctan(bulge)
    chord = b - a
    c = np.linalg.norm(chord, axis=-1)
    mid = 0.5 * (a + b)
    # Left normal of the chord; the centre is at distance h = c/2 * cot(theta/2)
    # on the left for a counter-clockwise (positive) arc.
    nrm = np.stack([-chord[..., 1], chord[..., 0]], axis=-1) / np.maximum(c, 1e-300)[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        h = 0.5 * c / np.tan(0.5 * theta)
        radius = 0.5 * c / np.sin(0.5 * theta)
    centre = mid + h[..., None] * nrm
    return centre, radius, theta


_STRAIGHT = 1e-9  # |bulge| below which an arc is treated as a segment


def point_bulge_distance(
    q: np.ndarray, a: np.ndarray, b: np.ndarray, bulge: np.ndarray
) -> np.ndarray:
    """Distance from points ``q`` to bulge segments ``a -> b`` (arrays broadcast), mm."""
    q, a, b = np.broadcast_arrays(q, a, b)
    bulge = np.broadcast_to(bulge, q.shape[:-1])
    out = _point_segment_distance(q, a, b)
    arc = np.abs(bulge) > _STRAIGHT
    if np.any(arc):
        qa, aa, ba, bu = q[arc], a[arc], b[arc], bulge[arc]
        centre, radius, theta = _arc_geometry(aa, ba, bu)
        va, vq = aa - centre, qa - centre
        # Angle swept from a to q in the arc's direction, within [0, theta]?
        ang = np.arctan2(_cross(va, vq), _dot(va, vq))
        ang = np.where(theta > 0, np.mod(ang, 2 * np.pi), -np.mod(-ang, 2 * np.pi))
        inside = np.abs(ang) <= np.abs(theta)
        d_arc = np.abs(np.linalg.norm(vq, axis=-1) - np.abs(radius))
        d_end = np.minimum(np.linalg.norm(qa - aa, axis=-1), np.linalg.norm(qa - ba, axis=-1))
        out[arc] = np.where(inside, d_arc, d_end)
    return out


def bulge_arc_points(a: np.ndarray, b: np.ndarray, bulge: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Points at fractions ``u`` (k,) along bulge segments (n,): (n, k, 2)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    bulge = np.asarray(bulge, dtype=float)
    u = np.asarray(u, dtype=float)
    lin = a[:, None, :] + u[None, :, None] * (b - a)[:, None, :]
    arc = np.abs(bulge) > _STRAIGHT
    if np.any(arc):
        centre, _, theta = _arc_geometry(a[arc], b[arc], bulge[arc])
        va = a[arc] - centre
        ang = theta[:, None] * u[None, :]
        c, s = np.cos(ang), np.sin(ang)
        rot = np.stack(
            [va[:, None, 0] * c - va[:, None, 1] * s, va[:, None, 0] * s + va[:, None, 1] * c],
            axis=-1,
        )
        lin[arc] = centre[:, None, :] + rot
    return lin


def biarc(
    p0: np.ndarray, t0: np.ndarray, p1: np.ndarray, t1: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Equal-parameter biarcs from (p0, unit tangent t0) to (p1, t1), vectorised.

    Returns the junction points (n, 2) and the bulges of the first and
    second arc (n,). Both arcs are tangent to the given tangents at the ends
    and to each other at the junction.
    """
    v = p1 - p0
    tt = t0 + t1
    vt = _dot(v, tt)
    vv = _dot(v, v)
    c = 1.0 - _dot(t0, t1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d_gen = (-vt + np.sqrt(vt * vt + 2.0 * c * vv)) / (2.0 * c)
        d_par = vv / (4.0 * _dot(v, t1))
    d = np.where(np.abs(c) > 1e-12, d_gen, d_par)
    junction = 0.5 * (p0 + d[:, None] * t0 + p1 - d[:, None] * t1)
    ch1 = junction - p0
    ch2 = p1 - junction
    half1 = np.arctan2(_cross(t0, ch1), _dot(t0, ch1))
    half2 = np.arctan2(_cross(ch2, t1), _dot(ch2, t1))
    return junction, np.tan(0.5 * half1), np.tan(0.5 * half2)


def project_to_curve(
    curve: ProfileCurve,
    q: np.ndarray,
    t0: np.ndarray,
    t_lo: float,
    t_hi: float,
    iterations: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest-point projection of ``q`` (n, 2) onto ``curve`` near parameters ``t0``.

    Newton on ``(C(t) - q) . C'(t) = 0``, clamped to ``[t_lo, t_hi]``.
    Returns ``(t, distance)``.
    """
    t = np.clip(np.asarray(t0, dtype=float), t_lo, t_hi)
    h = 1e-7 * max(1.0, t_hi - t_lo)
    for _ in range(iterations):
        c = curve.points(t)
        d1 = curve.derivative(t)
        d2 = (curve.derivative(t + h) - curve.derivative(t - h)) / (2 * h)
        diff = c - q
        f = _dot(diff, d1)
        fp = _dot(d1, d1) + _dot(diff, d2)
        fp = np.where(fp > 0, fp, _dot(d1, d1))
        step = f / np.maximum(fp, 1e-300)
        t = np.clip(t - step, t_lo, t_hi)
    return t, np.linalg.norm(curve.points(t) - q, axis=-1)


# --- the three representations -----------------------------------------------
def _unit_tangents(curve: ProfileCurve, t: np.ndarray) -> np.ndarray:
    d = curve.derivative(t)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _span_primitives(curve: ProfileCurve, t_nodes: np.ndarray, representation: str):
    """Vertices and bulges for spans between consecutive nodes of one piece."""
    p = curve.points(t_nodes)
    if representation == "polyline":
        return p[:-1], np.zeros(len(t_nodes) - 1), p
    tan = _unit_tangents(curve, t_nodes)
    junction, b1, b2 = biarc(p[:-1], tan[:-1], p[1:], tan[1:])
    verts = np.empty((2 * (len(t_nodes) - 1), 2))
    verts[0::2] = p[:-1]
    verts[1::2] = junction
    bulges = np.empty(2 * (len(t_nodes) - 1))
    bulges[0::2] = b1
    bulges[1::2] = b2
    return verts, bulges, p


def _golden_max(f, lo: np.ndarray, hi: np.ndarray, iters: int = 48) -> np.ndarray:
    """Vectorised golden-section search for the maximum of ``f`` on each ``[lo, hi]``."""
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    a, b = lo.astype(float), hi.astype(float)
    c = b - g * (b - a)
    d = a + g * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iters):
        left = fc >= fd
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        d_new = np.where(left, c, a + g * (b - a))
        c_new = np.where(left, b - g * (b - a), d)
        f_new = f(np.where(left, c_new, d_new))
        # Left: the old c becomes d, the new point is c. Right: old d becomes c.
        fc, fd = np.where(left, f_new, fd), np.where(left, fc, f_new)
        c, d = c_new, d_new
    return np.maximum(fc, fd)


def _max_per_span(f, n_span: int, m: int) -> np.ndarray:
    """Max over ``u`` in [0, 1] of ``f(span, u)`` per span: sampled, then refined."""
    u = np.linspace(0.0, 1.0, m + 1)
    span = np.repeat(np.arange(n_span), m + 1)
    vals = f(span, np.tile(u, n_span)).reshape(n_span, m + 1)
    best = vals.max(axis=1)
    # Refine only spans that could hold the maximum: between samples a smooth
    # distance can exceed its sampled peak by far less than 20 %.
    idx = np.flatnonzero(best >= 0.8 * best.max())
    k = np.argmax(vals[idx], axis=1)
    lo = u[np.maximum(k - 1, 0)]
    hi = u[np.minimum(k + 1, m)]
    refined = _golden_max(lambda x: f(idx, x), lo, hi)
    best[idx] = np.maximum(best[idx], refined)
    return best


def _bulge_distance_fn(curve: ProfileCurve, t_nodes: np.ndarray, verts, bulges):
    """f(span, u): distance from the exact curve at node interval ``span`` to its primitives."""
    n_span = len(t_nodes) - 1
    per_span = len(verts) // n_span
    closed = np.vstack([verts, curve.points(t_nodes[-1:])])
    dt = np.diff(t_nodes)

    def f(span, u):
        q = curve.points(t_nodes[span] + u * dt[span])
        best = np.full(q.shape[0], np.inf)
        for j in range(per_span):
            k = span * per_span + j
            best = np.minimum(best, point_bulge_distance(q, closed[k], closed[k + 1], bulges[k]))
        return best

    return f


def _bulge_span_error(
    curve: ProfileCurve, t_nodes: np.ndarray, verts: np.ndarray, bulges: np.ndarray, m: int
) -> np.ndarray:
    """Exact-to-approximation distance per span (max over m + 1 samples), mm."""
    f = _bulge_distance_fn(curve, t_nodes, verts, bulges)
    n_span = len(t_nodes) - 1
    u = np.linspace(0.0, 1.0, m + 1)
    span = np.repeat(np.arange(n_span), m + 1)
    return f(span, np.tile(u, n_span)).reshape(n_span, m + 1).max(axis=1)


def _piece_spline(curve: ProfileCurve, t_nodes: np.ndarray) -> BSpline:
    t_a, t_b = t_nodes[0], t_nodes[-1]
    d = curve.derivative(np.array([t_a, t_b]))
    return make_interp_spline(
        t_nodes, curve.points(t_nodes), k=3, bc_type=([(1, d[0])], [(1, d[1])])
    )


def _spline_span_error(curve: ProfileCurve, t_nodes: np.ndarray, spl: BSpline, m: int):
    u = (np.arange(m) + 0.5) / m
    ts = (t_nodes[:-1, None] + u[None, :] * np.diff(t_nodes)[:, None]).ravel()
    err = np.linalg.norm(spl(ts) - curve.points(ts), axis=-1)
    return err.reshape(len(t_nodes) - 1, m).max(axis=1)


def _refine(curve: ProfileCurve, representation: str, tol: float, max_rounds: int = 60):
    t_a, t_b = curve.piece_t_range
    t_nodes = np.linspace(t_a, t_b, 9)
    for _ in range(max_rounds):
        if representation == "spline":
            spl = _piece_spline(curve, t_nodes)
            err = _spline_span_error(curve, t_nodes, spl, _SPAN_SAMPLES)
        else:
            verts, bulges, _ = _span_primitives(curve, t_nodes, representation)
            err = _bulge_span_error(curve, t_nodes, verts, bulges, _SPAN_SAMPLES)
        bad = err > _REFINE_SAFETY * tol
        if not np.any(bad):
            return t_nodes
        mids = 0.5 * (t_nodes[:-1] + t_nodes[1:])[bad]
        t_nodes = np.sort(np.concatenate([t_nodes, mids]))
        if np.min(np.diff(t_nodes)) < 1e-13 * max(1.0, abs(t_b - t_a)):
            break
    raise ProfileError(
        f"tolerance = {tol:g} mm: cannot be reached for the {representation} representation "
        "(the profile is too sharp at the tooth tip; relax the tolerance or move away "
        "from the undercut limit)"
    )


def _measure_bulge(curve: ProfileCurve, t_nodes: np.ndarray, verts: np.ndarray, bulges):
    """Both-direction deviation of tooth 0's bulge spans, refined to the local maxima."""
    pad = 0.0 if curve.has_corners else 0.5 * (t_nodes[-1] - t_nodes[0])
    t_lo, t_hi = t_nodes[0] - pad, t_nodes[-1] + pad
    n_span = len(t_nodes) - 1
    per_span = len(verts) // n_span
    fwd = _max_per_span(_bulge_distance_fn(curve, t_nodes, verts, bulges), n_span, _MEASURE_SAMPLES)
    closed = np.vstack([verts, curve.points(t_nodes[-1:])])
    dt = np.diff(t_nodes)

    def back(seg, u):
        q = _points_on_bulges(closed[seg], closed[seg + 1], bulges[seg], u)
        node = seg // per_span
        frac = (seg % per_span + u) / per_span
        _, d = project_to_curve(curve, q, t_nodes[node] + frac * dt[node], t_lo, t_hi)
        return d

    bwd = _max_per_span(back, len(verts), _MEASURE_SAMPLES)
    return max(float(fwd.max()), float(bwd.max()))


def _points_on_bulges(a: np.ndarray, b: np.ndarray, bulge: np.ndarray, u: np.ndarray) -> np.ndarray:
    """One point per segment at its own fraction ``u`` (n,): (n, 2)."""
    out = a + u[:, None] * (b - a)
    arc = np.abs(bulge) > _STRAIGHT
    if np.any(arc):
        centre, _, theta = _arc_geometry(a[arc], b[arc], bulge[arc])
        va = a[arc] - centre
        ang = theta * u[arc]
        c, s = np.cos(ang), np.sin(ang)
        out[arc] = centre + np.stack([va[:, 0] * c - va[:, 1] * s, va[:, 0] * s + va[:, 1] * c], -1)
    return out


def _measure_spline(curve: ProfileCurve, t_nodes: np.ndarray, spl) -> float:
    dt = np.diff(t_nodes)

    def f(span, u):
        t = t_nodes[span] + u * dt[span]
        return np.linalg.norm(spl(t) - curve.points(t), axis=-1)

    return float(_max_per_span(f, len(t_nodes) - 1, _MEASURE_SAMPLES).max())


def approximate(curve: ProfileCurve, representation: str, tolerance: float) -> ProfileApproximation:
    """Approximate the closed ``curve`` within ``tolerance`` (mm) and measure the result.

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
    z = curve.tooth_count
    pitch = 2.0 * math.pi / z
    t_nodes = _refine(curve, representation, tolerance)
    n_span = len(t_nodes) - 1
    if representation == "spline":
        spl = _piece_spline(curve, t_nodes)
        dev = _measure_spline(curve, t_nodes, spl)
        knots, ctrl = _join_spline_pieces(spl, z, pitch)
        # The other teeth are rotations: check the joined spline there too.
        joined = BSpline(knots, ctrl, 3)
        span_len = t_nodes[-1] - t_nodes[0]
        u = np.linspace(0.0, 1.0, 8 * n_span + 1)
        ts = t_nodes[0] + u * span_len
        worst = 0.0
        for m in range(z):
            exact = curve.points(ts + m * pitch)
            worst = max(
                worst, float(np.linalg.norm(joined(ts + m * span_len) - exact, axis=-1).max())
            )
        dev = max(dev, worst)
        return ProfileApproximation(
            representation, ctrl, np.zeros(len(ctrl)), knots, dev, float(tolerance), n_span
        )
    verts, bulges, _ = _span_primitives(curve, t_nodes, representation)
    dev = _measure_bulge(curve, t_nodes, verts, bulges)
    all_verts = replicate_teeth(verts, z)
    # Rotated copies: their vertices must lie on the exact curve of their tooth.
    node_t = np.concatenate([t_nodes[:-1] + m * pitch for m in range(z)])
    step = len(verts) // n_span
    rot_err = np.linalg.norm(all_verts[::step] - curve.points(node_t), axis=-1).max()
    return ProfileApproximation(
        representation,
        all_verts,
        np.tile(bulges, z),
        None,
        dev + float(rot_err),  # rotated copies: their own float error on top
        float(tolerance),
        n_span,
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


def distance_to_curve(curve: ProfileCurve, q: np.ndarray, samples_per_tooth: int = 4000):
    """Distance from arbitrary points ``q`` (n, 2) to the closed exact ``curve``, mm.

    Seeds each point at the nearest of a dense sampling (k-d tree), then
    projects with Newton, clamped to the seed's tooth piece so that a trimmed
    (undercut) profile is never measured against its discarded swallowtail.
    Returns ``(distance, t)``.
    """
    from scipy.spatial import cKDTree

    q = np.asarray(q, dtype=float).reshape(-1, 2)
    z = curve.tooth_count
    pitch = 2.0 * math.pi / z
    t_a, t_b = curve.piece_t_range
    t_local = np.linspace(t_a, t_b, samples_per_tooth + 1)
    tooth = np.repeat(np.arange(z), t_local.size)
    t_all = np.tile(t_local, z) + tooth * pitch
    tree = cKDTree(curve.points(t_all))
    _, idx = tree.query(q)
    m = tooth[idx]
    t_seed = t_all[idx] - m * pitch
    # Project the points rotated back onto tooth 0.
    q0 = np.empty_like(q)
    for mm in np.unique(m):
        sel = m == mm
        q0[sel] = kin.rotate_by_polar_angle(q[sel], -mm * pitch)
    # A smooth profile continues into the next tooth; only a trimmed one stops.
    pad = 0.0 if curve.has_corners else 0.5 * pitch
    t, dist = project_to_curve(curve, q0, t_seed, t_a - pad, t_b + pad, iterations=12)
    return dist, t + m * pitch
