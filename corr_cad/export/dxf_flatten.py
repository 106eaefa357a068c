"""Flattening a DXF contour's arcs and splines to points, bounded before it allocates.

A contour read back (a measured ring) is flattened to chords within a given
sagitta. How many points that takes is counted first, from the arcs' radii
and angles and from the splines' control points, and a contour that would
need more than ``max_points`` is refused (:class:`FlatteningTooLarge`)
before any point is made: 2,000 bulged vertices on a circle of 1e9 mm at a
sagitta of 0.1 um would need 7 million points, a spline with coordinates of
1e15 mm billions.

* an arc of radius ``R`` and angle ``theta`` takes ``ceil(theta / step)``
  chords, ``step = 2 acos(1 - s / R)``: each chord's sagitta is at most ``s``;
* a Bezier piece of degree ``p`` whose control points' second differences are
  at most ``D`` takes ``n = ceil(sqrt(p (p - 1) D / (8 s)))`` chords of equal
  parameter: the curve's second derivative is at most ``p (p - 1) D`` and a
  chord over a parameter step ``h`` deviates at most ``|C''| h^2 / 8``
  (Farin, *Curves and Surfaces for CAGD*, 5th ed., section 5.5; de Boor, *A
  Practical Guide to Splines*, 2001, chapter II).
"""

from __future__ import annotations

import math

import numpy as np

from corr_cad.errors import ExportError
from corr_cad.geometry.sampling import bulge_arc_points

__all__ = [
    "FlatteningTooLarge",
    "bulge_chord_counts",
    "flatten_bulge_polygon",
    "spline_chord_counts",
    "flatten_spline",
]

#: Points made at a time while flattening (the temporaries stay below ~40 MB).
_CHUNK_POINTS = 250_000


class FlatteningTooLarge(ExportError):
    """A contour would flatten to more points than allowed; ``points`` it would need."""

    def __init__(self, message: str, points: float, allowed: int) -> None:
        super().__init__(message)
        self.points = points
        self.allowed = allowed


def _refuse(what: str, points: float, allowed: int) -> None:
    raise FlatteningTooLarge(f"its {what} would flatten to {points:.3g} points", points, allowed)


def bulge_chord_counts(vertices: np.ndarray, bulges: np.ndarray, sagitta: float) -> np.ndarray:
    """Chords (float, possibly huge) of each segment of a closed bulge polygon (n, 2)."""
    a = np.asarray(vertices, dtype=float)
    b = np.roll(a, -1, axis=0)
    theta = np.abs(4.0 * np.arctan(np.asarray(bulges, dtype=float)))
    chord = np.hypot(*(b - a).T)
    arc = theta > 1e-12
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        radius = np.where(arc, chord / (2 * np.sin(theta / 2)), np.inf)
        # 2 acos(1 - x) = 4 asin(sqrt(x / 2)): exact where s / R is below the float step
        step = 4 * np.arcsin(np.sqrt(np.clip(0.5 * sagitta / radius, 0.0, 1.0)))
        counts = np.where(arc, np.ceil(theta / step), 1.0)
    counts[~np.isfinite(counts)] = np.inf
    return np.maximum(counts, 1.0)


def flatten_bulge_polygon(
    vertices: np.ndarray, bulges: np.ndarray, sagitta: float, max_points: int | None = None
) -> np.ndarray:
    """Closed bulge polygon to points (m, 2), every chord's sagitta below ``sagitta``.

    Refused (:class:`FlatteningTooLarge`) when its arcs would take it to more
    than ``max_points`` points (a straight polygon is its vertices, whatever
    their number); without a bound each arc takes at most 10,000.
    """
    counts = bulge_chord_counts(vertices, bulges, sagitta)
    total = float(counts.sum())
    if max_points is not None and total > max(max_points, len(counts)):
        _refuse(f"{len(counts)} bulged vertices", total, max_points)
    n_seg = np.clip(counts, 1, 10_000 if max_points is None else max_points).astype(np.int64)
    a = np.asarray(vertices, dtype=float)
    b = np.roll(a, -1, axis=0)
    bulges = np.asarray(bulges, dtype=float)
    out = np.empty((int(n_seg.sum()), 2))
    start = np.concatenate([[0], np.cumsum(n_seg)[:-1]])
    for n in np.unique(n_seg):
        sel = np.flatnonzero(n_seg == n)
        u = np.arange(n) / n
        per = max(1, _CHUNK_POINTS // int(n))
        for lo in range(0, len(sel), per):
            part = sel[lo : lo + per]
            pts = bulge_arc_points(a[part], b[part], bulges[part], u)
            rows = start[part, None] + np.arange(n)[None, :]
            out[rows.ravel()] = pts.reshape(-1, 2)
    return out


def _pieces(spline) -> tuple[list[np.ndarray], bool]:
    """Control points (k, 3) of the spline's Bezier pieces, or of its knot spans
    (weighted or unclamped splines: not decomposed; their bound uses the span's
    control points, times the weights' squared ratio and a margin of 4)."""
    if _decomposable(spline):
        return [
            np.asarray(list(piece), dtype=float) for piece in spline.bezier_decomposition()
        ], False
    p = spline.degree
    ctrl = np.asarray(spline.control_points, dtype=float)
    knots = np.asarray(spline.knots(), dtype=float)
    spans = [i for i in range(p, len(ctrl)) if knots[i + 1] > knots[i]]
    return [ctrl[i - p : i + 1] for i in spans], True


def _decomposable(spline) -> bool:
    return not spline.is_rational and spline.is_clamped


def spline_chord_counts(spline, sagitta: float) -> tuple[np.ndarray, bool]:
    """Chords (float) of each Bezier piece (or knot span) of an ezdxf ``BSpline``."""
    p = spline.degree
    pieces, by_span = _pieces(spline)
    ratio = 1.0
    if by_span:
        w = np.asarray(spline.weights(), dtype=float) if spline.is_rational else np.ones(1)
        ratio = 2.0 * (float(w.max() / w.min()) if w.size and w.min() > 0 else math.inf)
    counts = np.ones(len(pieces))
    if p < 2:
        return counts, by_span
    with np.errstate(over="ignore", invalid="ignore"):
        for i, c in enumerate(pieces):
            d2 = np.diff(c[:, :2], 2, axis=0)
            worst = float(np.max(np.hypot(d2[:, 0], d2[:, 1]))) if len(d2) else 0.0
            need = p * (p - 1) * worst * ratio**2 / (8.0 * sagitta)
            counts[i] = max(1.0, math.ceil(math.sqrt(need))) if math.isfinite(need) else math.inf
    return counts, by_span


def flatten_spline(spline, sagitta: float, max_points: int | None = None) -> np.ndarray:
    """Points (m, 2) of an ezdxf ``BSpline`` from its start to its end (both included),
    within ``sagitta``; refused (:class:`FlatteningTooLarge`) beyond ``max_points``."""
    counts, by_span = spline_chord_counts(spline, sagitta)
    total = float(counts.sum()) + 1
    if max_points is not None and total > max_points:
        _refuse(f"spline of {len(spline.control_points)} control points", total, max_points)
    counts = counts.astype(np.int64)
    if not by_span:
        out = [np.asarray(next(iter(spline.bezier_decomposition()))[0], dtype=float)[None, :2]]
        for n, piece in zip(counts, spline.bezier_decomposition(), strict=True):
            c = np.asarray(list(piece), dtype=float)[:, :2]
            out.append(_bezier(c, np.arange(1, n + 1) / n))
        return np.concatenate(out)
    knots = np.asarray(spline.knots(), dtype=float)
    p = spline.degree
    edges = np.unique(knots[p : len(knots) - p])
    params = [edges[:1]] + [
        np.linspace(t0, t1, int(n) + 1)[1:]
        for t0, t1, n in zip(edges[:-1], edges[1:], counts, strict=True)
    ]
    return np.array([(v.x, v.y) for v in spline.points(np.concatenate(params))], dtype=float)


def _bezier(ctrl: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Points of the Bezier curve with control points ``ctrl`` (p + 1, 2) at ``u`` (k,)."""
    p = len(ctrl) - 1
    k = np.arange(p + 1)
    binom = np.array([math.comb(p, int(i)) for i in k], dtype=float)
    basis = binom * u[:, None] ** k * (1.0 - u[:, None]) ** (p - k)
    return basis @ ctrl
