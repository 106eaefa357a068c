"""Converged point-to-curve projection and two-way deviation measurement.

The projection of a point ``q`` onto a parametric curve ``C(t)`` is the
minimiser of ``g(t) = |C(t) - q|^2``. It is found in three steps:

1. *Seed*: the nearest few samples of a dense sampling of the curve whose
   density follows arc length **and** turning angle, so that a sharp tooth
   tip (curve speed a fraction of a percent of its mean) is as densely
   sampled as a long flank.
2. *Bracket*: each seed's neighbouring samples bound the parameter.
3. *Safeguarded Newton* on ``f(t) = (C(t) - q) . C'(t)`` (half of ``g'``)
   inside the bracket, with the Gauss-Newton slope ``|C'|^2`` (the dropped
   term is distance x curvature x ``|C'|^2``, small next to it for points
   near the curve): a step that leaves the bracket is replaced by
   bisection; the bracket shrinks at every step (``rtsafe``). The
   iteration stops when the step is below ``1e-13`` of the bracket width.
   A point that has not converged after :data:`MAX_ITER` steps (never seen
   in practice) falls back to a dense sampling of its bracket.

The bracket ends are candidates too, so a point whose nearest curve point is
the end of a trimmed (undercut) piece is measured to that end.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["DenseSampling", "Projection", "dense_parameters", "project_points", "max_on_spans"]

MAX_ITER = 60
_STEP_TOL = 1e-13  # converged when |Newton step| < this share of the bracket
_FALLBACK_SAMPLES = 129


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def dense_parameters(
    points: Callable[[np.ndarray], np.ndarray],
    derivative: Callable[[np.ndarray], np.ndarray],
    t_lo: float,
    t_hi: float,
    n: int,
    fine: int = 16384,
) -> np.ndarray:
    """``n + 1`` parameters on ``[t_lo, t_hi]``, equally spaced in arc length + turning.

    The measure is ``ds + (S / pi) dtheta`` (``S`` the arc length of the
    range): half the samples or more follow length, the rest follow turning,
    so a tip that turns by nearly pi over a hundredth of a millimetre gets a
    share of the samples like a flank does.
    """
    t = np.linspace(t_lo, t_hi, fine + 1)
    d = derivative(t)
    speed = np.linalg.norm(d, axis=-1)
    ang = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    ds = 0.5 * (speed[1:] + speed[:-1]) * np.diff(t)
    dtheta = np.abs(np.diff(ang))
    length = float(ds.sum())
    m = np.concatenate([[0.0], np.cumsum(ds + (length / math.pi) * dtheta)])
    # Keep a floor of uniform-parameter density so no stretch is left empty.
    m = m / m[-1] + np.linspace(0.0, 0.05, m.size)
    target = np.linspace(m[0], m[-1], n + 1)
    return np.interp(target, m, t)


@dataclass(frozen=True)
class DenseSampling:
    """A dense sampling of a curve with its k-d tree, for seeding projections."""

    t: np.ndarray
    points: np.ndarray
    tree: object

    @classmethod
    def build(
        cls,
        points: Callable[[np.ndarray], np.ndarray],
        derivative: Callable[[np.ndarray], np.ndarray],
        t_lo: float,
        t_hi: float,
        n: int = 4096,
    ) -> DenseSampling:
        from scipy.spatial import cKDTree

        t = dense_parameters(points, derivative, t_lo, t_hi, n)
        p = points(t)
        return cls(t, p, cKDTree(p))


@dataclass(frozen=True)
class Projection:
    """Nearest points on a curve.

    Attributes
    ----------
    t : (n,) float
        Parameter of the nearest curve point.
    distance : (n,) float, mm
    converged : (n,) bool
        False only where the dense fallback was used.
    iterations : int
        Safeguarded-Newton iterations of the slowest point.
    """

    t: np.ndarray
    distance: np.ndarray
    converged: np.ndarray
    iterations: int


def _newton_in_bracket(points, derivative, q, lo, hi):
    """Safeguarded Newton for a root of f = (C - q) . C' with f(lo) < 0 < f(hi)."""
    t = 0.5 * (lo + hi)
    width0 = hi - lo
    active = np.ones(t.shape, dtype=bool)
    it = 0
    for it in range(1, MAX_ITER + 1):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            it -= 1
            break
        ti, qi = t[idx], q[idx]
        c = points(ti)
        d1 = derivative(ti)
        diff = c - qi
        f = _dot(diff, d1)
        neg = f < 0
        lo[idx] = np.where(neg, ti, lo[idx])
        hi[idx] = np.where(neg, hi[idx], ti)
        # Gauss-Newton slope |C'|^2: the dropped term (C - q) . C'' is the
        # distance times the curvature times |C'|^2, small for points near
        # the curve; the bracket keeps every step safe anyway.
        fp = _dot(d1, d1)
        with np.errstate(divide="ignore", invalid="ignore"):
            tn = ti - f / fp
        small = np.abs(tn - ti) <= _STEP_TOL * width0[idx]
        # A Newton step landing on or beyond the bracket is replaced by
        # bisection, unless it is already below the convergence threshold.
        bad = ~np.isfinite(tn) | (fp <= 0) | (tn <= lo[idx]) | (tn >= hi[idx])
        bad &= ~(small & (fp > 0))
        tn = np.where(bad, 0.5 * (lo[idx] + hi[idx]), tn)
        t[idx] = tn
        done = (~bad & small) | (f == 0) | (hi[idx] - lo[idx] <= _STEP_TOL * width0[idx])
        active[idx[done]] = False
    return t, ~active, it


def _project_brackets(points, derivative, q, a, b):
    """Minimise |C(t) - q| on each bracket [a, b]: ends and the interior root."""
    da = np.linalg.norm(points(a) - q, axis=-1)
    db = np.linalg.norm(points(b) - q, axis=-1)
    best_t = np.where(da <= db, a, b)
    best_d = np.minimum(da, db)
    fa = _dot(points(a) - q, derivative(a))
    fb = _dot(points(b) - q, derivative(b))
    root = (fa < 0) & (fb > 0)
    converged = np.ones(q.shape[0], dtype=bool)
    iters = 0
    if np.any(root):
        r = np.flatnonzero(root)
        t, ok, iters = _newton_in_bracket(points, derivative, q[r], a[r].copy(), b[r].copy())
        d = np.linalg.norm(points(t) - q[r], axis=-1)
        if not np.all(ok):
            # Dense fallback on the original bracket of the stragglers.
            s = np.flatnonzero(~ok)
            u = np.linspace(0.0, 1.0, _FALLBACK_SAMPLES)
            tt = a[r][s, None] + u[None, :] * (b[r] - a[r])[s, None]
            pts = points(tt.ravel()).reshape(len(s), -1, 2)
            dd = np.linalg.norm(pts - q[r][s, None, :], axis=-1)
            k = np.argmin(dd, axis=1)
            better = dd[np.arange(len(s)), k] < d[s]
            t[s] = np.where(better, tt[np.arange(len(s)), k], t[s])
            d[s] = np.minimum(d[s], dd[np.arange(len(s)), k])
            converged[r[s]] = False
        take = d < best_d[r]
        best_t[r] = np.where(take, t, best_t[r])
        best_d[r] = np.where(take, d, best_d[r])
    return best_t, best_d, converged, iters


def project_points(
    points: Callable[[np.ndarray], np.ndarray],
    derivative: Callable[[np.ndarray], np.ndarray],
    dense: DenseSampling,
    q: np.ndarray,
    seeds: int = 2,
) -> Projection:
    """Project ``q`` (n, 2) onto the curve sampled by ``dense``; see the module docstring."""
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    n = q.shape[0]
    k = min(seeds, dense.t.size)
    _, idx = dense.tree.query(q, k=k)
    idx = np.asarray(idx).reshape(n, k)
    last = dense.t.size - 1
    a = dense.t[np.maximum(idx - 1, 0)].ravel()
    b = dense.t[np.minimum(idx + 1, last)].ravel()
    qq = np.repeat(q, k, axis=0)
    t, d, conv, iters = _project_brackets(points, derivative, qq, a, b)
    d = d.reshape(n, k)
    j = np.argmin(d, axis=1)
    rows = np.arange(n)
    return Projection(t.reshape(n, k)[rows, j], d[rows, j], conv.reshape(n, k)[rows, j], int(iters))


def max_on_spans(
    f: Callable[[np.ndarray, np.ndarray], np.ndarray],
    n_span: int,
    m: int,
    rounds: int = 4,
) -> np.ndarray:
    """Max over ``u`` in [0, 1] of ``f(span, u)`` for each span: sampled, then refined.

    ``m + 1`` samples per span; every span whose sampled peak is within half
    of the largest is refined by successive parabolic interpolation through
    the best sample and its neighbours (the distance functions here are
    smooth, so a few rounds reach the peak to a tiny fraction of its value).
    Every value returned is a distance actually evaluated, never an
    extrapolation.
    """
    u = np.linspace(0.0, 1.0, m + 1)
    span = np.repeat(np.arange(n_span), m + 1)
    vals = f(span, np.tile(u, n_span)).reshape(n_span, m + 1)
    best = vals.max(axis=1)
    idx = np.flatnonzero(best >= 0.5 * best.max())
    if idx.size == 0 or m < 2:
        return best
    k = np.clip(np.argmax(vals[idx], axis=1), 1, m - 1)
    x0, x1, x2 = u[k - 1], u[k], u[k + 1]
    rows = np.arange(idx.size)
    y0, y1, y2 = vals[idx][rows, k - 1], vals[idx][rows, k], vals[idx][rows, k + 1]
    top = best[idx].copy()
    for _ in range(rounds):
        # Vertex of the parabola through the three points.
        num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
        den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
        with np.errstate(divide="ignore", invalid="ignore"):
            xv = x1 - 0.5 * num / den
        mid = np.where(y0 > y2, 0.5 * (x0 + x1), 0.5 * (x1 + x2))
        xv = np.where(np.isfinite(xv) & (xv > x0) & (xv < x2) & (xv != x1), xv, mid)
        yv = f(idx, xv)
        top = np.maximum(top, yv)
        # Keep the best point with its neighbours.
        left = xv < x1
        up = yv >= y1
        nx0 = np.where(left, np.where(up, x0, xv), np.where(up, x1, x0))
        nx1 = np.where(up, xv, x1)
        nx2 = np.where(left, np.where(up, x1, x2), np.where(up, x2, xv))
        ny0 = np.where(left, np.where(up, y0, yv), np.where(up, y1, y0))
        ny1 = np.where(up, yv, y1)
        ny2 = np.where(left, np.where(up, y1, y2), np.where(up, y2, yv))
        x0, x1, x2, y0, y1, y2 = nx0, nx1, nx2, ny0, ny1, ny2
    best[idx] = top
    return best
