"""Circular-arc geometry: LWPOLYLINE bulge segments and biarcs.

A bulge segment from ``a`` to ``b`` is a circular arc whose included angle is
``4 atan(bulge)`` (positive: counter-clockwise), the DXF convention. A biarc
joins two points with given unit tangents by two arcs tangent to each other.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "bulge_arc_points",
    "point_bulge_distance",
    "points_on_bulges",
    "biarc",
    "biarc_with_ratio",
]


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


def _equal_leg(p0, t0, p1, t1):
    """Chord ``v``, ``|v|^2``, ``1 - t0.t1`` and the equal tangent-leg length ``d``."""
    v = p1 - p0
    tt = t0 + t1
    vt = _dot(v, tt)
    vv = _dot(v, v)
    c = 1.0 - _dot(t0, t1)
    with np.errstate(divide="ignore", invalid="ignore"):
        d_gen = (-vt + np.sqrt(vt * vt + 2.0 * c * vv)) / (2.0 * c)
        d_par = vv / (4.0 * _dot(v, t1))
    return v, vv, c, np.where(np.abs(c) > 1e-12, d_gen, d_par)


def _bulges(p0, t0, p1, t1, junction):
    """Junction and the bulges of the two arcs through it, tangent to t0 and t1."""
    ch1 = junction - p0
    ch2 = p1 - junction
    half1 = np.arctan2(_cross(t0, ch1), _dot(t0, ch1))
    half2 = np.arctan2(_cross(ch2, t1), _dot(ch2, t1))
    return junction, np.tan(0.5 * half1), np.tan(0.5 * half2)


def biarc(
    p0: np.ndarray, t0: np.ndarray, p1: np.ndarray, t1: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Equal-parameter biarcs from (p0, unit tangent t0) to (p1, t1), vectorised.

    Returns the junction points (n, 2) and the bulges of the first and
    second arc (n,). Both arcs are tangent to the given tangents at the ends
    and to each other at the junction.
    """
    *_, d = _equal_leg(p0, t0, p1, t1)
    junction = 0.5 * (p0 + d[:, None] * t0 + p1 - d[:, None] * t1)
    return _bulges(p0, t0, p1, t1, junction)


def biarc_with_ratio(
    p0: np.ndarray, t0: np.ndarray, p1: np.ndarray, t1: np.ndarray, ratio: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Biarcs with a free joint point: first tangent leg ``d1 = ratio * d``, vectorised.

    ``d`` is the equal-leg length of :func:`biarc`; ``ratio = 1`` gives the
    same biarc. The second leg follows from the tangency condition
    ``|p1 - d2 t1 - p0 - d1 t0| = d1 + d2``. Returns junctions and bulges as
    :func:`biarc` does; both arcs stay tangent to each other (G1).
    """
    v, vv, c, d = _equal_leg(p0, t0, p1, t1)
    d1 = ratio * d
    with np.errstate(divide="ignore", invalid="ignore"):
        d2 = (vv - 2.0 * d1 * _dot(v, t0)) / (2.0 * _dot(v, t1) + 2.0 * d1 * c)
    a = p0 + d1[:, None] * t0
    b = p1 - d2[:, None] * t1
    w = (d1 / (d1 + d2))[:, None]
    junction = a + w * (b - a)
    return _bulges(p0, t0, p1, t1, junction)


def points_on_bulges(a: np.ndarray, b: np.ndarray, bulge: np.ndarray, u: np.ndarray) -> np.ndarray:
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
