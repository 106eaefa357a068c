"""The free interval's numpy search, as the drive solver used it before its compiled
solution (:mod:`corr_cad.mechanics.drive.free_play`): golden-section searches over the
polygon's horizontal slices and bisections for its ends; and a preloaded row's cam
centre by a Newton that kept every position iterating until the last settled
(``DriveSolver._row_centre`` before it stopped each at its own convergence). A reference for
``tests/test_free_play.py`` only; the package does not import it."""

from __future__ import annotations

import math

import numpy as np

from corr_cad.mechanics.drive.drive import DRIVE_RTOL
from corr_cad.mechanics.drive.drive_numerics import _forces_of

_FLAT = 1e-9


def free_row(a, g, n, half_clearance: float, e: float, want_centre: bool = False):
    """One row's free crank interval ``(rev, fwd)`` (P,) at no load, rad.

    Roller ``k`` stays clear while ``a_k tau + g_k + n_k . u <= 0``; the cam's
    centre may sit anywhere with ``|u| <= half_clearance``. Since ``a_k = e
    n_k,x``, with ``v = u + e tau x`` the rollers ask ``n_k . v <= -g_k`` (a
    convex polygon of ``v``) and the bearing ``|v - e tau x| <= Pd/2``, so

        e fwd = max over the polygon of v_x + sqrt((Pd/2)^2 - v_y^2)

    (and ``e rev`` the min of ``v_x - sqrt(...)``): concave in ``v_y``, found by
    golden-section searches over the polygon's horizontal slices. An empty
    interval (``rev > fwd``): the row is preloaded (no ``v`` leaves every roller
    clear). ``want_centre``: also the least-pressed ``v`` found, (P, 2), a start
    for the preloaded cam's own equilibrium.
    """
    up, down = a > 0, a < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -g / a
        fwd = np.min(np.where(up, t, np.inf), axis=1)
        rev = np.max(np.where(down, t, -np.inf), axis=1)
    if half_clearance == 0.0:
        return (rev, fwd, np.zeros((a.shape[0], 2))) if want_centre else (rev, fwd)
    c = half_clearance
    nx, ny = n[..., 0], n[..., 1]
    # A roller whose normal is (nearly) along the eccentric, psi = 0 or pi, bounds v_y only:
    # its slice bound -g / n_x would be a round-off quotient.
    right, left = nx > _FLAT, nx < -_FLAT
    flat = ~(right | left) & np.isfinite(g)

    def slice_at(y):
        """``(x_left, x_right, press)`` (P,) of the polygon's slice at ``v_y = y``."""
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = (-g - ny * y[:, None]) / nx
        xr = np.min(np.where(right, bound, np.inf), axis=1)
        xl = np.max(np.where(left, bound, -np.inf), axis=1)
        # How far a roller with no arm (psi = 0 or pi) is pressed: <= 0 to stay clear.
        press = np.max(np.where(flat, ny * y[:, None] + g, -np.inf), axis=1)
        return xl, xr, press

    def golden(fun, lo, hi, iterations=90):
        """Argmax of a concave ``fun`` on ``[lo, hi]`` (P,)."""
        ratio = 0.5 * (math.sqrt(5.0) - 1.0)
        x1, x2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        f1, f2 = fun(x1), fun(x2)
        for _ in range(iterations):
            left_better = f1 >= f2
            hi = np.where(left_better, x2, hi)
            lo = np.where(left_better, lo, x1)
            x2n = np.where(left_better, x1, lo + ratio * (hi - lo))
            x1n = np.where(left_better, hi - ratio * (hi - lo), x2)
            x1, x2 = x1n, x2n
            f1, f2 = fun(x1), fun(x2)
        return 0.5 * (lo + hi)

    def width(y):
        """Concave in ``y``; >= 0 where the slice is not empty."""
        xl, xr, press = slice_at(y)
        return np.minimum(np.minimum(xr - xl, 1e300), -press)

    P = a.shape[0]
    lo0, hi0 = np.full(P, -c), np.full(P, c)
    # Round-off allowance of the polygon: a nominal row pins v to one point.
    tol = 1e-12 * (c + np.max(np.where(np.isfinite(g), np.abs(g), 0.0), axis=1))
    y_mid = golden(width, lo0, hi0)
    feasible = width(y_mid) >= -tol

    def edge(inside, outside, iterations=80):
        for _ in range(iterations):
            mid = 0.5 * (inside + outside)
            ok = width(mid) >= -tol
            inside = np.where(ok, mid, inside)
            outside = np.where(ok, outside, mid)
        return inside

    y1, y2 = edge(y_mid, lo0), edge(y_mid, hi0)

    def reach(sense):
        def fun(y):
            xl, xr, _ = slice_at(y)
            arc = np.sqrt(np.maximum(c * c - y * y, 0.0))
            return (xr + arc) if sense > 0 else -(xl - arc)

        return sense * fun(golden(fun, y1, y2))

    e_fwd, e_rev = reach(1.0), reach(-1.0)
    fwd = np.where(feasible, e_fwd / e, -np.inf)
    rev = np.where(feasible, e_rev / e, np.inf)
    if want_centre:
        xl, xr, _ = slice_at(y_mid)
        mid = np.where(np.isfinite(xl + xr), 0.5 * (xl + xr), np.where(np.isfinite(xl), xl, xr))
        return rev, fwd, np.stack([np.where(np.isfinite(mid), mid, 0.0), y_mid], axis=1)
    return rev, fwd


def row_centre(self, c: int, idx: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Where row ``c``'s rollers hold its cam centre (``v``, (len(idx), 2)) at positions
    ``idx`` with no bearing load: ``sum_k F_k(g_k + n_k . v) n_k = 0``, by Newton
    with backtracking from ``v``."""
    R, geo = self.R, self.geo_joined
    sl = slice(c * R, (c + 1) * R)
    comp = self.comp.take(idx)
    g = np.where(geo.loadable, geo.gap, -1e300)[idx]
    n = self.n[idx]
    other = np.ones(2 * R, dtype=bool)
    other[sl] = False

    def residual(v):
        h = g + np.einsum("pkx,px->pk", n, v)
        h[:, other] = -1e300
        F, k = _forces_of(comp, h)
        r = np.einsum("pk,pkx->px", F, n)
        return r, F, k

    r, F, k = residual(v)
    for _ in range(100):
        scale = np.sum(F, axis=1) + 1e-300
        if np.all(np.linalg.norm(r, axis=1) <= DRIVE_RTOL * scale):
            break
        J = np.einsum("pk,pkx,pky->pxy", k, n, n)
        J += (1e-12 * np.trace(J, axis1=1, axis2=2) + 1e-9)[:, None, None] * np.eye(2)
        step = -np.linalg.solve(J, r[:, :, None])[:, :, 0]
        alpha = np.ones(len(idx))
        m0 = np.linalg.norm(r, axis=1)
        for _ in range(40):
            rt, Ft, kt = residual(v + alpha[:, None] * step)
            ok = np.linalg.norm(rt, axis=1) <= (1.0 - 1e-4 * alpha) * m0
            if np.all(ok):
                break
            alpha = np.where(ok, alpha, 0.5 * alpha)
        v = v + alpha[:, None] * step
        r, F, k = rt, Ft, kt
    return v
